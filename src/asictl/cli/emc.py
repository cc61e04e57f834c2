"""``asictl emc``: the PC2's EMC test mode, command 130 (host/emc.py, docs/host.md)."""

from __future__ import annotations

import json
import re
from dataclasses import asdict
from typing import Unpack

import click

from asictl.cli.board_options import BoardOptions, board_options, master_wait, open_master
from asictl.cli.guard_options import real_master_option
from asictl.cli.options import Duration
from asictl.errors import ExitCode, UserError
from asictl.host.emulated.actions import parse_address, parse_number
from asictl.host.overwrite_guard import check_overwrite


def _slaves(text: str) -> list[int]:
    """``1,2,5`` or ``1-4,7``: slave addresses 0..31."""
    found: list[int] = []
    for part in (p for p in re.split(r"[,\s]+", text.strip()) if p):
        low, dash, high = part.partition("-")
        first = parse_address(low)
        last = parse_address(high) if dash else first
        if last < first:
            raise UserError(f"slaves '{part}': the range runs backwards", ExitCode.USAGE)
        found.extend(range(first, last + 1))
    if not found:
        raise UserError("which slaves? e.g. '1,2,5' or '1-4'", ExitCode.USAGE)
    return sorted(set(found))


@click.command("emc")
@click.argument("slaves", metavar="SLAVES|off")
@click.option("--request", default="0", show_default=True, metavar="BITS",
              help="The master call's information bits I0..I4 (0..1Fh): a data call with "
              "output data I0..I3, or with I4 set (10h..1Fh) a parameter call.")
@click.option("--expect", metavar="BITS",
              help="Check every answer against these bits (0..1Fh); a wrong one counts as "
              "failed. Without it only missing answers do.")
@click.option("--repetitions", is_flag=True,
              help="Allow the master to repeat a failed request once.")
@click.option("--for", "for_ms", type=Duration(least_ms=10, limit_ms=3_600_000), default="1s",
              show_default=True, metavar="TIME", help="How long the test runs.")
@click.option("--keep", is_flag=True,
              help="Leave the test running after the report ('asictl emc off' ends it).")
@click.option("--json", "as_json", is_flag=True, help="The counts as one JSON object.")
@board_options
@real_master_option
def emc(
    slaves: str, request: str, expect: str | None, repetitions: bool, for_ms: float,
    keep: bool, as_json: bool, real_master: bool, **board: Unpack[BoardOptions],
) -> None:
    """Run the EMC test mode (command 130) on SLAVES: for the --for time the master sends
    the request to each of them every AS-i cycle instead of the data exchange and counts
    the requests and the answers that are missing (or wrong, with --expect); then the
    test ends and the counts are shown. 'off' ends a test left running (--keep) and
    reports it. Only a master with the option (installed software byte 3 'E') has the
    mode; the data exchange, and so the control program's outputs, stop while it runs.

    Exit status: 0 tested, 1 the master has no EMC test mode or did not answer (a gateway
    has none), 2 bad usage.

    \b
    Examples:
      asictl bus plug 5 iiio,1
      asictl emc 5 --for 1s
      asictl emc 5 --request 3 --expect 6 --for 1s
    """
    from asictl.host.emc import emc_command, emc_test
    from asictl.platform.pc2 import emc_parameters

    ending = slaves.strip().lower() == "off"
    addresses = [] if ending else _slaves(slaves)
    bits = parse_number(request, "request", 0x1F)
    expected = None if expect is None else parse_number(expect, "expected answer", 0x1F)
    with open_master(**board) as master:
        if master.driver is None:
            raise UserError(
                f"{master.name}: the EMC test mode is not reachable through a gateway: its "
                "software letter E is its master's (the PC2 inside has command 130), but the "
                "gateway manual gives no Modbus function or register that issues command 130; "
                "run 'asictl emc' on the board itself (--port)",
                ExitCode.FAILED,
            )
        if not ending:
            check_overwrite(master, "run the EMC test mode (the data exchange, and so the "
                            "control program's outputs, stop while it runs)",
                            real_master=real_master)
        if ending:
            counts = emc_command(master.driver, emc_parameters([], 0))
            what = "EMC test ended"
        else:
            counts = emc_test(
                master.driver, addresses, bits, expected=expected, repetitions=repetitions,
                seconds=for_ms / 1000, keep=keep,
                wait=master_wait(master),
            )
            what = f"EMC test of slave{'s' if len(addresses) > 1 else ''} " + ", ".join(
                map(str, addresses)) + f" for {for_ms / 1000:g} s" + (" (still running)" if keep
                                                                else "")
    if as_json:
        click.echo(json.dumps({**asdict(counts), "slaves": addresses, "running": keep}))
    else:
        click.echo(
            f"{master.name}: {what}: {counts.requests} requests, {counts.failures} failed "
            f"({counts.failed_percent:.2f} %)"
        )
    if keep and master.action is not None and master.action.live is None:
        click.echo(
            f"{master.name}: note: this emulated board runs only during a command: the test "
            "ends with it ('asictl serve' keeps the board running)", err=True,
        )
