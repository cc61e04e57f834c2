"""``asictl monitor``: the live full-screen view (docs/commissioning.md).

Textual is an optional extra (``monitor``) and is imported only here, when the
command runs: the other commands, and ``asictl --help``, never load it.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Unpack

import click

from asictl.cli.board_options import BoardOptions, board_options, master_address
from asictl.diagnostics import printable
from asictl.errors import missing_extra


def _notify(text: str) -> None:
    click.echo(f"asictl: {printable(text)}", err=True)


@click.command("monitor")
@board_options
def monitor(**board: Unpack[BoardOptions]) -> None:
    """A live full-screen view of the master: ASI_MON and ASI_VIS in one.

    The 31 slaves with their input and output data and list membership, the selected
    slave's details, the flag bytes, timers and counters, the program's state, cycle
    times, phase and mode, and an event log, laid out for the terminal's size (every
    slave on the screen from 80x24 on). Keys (? or F1 lists them all): arrows select a
    slave; 0-3 toggle the selected emulated slave's input bits; o writes its outputs
    (program stopped); f writes a flag byte or bit; s starts or stops the program; b
    presses the set button; p/u plug/unplug a slave at the selected address; a changes
    its address; P writes its parameter; m switches protected/configuration mode; F5/F6
    store the actual parameters/configuration; F9 reads everything again; h sets the
    hi-flags; F forces an operand or name (held every cycle, FORCE n on top) and R
    releases it (an emulated board); d shows the data view (the flags panel across the
    screen); w the watch view (a chosen list in binary, decimal and hex: + adds, -
    removes, = writes once, F/R force and release the selected row); q or F10 quits.
    Where 'asictl gateway
    serve' serves the board, its front panel is shown (display and LEDs), [ and ] press
    its mode and set keys, { and } hold them 6 s, | holds both 6 s.

    v shows the program view instead of the slaves: the program's source with each IL
    line's RLO, ACCU1, ACCU2, constant register (KREG) and operand value from the latest
    cycle (an emulated board only), operands named by the board's symbol table, lines
    that did not run grey; arrows and PgUp/PgDn scroll, n goes to the next file (the
    function blocks follow the main file), x shows hex; v again returns.

    An emulated board that no 'asictl serve' keeps running is served live by the monitor
    itself while it runs, so the other commands reach it meanwhile; when the server it
    watches goes away, the monitor takes over serving the board (top line and event log:
    'took over'), or, when another process holds the board, shows the master as gone in
    red and refuses the keys that act on it until it can.

    Needs the 'monitor' extra (Textual).

    Exit status: 0 quit, 2 bad usage or Textual not installed.

    \b
    Examples:
      asictl monitor
      asictl monitor --port 304h
    """
    try:
        from asictl.monitor.app import MonitorApp
    except ImportError as exc:
        raise missing_extra("asictl monitor", "monitor", f"no {exc.name or exc}") from None
    from asictl.host.emulated.boards import state_directory
    from asictl.host.live.client import is_served
    from asictl.host.search import resolve_port
    from asictl.host.transports.ports import port_name
    from asictl.monitor.source import MonitorSource

    address = master_address(**board)
    if address.modbus is None:
        directory = state_directory(address.state_dir)
        base = resolve_port(address.port, address.io, directory, _notify)
        address = replace(address, port=port_name(base))  # searched once, not each refresh
        if address.io == "emulated":
            is_served(directory, base)  # a socket place that is not safe: refused at once
    with MonitorSource(address) as source:
        MonitorApp(source).run()
