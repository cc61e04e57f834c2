"""``prove --timeout`` and ``diff --equivalent --timeout`` hold from the start of the
command: a program of many small loops, whose model takes longer to build than the limit,
ends within it (building counts) and says how long it really took."""

from __future__ import annotations

import re
import time
from pathlib import Path

from click.testing import CliRunner

from asictl.cli import main

LOOPS = 40  # about 6 s to build on an idle core: well beyond the limit below
LIMIT_S = 1.0
SLACK_S = 3.0  # reading the program, stopping at the next check, a loaded machine


def many_loops(path: Path, output: str = "Q 2.0") -> Path:
    """A program of ``LOOPS`` small loops, each run as often as input byte 0 says."""
    lines = ["[SETUP]", "1: iiii, 0", "2: oooo, 0", "[PROGRAM]"]
    for n in range(LOOPS):
        flag = 10 + n
        lines += ["    L KB 0", f"    T FY {flag}", f"l{n}: L FY {flag}", "    L KB 16",
                  "    + F", f"    T FY {flag}", f"    L FY {flag}", "    L IB 0", "    >< F",
                  f"    JC l{n}"]
    path.write_text("\n".join([*lines, "    A F 10.5", f"    = {output}"]) + "\n")
    return path


def timed(*args: str) -> tuple[float, str, int]:
    started = time.monotonic()
    result = CliRunner().invoke(main, list(args))
    return time.monotonic() - started, result.output, result.exit_code


def test_prove_stops_at_its_limit_while_building_the_model(tmp_path: Path):
    program = many_loops(tmp_path / "loops.asi")
    (tmp_path / "loops.props.toml").write_text(
        '[[property]]\nname = "q"\nnever = "Q 2.0 and Q 2.1"\n'
        '[[property]]\nname = "r"\nnever = "Q 2.1"\n')
    seconds, output, code = timed("prove", str(program), "--timeout", f"{LIMIT_S:g}s")
    assert code == 1, output
    assert seconds < LIMIT_S + SLACK_S, (seconds, output)
    notes = re.findall(r"note: time limit \(1 s\) while building the model, ([\d.]+) s "
                       r"since the start", output)
    assert len(notes) == 2, output  # every property: none was decided
    assert LIMIT_S <= float(notes[0]) < LIMIT_S + SLACK_S


def test_diff_equivalent_stops_at_its_limit_and_says_the_time_it_took(tmp_path: Path):
    first = many_loops(tmp_path / "a.asi")
    second = many_loops(tmp_path / "b.asi", "Q 2.1")
    seconds, output, code = timed("diff", str(first), str(second), "--equivalent",
                                  "--timeout", f"{LIMIT_S:g}s")
    assert code == 1, output
    assert seconds < LIMIT_S + SLACK_S, (seconds, output)
    took = re.search(r"time limit \(1 s\) while building the model, ([\d.]+) s since", output)
    assert took is not None, output
    assert float(took[1]) >= LIMIT_S and "(0.1 s)" not in output


def test_a_small_program_is_still_decided_within_the_limit(tmp_path: Path):
    program = tmp_path / "p.asi"
    program.write_text("[SETUP]\n1: iiii, 0\n2: oooo, 0\n[PROGRAM]\n    A I 1.0\n    = Q 2.0\n")
    (tmp_path / "p.props.toml").write_text('[[property]]\nname = "q"\nreachable = "Q 2.0"\n')
    seconds, output, code = timed("prove", str(program), "--timeout", "20s")
    assert code == 0 and "reached" in output and seconds < 20, output
