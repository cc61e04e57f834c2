"""The exported AWL run in awlsim (an independent S7 runtime) beside the reference
interpreter: every demo over its scenario and a few generated input sequences here, the
1,000-sequence campaign of ``asictl export --check`` behind the ``slow`` marker.

awlsim lives in its own venv (.ci/run installs it), found as ``asictl export --check``
finds it: ``ASICTL_AWLSIM_PYTHON`` or ``awlsim-test`` on PATH.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from mapped_counter_writes import RUN, mapped_counter_writes

from asictl.build import build_file
from asictl.errors import UserError
from asictl.export.awl import export_awl
from asictl.export.check import Awlsim, Checker, Cycle, awlsim_python, generated_runs, scenario_run
from asictl.observe.symbols import SymbolTable
from asictl.sim.session import prepare

DEMOS = Path(__file__).parents[2] / "demos"


def _python() -> str | None:
    try:
        return awlsim_python()
    except UserError:
        return None


PYTHON = _python()
needs_awlsim = pytest.mark.skipif(
    PYTHON is None and not os.environ.get("CI"),  # CI installs it: there it must run
    reason="needs awlsim 0.77.1 in a venv (.ci/run; ASICTL_AWLSIM_PYTHON)",
)


def _checker(awlsim: Awlsim, path: Path) -> Checker:
    program = build_file(path).program
    assert program is not None
    return Checker(program, export_awl(path.name, program), awlsim)


@needs_awlsim
@pytest.mark.parametrize("path", sorted(DEMOS.glob("*.asi")), ids=lambda p: p.name)
def test_each_demo_behaves_the_same_in_awlsim(path: Path) -> None:
    program = build_file(path).program
    assert program is not None
    exported = export_awl(path.name, program)
    prepared = prepare(path, path.with_suffix(".scenario.toml"))
    run = scenario_run(prepared)
    assert len(run) > 5
    assert PYTHON is not None
    with Awlsim(exported.render(), PYTHON) as awlsim:
        checker = Checker(program, exported, awlsim)
        assert checker.compare("scenario", run) is None
        for name, generated in generated_runs(3, seed=7, length=40):
            assert checker.compare(name, generated) is None


@needs_awlsim
def test_a_wrong_translation_is_named_by_its_operand() -> None:
    """The check can fail: AWL that resets F 0.0 where the IL sets it differs in the
    output that follows the flag (outputs are compared first, then flags)."""
    path = DEMOS / "sequence.asi"
    program = build_file(path).program
    assert program is not None
    exported = export_awl(path.name, program)
    text = exported.render()
    assert "S     M 0.0" in text
    assert PYTHON is not None
    with Awlsim(text.replace("S     M 0.0", "R     M 0.0"), PYTHON) as awlsim:
        start = bytes([0x60]) + bytes(15)  # I 1.1 and I 1.2: retracted, start
        difference = Checker(program, exported, awlsim).compare("start", [Cycle(start, 1)])
    assert difference is not None
    assert (difference.cycle, difference.operand, difference.il, difference.awl) == \
        (0, "Q 2.0", 1, 0)


@needs_awlsim
def test_timers_run_out_on_the_masters_tick_across_the_clock_wrap() -> None:
    """timer.asi: a 5 s timer, at 10 ms and at 50 ms cycles, runs out in the same cycle
    in awlsim as on the master (awlsim's clock starts 200 ms before its 31-bit wrap)."""
    path = DEMOS / "timer.asi"
    assert PYTHON is not None
    with Awlsim(export_awl(path.name, build_file(path).program).render(), PYTHON) as awlsim:
        checker = _checker(awlsim, path)
        for ticks in (1, 5):
            on = bytes([0x10]) + bytes(15)  # I 1.0: start
            run = [Cycle(bytes(16), ticks), *(Cycle(on, ticks) for _ in range(600 // ticks))]
            assert checker.compare(f"{ticks * 10} ms cycles", run) is None


@needs_awlsim
def test_awlsim_refusing_the_code_is_a_user_error() -> None:
    assert PYTHON is not None
    with pytest.raises(UserError, match="awlsim refuses the exported AWL"):
        Awlsim("ORGANIZATION_BLOCK OB 1\nBEGIN\n  FROB M 0.0\nEND_ORGANIZATION_BLOCK\n",
               PYTHON)


@needs_awlsim
@pytest.mark.slow
@pytest.mark.parametrize("name", ["sequence.asi", "1h_timer.asi", "counter.asi"])
def test_a_thousand_generated_sequences(name: str) -> None:
    path = DEMOS / name
    assert PYTHON is not None
    program = build_file(path).program
    assert program is not None
    with Awlsim(export_awl(name, program).render(), PYTHON) as awlsim:
        checker = _checker(awlsim, path)
        for label, run in generated_runs(1000, seed=1):
            assert checker.compare(label, run) is None


@needs_awlsim
def test_awlsim_reads_the_symbol_table() -> None:
    path = DEMOS / "fb.asi"
    program = build_file(path).program
    assert program is not None
    exported = export_awl(path.name, program)
    table = exported.symbol_table(SymbolTable("t", {"start": ("Start", "I 1.0")}))
    assert PYTHON is not None
    with Awlsim(exported.render(), PYTHON, table):
        pass
    with pytest.raises(UserError, match="awlsim refuses"):
        Awlsim(exported.render(), PYTHON, table + '"Start";"I 0.5";"BOOL";"twice"\n')


@needs_awlsim
def test_writes_to_the_bits_a_mapped_counter_keeps_at_0_change_nothing() -> None:
    """=, S, R, T FY and T FW (both alignments) on the upper bits of a mapped counter's
    high byte, read back in the same cycle: awlsim's flags and outputs stay the master's
    (the AWL masks the transfers and leaves the bit stores out)."""
    program = mapped_counter_writes()
    exported = export_awl("mapped_counter_writes.asi", program)
    text = exported.render()
    assert "F 119.5 stays 0 on the master" in text
    assert not [line for line in text.splitlines() if line.split()[:3] == ["=", "M", "119.5"]]
    assert PYTHON is not None
    with Awlsim(text, PYTHON) as awlsim:
        assert Checker(program, exported, awlsim).compare("mapped", RUN) is None
