"""What an HMI or historian relies on in ``serve --opcua``, asked of asyncua's own
client: every value update carries a source and a server timestamp (a change read from
the board and a client's write alike), a symbol that names a bit is a Boolean as the flag
bits are, and the board's browse names are in its own namespace, so a browse path
(``0:Objects/2:Master/2:Phase``) finds them."""

from __future__ import annotations

import asyncio
import subprocess
import sys
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path

import pytest
from asyncua import Client, ua
from asyncua.common.subscription import DataChangeNotif
from test_opcua import NAMESPACE, PROGRAM, asictl, node, served

V = ua.VariantType


@pytest.fixture(scope="module")
def board(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, str]]:
    """One writable board for the module, its state folder and URL: FY 12 = 42, timer 0
    running; the symbol table names a byte and two of its bits."""
    state = tmp_path_factory.mktemp("opcua_values")
    state.chmod(0o700)
    (state / "flag.asi").write_text(PROGRAM)
    (state / "flag.symbols.toml").write_text(
        'answer = "FY 12"\nbit_one = "F 12.1"\nbit_zero = "F 12.0"\n'
    )
    asictl(state, "download", str(state / "flag.asi"), "--start")
    with served(state, "serve", "--opcua-writable") as url:
        yield state, url


@pytest.fixture
def url(board: tuple[Path, str]) -> str:
    return board[1]


def utc(stamp: datetime | None) -> datetime:
    assert stamp is not None, "a value without this timestamp"
    return stamp if stamp.tzinfo is not None else stamp.replace(tzinfo=UTC)


def stamped_between(value: ua.DataValue, earliest: datetime, latest: datetime) -> None:
    """Both timestamps, the source no later than the server's, both within the times."""
    source, server = utc(value.SourceTimestamp), utc(value.ServerTimestamp)
    assert earliest <= source <= server <= latest, (earliest, source, server, latest)


async def heard_until(client: Client, key: str, wanted: int, change: object) -> list[ua.DataValue]:
    """The data values a subscription to ``key`` hears until it hears ``wanted``, after
    ``change`` (a callable, awaited or run in a thread) made the change."""
    ns = await client.get_namespace_index(NAMESPACE)
    heard: list[ua.DataValue] = []
    arrived = asyncio.Event()

    class Handler:
        def datachange_notification(self, _node: object, value: int,
                                    data: DataChangeNotif) -> None:
            heard.append(data.monitored_item.Value)
            if value == wanted:
                arrived.set()

    subscription = await client.create_subscription(50, Handler())
    await subscription.subscribe_data_change(node(client, ns, key))
    result = change()  # type: ignore[operator]
    if asyncio.iscoroutine(result):
        await result
    await asyncio.wait_for(arrived.wait(), 20)
    await subscription.delete()
    return heard


def test_a_change_read_from_the_board_carries_both_timestamps(board: tuple[Path, str]):
    state, url = board

    async def session() -> None:
        async with Client(url) as client:
            ns = await client.get_namespace_index(NAMESPACE)
            before = datetime.now(UTC)
            loop = asyncio.get_running_loop()

            def write() -> object:
                return loop.run_in_executor(None, lambda: asictl(state, "write", "FY 13=7"))

            heard = await heard_until(client, "FY 13", 7, write)
            after = datetime.now(UTC)
            stamped_between(heard[-1], before, after)
            stamped_between(await node(client, ns, "FY 13").read_data_value(), before, after)
            # the running timer changes at every refresh: its value is as new as it is
            first = await node(client, ns, "T 0").read_data_value()
            await asyncio.sleep(0.3)
            second = await node(client, ns, "T 0").read_data_value()
            assert utc(second.SourceTimestamp) > utc(first.SourceTimestamp)
            stamped_between(second, before, datetime.now(UTC))

    asyncio.run(session())


def test_a_clients_write_without_timestamps_is_heard_with_both(url: str):
    async def session() -> None:
        async with Client(url) as client:
            ns = await client.get_namespace_index(NAMESPACE)
            before = datetime.now(UTC)

            async def write() -> None:
                # a bare DataValue: the client gives neither timestamp
                await node(client, ns, "FY 20").write_value(ua.DataValue(ua.Variant(9, V.Byte)))

            heard = await heard_until(client, "FY 20", 9, write)
            assert heard[-1].Value is not None and heard[-1].Value.Value == 9
            stamped_between(heard[-1], before, datetime.now(UTC))

    asyncio.run(session())


def test_a_symbol_naming_a_bit_is_a_boolean_and_a_byte_an_integer(url: str):
    async def session() -> None:
        async with Client(url) as client:
            ns = await client.get_namespace_index(NAMESPACE)
            for key, kind, value in (("Symbol.bit_one", V.Boolean, True),  # 42 = 101010b
                                     ("Symbol.bit_zero", V.Boolean, False),
                                     ("Symbol.answer", V.Int32, 42),
                                     ("F 12.1", V.Boolean, True)):
                variable = node(client, ns, key)
                assert await variable.read_data_type_as_variant_type() is kind, key
                read = (await variable.read_data_value()).Value
                assert read is not None and read.VariantType is kind, key
                assert read.Value == value and type(read.Value) is type(value), key

    asyncio.run(session())


def test_browse_names_are_in_the_boards_namespace(url: str):
    async def session() -> None:
        async with Client(url) as client:
            namespaces = await client.get_namespace_array()
            assert namespaces.index(NAMESPACE) == 2
            root = client.nodes.root
            for path, key in ((["0:Objects", "2:Master", "2:Phase"], "Master.Phase"),
                              (["0:Objects", "2:Flags", "2:FY 12", "2:F 12.3"], "F 12.3"),
                              (["0:Objects", "2:Slaves", "2:Slave 1", "2:Inputs"],
                               "Slave.1.Inputs"),
                              (["0:Objects", "2:Symbols", "2:answer"], "Symbol.answer"),
                              (["0:Objects", "2:Timers", "2:T 0 running"], "T 0.Running"),
                              (["0:Objects", "2:Master", "2:Start"], "Master.Start")):
                found = await root.get_child(path)
                assert found.nodeid == ua.NodeId(key, 2), path
            assert await (await root.get_child(
                ["0:Objects", "2:Master", "2:Phase"])).read_value() == "normal operation"
            # and every name under the board's folders, not only those looked up
            board = [child for child in await client.nodes.objects.get_children()
                     if child.nodeid.NamespaceIndex == 2]
            assert len(board) == 6  # Master, Slaves, Flags, Timers, Counters, Symbols
            for parent in board:
                for child in [parent, *await parent.get_children()]:
                    assert (await child.read_browse_name()).NamespaceIndex == 2, child

    asyncio.run(session())
    # and as the finding was met: asyncua's own command-line reader, by browse path
    read = subprocess.run(
        [sys.executable, "-c", "from asyncua.tools import uaread; uaread()", "-u", url,
         "-p", "0:Objects,2:Master,2:Phase"], capture_output=True, text=True, timeout=60,
    )
    assert read.returncode == 0 and read.stdout.strip() == "normal operation", read
