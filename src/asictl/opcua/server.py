"""The OPC UA server on a live board: the master, its slaves, flags, timers, counters and
the symbol table's names as variables an HMI or SCADA browses (docs/opcua.md).

It runs on the live board's own loop (``host.live.run_live``'s ``attach``), beside the
board's socket and, under ``gateway serve``, the Modbus gateway, so every value is read
from the board in this process: the status as ``asictl status`` reads it (host.status,
through the board's registers, with the program kept between refreshes as the monitor
keeps it) and each operand as the debugger reads it (observe.view.read_on_board). Every
``interval`` the values are read once and written to the address space, and only the ones
that changed: a subscription hears a change at that rate, however fast it asks.

Read-only unless ``writable``: then the flag bytes and bits, the emulated cable's slave
inputs and the master's Start and Stop methods change the board, exactly as
``asictl write``, ``asictl bus inputs`` and ``asictl start``/``stop`` do; a change of the
board's non-volatile state is saved before the write is answered (LiveBoard.save_changes).
A read-only variable's access level has no write bit, so a client's write is refused by
the server itself (BadUserAccessDenied). Anonymous clients are served only on a loopback
address; anywhere else a user and password are required (and then only they are
accepted). No session is ever given the administrator role, which would bypass the
access levels.
"""

from __future__ import annotations

import asyncio
import contextlib
import gc
import hmac
import inspect
import logging
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from dataclasses import dataclass, replace
from datetime import UTC
from typing import Any

from asyncua import ua
from asyncua.common.node import Node
from asyncua.crypto.permission_rules import User, UserRole
from asyncua.server.address_space import NodeData
from asyncua.server.internal_session import InternalSession
from asyncua.server.server import Server
from asyncua.ua.attribute_ids import AttributeIds
from asyncua.ua.status_codes import StatusCodes
from asyncua.ua.uaerrors._base import UaStatusCodeError

from asictl.errors import ExitCode, UserError
from asictl.host.emulated.actions import run_action
from asictl.host.live.board import LiveBoard
from asictl.host.live.status_reader import LiveStatus
from asictl.host.status import MasterStatus, StoredProgram
from asictl.host.transfer import set_start
from asictl.host.transports.target import is_loopback
from asictl.observe.operands import Operand, image_symbols, parse_operand
from asictl.observe.symbols import SymbolTable
from asictl.observe.view import host_write, read_on_board, wake
from asictl.opcua.limits import (
    DEFAULT_LOGIN_TIMEOUT_S,
    DEFAULT_MAX_CONNECTIONS,
    DEFAULT_MAX_SESSIONS,
    MAX_SESSION_TIMEOUT_S,
)
from asictl.opcua.standard_space import CachedStandardSpace
from asictl.platform import pc2
from asictl.platform.master import SLAVES

NAMESPACE = "urn:asictl:board"
DEFAULT_PORT = 4840
#: How often the values are read from the board (seconds): the rate subscriptions see.
DEFAULT_INTERVAL_S = 0.1
#: The slave addresses an address space shows (0 is a new slave's, never in a list).
SLAVE_ADDRESSES = range(1, SLAVES)
FLAG_BYTES = pc2.FLAGS_SIZE

V = ua.VariantType


@dataclass(frozen=True)
class OpcUaOptions:
    """Where and how to serve: ``host``:``port``, the refresh interval, whether clients may
    write, the user and password clients must give (None: anonymous, loopback only), the
    symbol table whose names become variables, and the limits on clients: connections,
    sessions, and the seconds a connection has to log in."""

    host: str = "127.0.0.1"
    port: int = DEFAULT_PORT
    writable: bool = False
    user: str | None = None
    password: str | None = None
    interval: float = DEFAULT_INTERVAL_S
    symbols: SymbolTable | None = None
    max_connections: int = DEFAULT_MAX_CONNECTIONS
    max_sessions: int = DEFAULT_MAX_SESSIONS
    login_timeout: float = DEFAULT_LOGIN_TIMEOUT_S

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"opc.tcp://{host}:{self.port}/asictl/"


def check_access(options: OpcUaOptions) -> None:
    """Refuse anonymous access beyond this machine, and half a login."""
    if (options.user is None) != (options.password is None):
        raise UserError("--opcua-user and its password go together (the password from "
                        "$ASICTL_OPCUA_PASSWORD)", ExitCode.USAGE)
    if options.user is None and not is_loopback(options.host):
        raise UserError(
            f"--opcua {options.host}:{options.port}: anonymous OPC UA clients are served on "
            "a loopback address only (127.0.0.1, ::1); give --opcua-user and "
            "$ASICTL_OPCUA_PASSWORD to serve other machines", ExitCode.USAGE,
        )


#: Failed logins a client (an address) may make before it must wait; each further one
#: doubles the wait, from LOGIN_WAIT_S up to LOGIN_WAIT_MAX_S.
LOGIN_FREE = 5
LOGIN_WAIT_S = 0.5
LOGIN_WAIT_MAX_S = 30.0
#: The clients whose failures are remembered at once (the oldest are forgotten first).
LOGIN_CLIENTS = 4096


class _Login:
    """asyncua's user manager: the one user and password, or anonymous where allowed;
    never the administrator role.

    Wrong passwords are rate-limited per client address: after ``LOGIN_FREE`` failures a
    client must wait (half a second, doubling with each further failure, at most 30 s)
    before its next attempt is even looked at; an attempt before then is refused as a
    wrong one is (BadUserAccessDenied), and a right one ends the wait. Refusing, rather
    than sleeping, keeps the one event loop every client shares free."""

    def __init__(self, user: str | None, password: str | None,
                 clock: Callable[[], float] | None = None) -> None:
        self.user, self.password = user, password
        self._clock = clock or time.monotonic
        #: client address -> (failures, the time before which it is refused)
        self._failures: dict[str, tuple[int, float]] = {}

    def get_user(
        self, iserver: Any, username: str | None = None, password: str | None = None,
        certificate: Any = None,
    ) -> User | None:
        if self.user is None:
            return User(role=UserRole.User)
        return self.check(_client_of_caller(), username, password)

    def check(self, client: str, username: str | None, password: str | None) -> User | None:
        """The user, if ``client`` may try now and the login is right."""
        now = self._clock()
        failures, until = self._failures.get(client, (0, 0.0))
        if now < until:
            return None
        if username is not None and password is not None and self.password is not None \
                and self.user is not None:
            given = (username.encode(), password.encode())
            if hmac.compare_digest(given[0], self.user.encode()) & hmac.compare_digest(
                given[1], self.password.encode()
            ):
                self._failures.pop(client, None)
                return User(role=UserRole.User, name=username)
        failures += 1
        wait = 0.0 if failures < LOGIN_FREE else min(
            LOGIN_WAIT_MAX_S, LOGIN_WAIT_S * 2 ** (failures - LOGIN_FREE))
        self._failures.pop(client, None)  # to the end: the newest
        self._failures[client] = (failures, now + wait)
        while len(self._failures) > LOGIN_CLIENTS:
            del self._failures[next(iter(self._failures))]
        return None


def _client_of_caller() -> str:
    """The address of the client whose session asks for a login: asyncua calls the user
    manager from the session's ``activate_session``, whose name is the client's peer
    name (host, port); the host alone is the client (each connection has a new port).
    '' where that cannot be seen (then all such clients share one limit)."""
    frame = inspect.currentframe()
    caller = frame.f_back.f_back if frame is not None and frame.f_back is not None else None
    session = caller.f_locals.get("self") if caller is not None else None
    name = getattr(session, "name", None)
    if isinstance(name, tuple) and name:
        return str(name[0])
    return ""


class BoardSpace:
    """The board's address space and its refresh."""

    def __init__(self, server: Server, live: LiveBoard, name: str, options: OpcUaOptions) -> None:
        self.server, self.live, self.options = server, live, options
        self.reader = LiveStatus(live, name)
        self.master = self.reader.master
        self.ns = 0
        #: node id -> (node, variant type, last value written)
        self.values: dict[str, tuple[Node, ua.VariantType, Any]] = {}
        self.symbols: dict[str, Operand] = {}
        self.timers: Node | None = None
        self.counters: Node | None = None
        #: True while the refresh writes: a setter then only stores the value
        self._refreshing = False

    def node_id(self, text: str) -> ua.NodeId:
        return ua.NodeId(ua.String(text), ua.Int16(self.ns))

    def browse_name(self, name: str) -> ua.QualifiedName:
        """A browse name in the board's namespace, as its node ids are: a client browsing
        by path (``0:Objects/2:Master/2:Phase``) names it so."""
        return ua.QualifiedName(name, self.ns)

    async def variable(
        self, parent: Node, key: str, name: str, value: Any, kind: ua.VariantType,
        write: Callable[[Any], None] | None = None,
    ) -> Node:
        node = await parent.add_variable(self.node_id(key), self.browse_name(name),
                                         ua.Variant(value, kind))
        self.values[key] = (node, kind, value)
        if write is not None and self.options.writable:
            await node.set_writable()
            self.server.set_attribute_value_setter(node.nodeid, self._setter(write))
        return node

    def _setter(self, write: Callable[[Any], None]) -> Callable[
        [NodeData, AttributeIds, ua.DataValue], None
    ]:
        def setter(node: NodeData, attr: AttributeIds, value: ua.DataValue) -> None:
            if not self._refreshing and value.Value is not None:
                # asyncua holds a write to the variable's type but not to its value
                # rank: an array of that type ([] too) is no value of a scalar
                if value.Value.is_array or isinstance(value.Value.Value, list):
                    raise _refused(StatusCodes.BadTypeMismatch)
                write(value.Value.Value)
                # stamped when the board took it (a client's own source timestamp
                # kept); in place, since asyncua hands this same value on to the
                # subscriptions after the setter
                now = ua.DateTime.now(UTC)
                value.SourceTimestamp = value.SourceTimestamp or now
                value.ServerTimestamp = now
            node.attributes[attr].value = value

        return setter

    async def build(self) -> None:
        server = self.server
        self.ns = await server.register_namespace(NAMESPACE)
        objects = server.nodes.objects
        status = self.read()
        master = await objects.add_object(self.node_id("Master"), self.browse_name("Master"))
        for key, name, kind in _MASTER:
            await self.variable(master, f"Master.{name}", name, _master_value(status, key), kind)
        if self.options.writable:
            await master.add_method(self.node_id("Master.Start"), self.browse_name("Start"),
                                    self._start, [], [])
            await master.add_method(self.node_id("Master.Stop"), self.browse_name("Stop"),
                                    self._stop, [], [])
        slaves = await objects.add_folder(self.node_id("Slaves"), self.browse_name("Slaves"))
        for address in SLAVE_ADDRESSES:
            slave = await slaves.add_object(self.node_id(f"Slave.{address}"),
                                            self.browse_name(f"Slave {address}"))
            for field, kind in _SLAVE:
                write = self._input_writer(address) if field == "Inputs" else None
                await self.variable(slave, f"Slave.{address}.{field}", field,
                                    _slave_value(status, address, field), kind, write)
        flags = await objects.add_folder(self.node_id("Flags"), self.browse_name("Flags"))
        for byte in range(FLAG_BYTES):
            node = await self.variable(flags, f"FY {byte}", f"FY {byte}", status.flags[byte],
                                       V.Byte, self._flag_writer(byte, None))
            for bit in range(8):
                await self.variable(node, f"F {byte}.{bit}", f"F {byte}.{bit}",
                                    bool(status.flags[byte] >> bit & 1), V.Boolean,
                                    self._flag_writer(byte, bit))
        self.timers = await objects.add_folder(self.node_id("Timers"), self.browse_name("Timers"))
        self.counters = await objects.add_folder(self.node_id("Counters"),
                                                 self.browse_name("Counters"))
        await self._timers_and_counters(status)
        # --opcua-symbols, else the table the download stored with the program
        table = self.options.symbols or image_symbols(self.program.image if self.program else None)
        if table:
            folder = await objects.add_folder(self.node_id("Symbols"),
                                              self.browse_name("Symbols"))
            for name, text in table.entries.values():
                operand = parse_operand(text)
                self.symbols[name] = operand
                await self.variable(folder, f"Symbol.{name}", name, self._symbol(operand),
                                    V.Boolean if operand.is_bit else V.Int32)

    def _symbol(self, operand: Operand) -> bool | int:
        """A symbol's value: a bit is a Boolean, as the flag bits are."""
        value = read_on_board(self.live.board, operand)
        return bool(value) if operand.is_bit else value

    @property
    def program(self) -> StoredProgram | None:
        return self.reader.program

    def read(self) -> MasterStatus:
        """The status now (the program re-read only when the board loaded another)."""
        return self.reader.read()

    async def _timers_and_counters(self, status: MasterStatus) -> None:
        assert self.timers is not None and self.counters is not None
        for timer in status.timers or []:
            key = f"T {timer.number}"
            if key not in self.values:
                await self.variable(self.timers, key, key, timer.remaining_ms, V.Int32)
                await self.variable(self.timers, f"{key}.Running", f"{key} running",
                                    timer.running, V.Boolean)
        for counter in status.counters or []:
            key = f"C {counter.number}"
            if key not in self.values:
                await self.variable(self.counters, key, key, counter.value, V.Int32)

    async def refresh(self) -> None:
        """Read the board once and write every value that changed; while a command holds
        the board (a download through the socket, say) the values stay as they were: the
        refresh's own host commands must not come between that command's requests."""
        if self.live.in_session():
            return
        self.live.sync()
        status = self.read()
        await self._timers_and_counters(status)
        now: dict[str, Any] = {}
        for key, name, _ in _MASTER:
            now[f"Master.{name}"] = _master_value(status, key)
        for address in SLAVE_ADDRESSES:
            for field, _ in _SLAVE:
                now[f"Slave.{address}.{field}"] = _slave_value(status, address, field)
        for byte, value in enumerate(status.flags):
            now[f"FY {byte}"] = value
            for bit in range(8):
                now[f"F {byte}.{bit}"] = bool(value >> bit & 1)
        for timer in status.timers or []:
            now[f"T {timer.number}"] = timer.remaining_ms
            now[f"T {timer.number}.Running"] = timer.running
        for counter in status.counters or []:
            now[f"C {counter.number}"] = counter.value
        for name, operand in self.symbols.items():
            now[f"Symbol.{name}"] = self._symbol(operand)
        read_at = ua.DateTime.now(UTC)  # the source timestamp of every value read above
        self._refreshing = True
        try:
            for key, value in now.items():
                node, kind, before = self.values[key]
                if value != before:
                    self.values[key] = (node, kind, value)
                    await self.server.write_attribute_value(node.nodeid, ua.DataValue(
                        ua.Variant(value, kind), SourceTimestamp=read_at,
                        ServerTimestamp=ua.DateTime.now(UTC),
                    ))
        finally:
            self._refreshing = False

    # -- writes (only with --opcua-writable)

    def _flag_writer(self, byte: int, bit: int | None) -> Callable[[Any], None]:
        def write(value: Any) -> None:
            board = self.live.board
            old = board.dpram_byte(pc2.FLAGS + byte)
            new = int(value) & 0xFF if bit is None else (
                old | 1 << bit if value else old & ~(1 << bit)
            )
            host_write(board, pc2.FLAGS + byte, new)
            wake(board)

        return write

    def _input_writer(self, address: int) -> Callable[[Any], None]:
        def write(value: Any) -> None:
            board = self.live.board
            if not board.bus.at(address):  # nothing on the cable there to deliver them
                raise _refused(StatusCodes.BadNotWritable)
            if not 0 <= int(value) <= 0xF:  # four input bits: 200 is no value of them
                raise _refused(StatusCodes.BadOutOfRange)
            run_action(board, "inputs", {"changes": [[address, 0xF, int(value) & 0xF]]})
            self._saved()

        return write

    def _saved(self) -> None:
        """A change of the non-volatile state is saved before it is acknowledged: the
        client hears of a failed save as a failed write or call."""
        if not self.live.save_changes():
            raise _refused(StatusCodes.BadResourceUnavailable)

    async def _start(self, parent: ua.NodeId, *arguments: ua.Variant
                     ) -> list[ua.Variant] | ua.StatusCode:
        return _answered(self._started, arguments)

    async def _stop(self, parent: ua.NodeId, *arguments: ua.Variant
                    ) -> list[ua.Variant] | ua.StatusCode:
        return _answered(self._stopped, arguments)

    def _started(self) -> None:
        if self.program is None or not self.program.info.valid:
            raise _refused(StatusCodes.BadInvalidState)  # as 'asictl start'
        set_start(self.master.transport, start=True)
        self._saved()

    def _stopped(self) -> None:
        set_start(self.master.transport, start=False)
        self._saved()


def _answered(action: Callable[[], None], arguments: tuple[ua.Variant, ...]
              ) -> list[ua.Variant] | ua.StatusCode:
    """A method's answer: asyncua answers every exception a method raises with
    BadUnexpectedError, but a status it returns is the call's status. Start and Stop
    take no argument: one is BadTooManyArguments (asyncua does not hold a call to the
    method's declared arguments); a program that cannot start BadInvalidState; a change
    not saved BadResourceUnavailable."""
    try:
        if arguments:
            raise _refused(StatusCodes.BadTooManyArguments)
        action()
    except UaStatusCodeError as exc:
        return ua.StatusCode(exc.code)
    return []


def _refused(code: int) -> Exception:
    """The error asyncua answers a write or call with ``code`` for (its constructor
    carries no type hints)."""
    return UaStatusCodeError(code)  # type: ignore[no-untyped-call]


#: (MasterStatus attribute, variable name, type)
_MASTER: tuple[tuple[str, str, ua.VariantType], ...] = (
    ("phase", "Phase", V.String),
    ("mode", "Mode", V.String),
    ("config_ok", "ConfigOk", V.Boolean),
    ("control_state", "ControlState", V.String),
    ("stop_reason", "StopReason", V.String),
    ("program_status", "ProgramStatus", V.String),
    ("program", "ProgramIdentity", V.String),
    ("start_flag", "StartFlag", V.Boolean),
    ("cycle_time_ms", "CycleTimeMs", V.Double),
    ("max_cycle_time_ms", "MaxCycleTimeMs", V.Double),
    ("stop_line", "StopLine", V.String),
    ("lps", "LPS", V.Byte),
    ("lds", "LDS", V.Byte),
    ("las", "LAS", V.Byte),
)
_SLAVE: tuple[tuple[str, ua.VariantType], ...] = (
    ("Lists", V.String),
    ("Inputs", V.Byte),
    ("Outputs", V.Byte),
    ("IoCode", V.Byte),
    ("IdCode", V.Byte),
    ("Parameter", V.Byte),
    ("ErrorCounter", V.UInt32),
)


def _master_value(status: MasterStatus, key: str) -> Any:
    value = getattr(status, key)
    if key == "program":
        return value.identity or ""
    if isinstance(value, list):
        return list(value)
    return "" if value is None else value


def _slave_value(status: MasterStatus, address: int, field: str) -> Any:
    slave = status.slaves.get(str(address))
    if field == "Lists":
        return [] if slave is None else list(slave.lists)
    if slave is None:
        return 0
    return {
        "Inputs": slave.inputs, "Outputs": slave.outputs, "IoCode": slave.pcd & 0xF,
        "IdCode": slave.pcd >> 4, "Parameter": slave.pp, "ErrorCounter": slave.errors or 0,
    }[field]


def _limit_clients(server: Server, options: OpcUaOptions) -> None:
    """No more than the options' connections and sessions, and no connection that has
    not logged in after ``login_timeout``: clients that connect and wait, or log in and
    vanish, cost a bounded number of descriptors, so the live board's own socket can
    always accept. Further connections are closed at once; a further session is refused
    with BadMaxConnectionsReached (asyncua counts sessions per process: there is one
    OPC UA server in it)."""
    server.iserver.max_connections = options.max_connections
    server.iserver.max_pending_activation_seconds = options.login_timeout
    server.iserver.max_session_timeout_ms = MAX_SESSION_TIMEOUT_S * 1000
    server.iserver.min_session_timeout_ms = min(
        server.iserver.min_session_timeout_ms, MAX_SESSION_TIMEOUT_S * 1000
    )
    InternalSession.max_connections = options.max_sessions


def opcua_attachment(
    options: OpcUaOptions, name: str, notify: Callable[[str], None],
    started: Callable[[str], None] | None = None,
) -> Callable[[LiveBoard], tuple[Awaitable[None], Callable[[], None]]]:
    """The OPC UA server for ``host.live.run_live``'s ``attach``; ``started(url)`` hears
    where it listens once it does."""

    def attach(live: LiveBoard) -> tuple[Awaitable[None], Callable[[], None]]:
        stop = asyncio.Event()
        return _serve(live, name, options, notify, stop, started), stop.set

    return attach


@contextlib.asynccontextmanager
async def _kept_for_good() -> AsyncIterator[None]:
    """The address space, built without the garbage collector and then frozen out of
    its reach: asyncua's standard nodes and the board's are some 650,000 objects the
    collector tracks, all living as long as the server; the collections that building
    them set off (each going through all built so far) took 40 to 50 % of the time to
    build them, and would go on visiting them in every full collection while serving
    (docs/performance.md). Building them leaves no garbage in cycles (none was found),
    so nothing is collected before freezing, which would cost a full collection."""
    collecting = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        if collecting:
            gc.enable()


async def _serve(
    live: LiveBoard, name: str, options: OpcUaOptions, notify: Callable[[str], None],
    stop: asyncio.Event, started: Callable[[str], None] | None,
) -> None:
    logging.getLogger("asyncua").setLevel(logging.CRITICAL)  # its tracebacks per bad client
    login = _Login(options.user, options.password)
    server = Server(iserver=CachedStandardSpace(user_manager=login))  # type: ignore[arg-type]
    space = BoardSpace(server, live, name, options)
    async with _kept_for_good():
        await server.init()
        await space.build()
    _limit_clients(server, options)
    server.set_endpoint(options.url)
    server.set_server_name(f"asictl board {name}")
    server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
    server.set_identity_tokens(
        [ua.UserNameIdentityToken] if options.user is not None else [ua.AnonymousIdentityToken]
    )
    await server.start()
    assert server.bserver is not None
    if started is not None:
        started(replace(options, port=server.bserver.port).url)
    try:
        while not stop.is_set():
            try:
                await space.refresh()
            except UserError as exc:  # a board that does not answer a refresh (in reset)
                notify(f"opcua: {exc}")
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(stop.wait(), options.interval)
    finally:
        await server.stop()
