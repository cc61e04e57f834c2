"""What the web server does to the live board: read its status, name operands, force,
write, start and stop, and the program's lines, each exactly as the command of that name
does it (host/: status, symbols, watch, forcing, commissioning, listing; observe.online).

Everything here runs on the live board's own loop, one request at a time, like a request
through the board's socket: nothing comes between a command's requests while a command
holds the board (``LiveBoard.in_session``): a read then answers the status last read, and
a write is refused (exit 1) instead of waiting, so HTTP never holds up the board.
"""

from __future__ import annotations

import base64
import os
import re
import tempfile
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from asictl.build import build_file
from asictl.errors import ExitCode, UserError
from asictl.host.commissioning import image_writes, write_flags
from asictl.host.connection import cable_setup_slaves
from asictl.host.force_list import forced_values
from asictl.host.forcing import force, unforce
from asictl.host.listing import listing_of
from asictl.host.live import requests
from asictl.host.live.board import LiveBoard
from asictl.host.live.status_reader import LiveStatus
from asictl.host.master import JSON
from asictl.host.program_files import uploaded_files
from asictl.host.status import MasterStatus
from asictl.host.symbols import Names
from asictl.host.transfer import StartMode, download, linked_for, set_start, upload
from asictl.host.watch import watch_list
from asictl.source import decode

#: Who the web page's changes are noted as (host.live.changes).
WEB_PAGE = "the web page"
#: The names a downloaded program's files may have (no folder, nothing hidden).
FILE_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,63}")


class LiveActions:
    """The emulated board's actions run on the live board as its socket runs them (a
    debugger holding the board refuses those that would run the program behind it)."""

    def __init__(self, live: LiveBoard) -> None:
        self._live = live

    @property
    def live(self) -> str:
        return "this process"

    def run(self, name: str, args: dict[str, JSON]) -> JSON:
        return requests.action(self._live, {"name": name, "args": args}, WEB_PAGE)

    def settle(self) -> None:
        """The live board runs by itself."""

    def wait_ms(self, ms: float) -> None:
        self._live.advance(ms)


class Busy(UserError):
    """A command holds the board through its socket (a download, say)."""

    exit_code = ExitCode.FAILED


class WebBoard:
    """The live board as the web server reaches it."""

    def __init__(self, live: LiveBoard, name: str) -> None:
        self.live, self.name = live, name
        self.reader = LiveStatus(live, name, LiveActions(live))
        self.master = self.reader.master
        self.last: MasterStatus | None = None
        self._changes_seen = live.changes.serial

    def changes(self) -> list[str]:
        """What clients changed on the board since the last call (host.live.changes)."""
        log = self.live.changes
        changes, self._changes_seen = log.since(self._changes_seen), log.serial
        return [f"{change.text} by {change.who}" for change in changes]

    def status(self) -> MasterStatus:
        """The status now, or while a command holds the board the one read last."""
        if self.live.in_session():
            if self.last is None:
                raise self._busy("reading the status")
            return self.last
        self.live.sync()
        self.last = self.reader.read()
        return self.last

    def _busy(self, what: str) -> Busy:
        return Busy(f"{self.name}: {what} must wait: another command holds the board "
                    "(try again when it is done)")

    def _names(self) -> Names:
        return Names(self.master, self.reader.stored_program().symbols)

    def operand(self, text: str) -> dict[str, Any]:
        """An operand by address or by name: what it is, its name, its value."""
        status = self.status()
        watched = watch_list(self._names(), [text])[0]
        return {"operand": watched.text, "symbol": watched.symbol,
                "value": watched.value(status)}

    def watch(self, status: MasterStatus, items: Sequence[str]) -> list[dict[str, Any]]:
        """The watch list's values in ``status``: per item its operand, name and value, or
        the error that item is."""
        names = self._names()
        rows: list[dict[str, Any]] = []
        for text in items:
            try:
                watched = watch_list(names, [text])[0]
                rows.append({"name": text, "operand": watched.text, "symbol": watched.symbol,
                             "value": watched.value(status)})
            except UserError as exc:
                rows.append({"name": text, "error": str(exc), "exit": int(exc.exit_code)})
        return rows

    def _changing(self, what: str) -> None:
        if self.live.in_session():
            raise self._busy(what)
        self.live.refuse_change(what)  # a debugger holds the master still
        self.live.sync()

    def _saved(self) -> None:
        """A change of the non-volatile state is saved before it is acknowledged."""
        if not self.live.save_changes():
            raise UserError(f"{self.name}: the change was made but cannot be saved: it is "
                            "lost if the board stops before a save succeeds", ExitCode.FAILED)

    def force(self, assignments: Sequence[str]) -> list[dict[str, Any]]:
        """``asictl force``: all or none; the force list after it."""
        self._changing("forcing")
        names = self._names()
        parsed = [names.assignment(text, example="F 10.0=1") for text in assignments]
        entries = force(self.master, parsed)
        self._saved()
        return [asdict(v) for v in forced_values(entries, names.table)]

    def unforce(self, operands: Sequence[str] | None) -> dict[str, Any]:
        """``asictl unforce`` of ``operands``, or of everything for None."""
        self._changing("releasing forces")
        names = self._names()
        which = None if operands is None else [(names.operand(t), t) for t in operands]
        released, entries = unforce(self.master, which)
        self._saved()
        return {"released": released,
                "forced": [asdict(v) for v in forced_values(entries, names.table)]}

    def write(self, assignments: Sequence[str]) -> None:
        """``asictl write``: flags, and outputs while the program is stopped."""
        self._changing("writing")
        names = self._names()
        flags, outputs = image_writes(
            [names.assignment(text, example="F 10.0=1") for text in assignments])
        tools = self.master.tools()
        if flags:
            write_flags(tools, flags)
        if outputs:
            tools.write_outputs(outputs)
        self._saved()

    def start(self, *, start: bool) -> str:
        """``asictl start`` / ``stop``; the control program's state after it."""
        self._changing("starting" if start else "stopping")
        if start and not self.reader.stored_program().info.valid:
            raise UserError(f"{self.name}: no valid program in the master to start "
                            "(download one first)", ExitCode.FAILED)
        set_start(self.master.transport, start=start)
        self._saved()
        return self.master.summary()

    def mode(self, *, configuration: bool) -> str:
        """``asictl mode``: the mode after the switch."""
        self._changing("switching the mode")
        self.master.tools().set_mode(configuration=configuration)
        self._saved()
        return self.status().mode

    def store(self, what: str) -> None:
        """``asictl store configuration|parameters``."""
        self._changing("storing")
        tools = self.master.tools()
        if what == "configuration":
            tools.store_configuration()
        elif what == "parameters":
            tools.store_parameters()
        else:
            raise UserError(f"store '{what}': configuration or parameters", ExitCode.USAGE)
        self._saved()

    def slave_address(self, old: int, new: int) -> None:
        """``asictl slave address OLD NEW``."""
        self._changing("changing a slave's address")
        self.master.tools().change_address(old, new)
        self._saved()

    def slave_parameter(self, address: int, value: int) -> int:
        """``asictl slave parameter ADDRESS VALUE``: the slave's answer."""
        self._changing("writing a parameter")
        answer = self.master.tools().write_parameter(address, value)
        self._saved()
        return answer

    def program(self) -> dict[str, Any]:
        """The program's listing (host/listing.py) with each operand's name."""
        stored = self.reader.stored_program()
        listing = listing_of(stored)
        table = stored.symbols
        return {
            "identity": stored.info.identity, "note": listing.note,
            "lines": [{
                "file": row.file, "line": row.number, "text": row.text, "code": row.code,
                "operand": row.operand,
                "symbol": table.name_of(row.operand) if row.operand else None,
            } for row in listing.lines],
        }

    def download(self, files: Sequence[tuple[str, str]], start: str) -> dict[str, Any]:
        """``asictl download`` of ``files`` (name, text; the main file first) with the
        start flag as ``start`` says (start, stop, keep): built as the command builds a
        file, refused with the diagnostics ``asictl check`` shows if it has errors."""
        self._changing("downloading")
        try:
            mode = StartMode(start)
        except ValueError:
            raise UserError(f"start '{start}': start, stop or keep", ExitCode.USAGE) from None
        for name, _ in files:
            if not FILE_NAME.fullmatch(name):
                raise UserError(f"'{name[:60]}' is no plain file name (letters, digits, "
                                "'_', '-' and '.')", ExitCode.USAGE)
        transport = self.master.transport
        with tempfile.TemporaryDirectory() as folder:
            for name, text in files:
                Path(folder, name).write_text(text, encoding="utf-8")
            entry_points = transport.entry_points()
            built = build_file(Path(folder, files[0][0]), entry_points=entry_points)
            image = built.image
            if built.has_errors or image is None:
                raise UserError(built.render().replace(folder + os.sep, "").rstrip(),
                                ExitCode.FAILED)
        linked_for(image, entry_points)
        cable_setup_slaves(self.master, image)
        download(transport, image, start=mode)
        self._saved()
        return {"identity": image.identity_hex, "size": len(image.to_bytes()),
                "control": self.master.summary()}

    def upload(self) -> dict[str, Any]:
        """``asictl upload``: the files it would write (their exact bytes in base64, and
        as text), main file first, as the image names them."""
        if self.live.in_session():
            raise self._busy("uploading")
        self.live.sync()
        image = upload(self.master.transport)
        main = next(iter(image.program_sources()), "program.asi")
        return {"identity": image.identity_hex, "files": [
            {"name": path.name, "text": decode(raw),
             "base64": base64.b64encode(raw).decode("ascii")}
            for path, raw in uploaded_files(image, main)
        ]}

    def lines(self) -> JSON:
        """The program's lines in the latest cycle (observe.online, the monitor's ``v``)."""
        self._changing("reading the program's values")
        return requests.action(self.live, {"name": "lines", "args": {}}, WEB_PAGE)
