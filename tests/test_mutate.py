"""asictl mutate: a weak suite leaves the mutant on the branch it never takes alive, the
missing scenario kills it, and the score and its bar; each operator on the AST."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

import asictl.quality.mutate as mutation
from asictl.cli import main
from asictl.il import ast
from asictl.il.parser import parse_text
from asictl.quality.mutate import mutations

PROGRAM = """\
[SETUP]
1: iiii, 0
2: oooo, 0

[PROGRAM]
        A   I 1.0
        =   Q 2.0
***
        A   I 1.1           ; stop
        JC  = off
***
        A   I 1.2
        =   Q 2.1
        BE
off:    R   Q 2.1
"""

#: never presses stop (I 1.1): the JC is never taken, the line after 'off' never runs
WEAK = """\
[master]
cycle_ms = 5
[[step]]
at_ms = 0
set = { "I 1.0" = 1, "I 1.2" = 1 }
[[step]]
at_ms = 50
expect = { "Q 2.0" = 1, "Q 2.1" = 1 }
[[step]]
at_ms = 60
set = { "I 1.0" = 0, "I 1.2" = 0 }
[[step]]
at_ms = 100
expect = { "Q 2.0" = 0, "Q 2.1" = 0 }
"""

#: presses stop while I 1.2 holds Q 2.1 on
STOP = """\
program = "machine.asi"
[master]
cycle_ms = 5
[[step]]
at_ms = 0
set = { "I 1.2" = 1 }
[[step]]
at_ms = 50
set = { "I 1.1" = 1 }
expect = { "Q 2.1" = 1 }
[[step]]
at_ms = 100
expect = { "Q 2.1" = 0 }
"""


@pytest.fixture
def project(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(mutation, "prove_available", lambda: False)  # forks inherit it
    (tmp_path / "machine.asi").write_text(PROGRAM)
    (tmp_path / "machine.scenario.toml").write_text(WEAK)
    return tmp_path


def _mutate(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, ["mutate", "-j", "2", *args])
    return result.exit_code, result.output


def _by_change(output: str) -> dict[tuple[int, str], str]:
    report = json.loads(output)
    return {(m["line"], m["change"]): m["verdict"] for m in report["mutants"]}


def test_the_weak_suite_leaves_the_untaken_branch_alive(project: Path):
    code, output = _mutate(".", "--format", "json")
    assert code == 0, output
    verdicts = _by_change(output)
    assert verdicts[(10, "JC = off -> removed")] == "survived"
    assert verdicts[(10, "JC = off -> JU = off")] == "killed"
    assert verdicts[(15, "R Q 2.1 -> S Q 2.1")] == "survived"  # never runs
    assert verdicts[(6, "A I 1.0 -> AN I 1.0")] == "killed"
    survivors = sorted(line for (line, _), v in verdicts.items() if v == "survived")
    assert survivors == [10, 15, 15]
    report = json.loads(output)
    assert report["equivalence_checked"] is False
    assert report["killed"] == len(verdicts) - 3 and report["counted"] == len(verdicts)


def test_text_report_and_min_score(project: Path):
    code, output = _mutate(".", "--min-score", "100")
    assert code == 1
    assert "machine.asi:10:9: survived: JC = off -> removed" in output
    lines = output.splitlines()
    assert any(line.startswith("machine.asi:6:9: killed: A I 1.0 -> AN I 1.0 (machine."
                               "scenario.toml:") for line in lines)
    assert "mutation score" in output and "is below --min-score 100%" in output
    assert f"note: {mutation.PROVE_HINT}" in output
    assert _mutate(".", "--min-score", "50")[0] == 0


def test_the_missing_scenario_kills_the_survivors(project: Path):
    (project / "stop.scenario.toml").write_text(STOP)
    code, output = _mutate(".", "--format", "json", "--min-score", "100")
    assert code == 0, output
    verdicts = _by_change(output)
    assert verdicts[(10, "JC = off -> removed")] == "killed"
    assert verdicts[(15, "R Q 2.1 -> S Q 2.1")] == "killed"
    assert "survived" not in verdicts.values()


def test_a_mutant_past_its_time_limit_is_a_timeout_and_counts_as_killed(
    project: Path, monkeypatch: pytest.MonkeyPatch
):
    real = mutation.simulate

    def endless(*args: Any, **kwargs: Any) -> Any:  # as a mutant that loops would run
        time.sleep(120)
        return real(*args, **kwargs)

    monkeypatch.setattr(mutation, "simulate", endless)  # the mutants' runs (forks inherit it)
    code, output = _mutate(".", "--format", "json", "--timeout", "0.5")
    assert code == 0
    report = json.loads(output)
    ran = [m for m in report["mutants"] if m["detail"] != "no scenario runs this line"]
    assert {m["verdict"] for m in ran} == {"timeout"}
    assert report["killed"] == len(ran) == len(report["mutants"]) - 2


def test_a_suite_that_fails_unchanged_is_refused(project: Path):
    (project / "machine.scenario.toml").write_text(WEAK.replace('"Q 2.0" = 1', '"Q 2.0" = 0'))
    code, output = _mutate(".")
    assert code == 1 and "fails on the unchanged program" in output


def test_bad_input(project: Path):
    (project / "machine.scenario.toml").unlink()
    code, output = _mutate(".")
    assert code == 2 and "no .scenario.toml files found" in output
    (project / "machine.scenario.toml").write_text("[[step]]\nat_ms = -1\n")
    code, output = _mutate(".")
    assert code == 2 and "machine.scenario.toml:2:1: error: at_ms is a time" in output
    assert "Traceback" not in output


def _first(source: str) -> ast.Statement | ast.GatingLine:
    module, diagnostics = parse_text(source, "x.asi")
    assert not [d for d in diagnostics if d.is_error]
    return next(module.code())


@pytest.mark.parametrize(("line", "expected"), [
    ("A I 1.0", ["AN I 1.0", "A I 1.1"]),
    ("ON F 3.7", ["O F 3.7", "ON F 3.6"]),
    ("S Q 2.3", ["R Q 2.3", "S Q 2.2"]),
    ("= F 1.0", [None, "= F 1.1"]),
    ("JC = x", ["JU = x", None]),
    ("JU = x", []),
    ("BEC", [None]),
    ("BE", []),
    ("L KT 500", ["L KT 490", "L KT 510"]),
    ("L KT 0", ["L KT 10"]),
    ("L KC 4095", ["L KC 4094"]),
    ("L KB 255", ["L KB 254"]),
    ("L KB 7", ["L KB 6", "L KB 8"]),
    ("><F", ["!= F"]),
    (">= F", ["< F"]),
])
def test_each_operator(line: str, expected: list[str | None]):
    node = _first(f"[PROGRAM]\n    {line}\nx: BE\n")
    found = [None if m is None else m.to_source() for m in mutations(node)]
    assert found == expected


def test_gating_terms():
    node = _first("[GATING]\nQ 2.0 = I 1.0 and not I 1.3\n")
    found = [None if m is None else m.to_source() for m in mutations(node)]
    assert found == [None, "Q 2.0 = not I 1.0 and not I 1.3", "Q 2.0 = I 1.1 and not I 1.3",
                     "Q 2.0 = I 1.0 and I 1.3", "Q 2.0 = I 1.0 and not I 1.2"]


#: F 5.0 is written and never read: removing its assignment changes the code, not what
#: the master does; the scenario cannot notice, the prover can tell that it is equivalent.
UNREAD_FLAG = """\
[SETUP]
1: iiii, 0
2: oooo, 0

[PROGRAM]
        A   I 1.0
        =   Q 2.0
        =   F 5.0
        BE
"""

FOLLOWS = """\
[master]
cycle_ms = 5
[[step]]
at_ms = 0
set = { "I 1.0" = 1 }
[[step]]
at_ms = 20
expect = { "Q 2.0" = 1 }
set = { "I 1.0" = 0 }
[[step]]
at_ms = 40
expect = { "Q 2.0" = 0 }
"""


def test_with_the_prover_a_surviving_mutant_that_changes_nothing_is_equivalent(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "flag.asi").write_text(UNREAD_FLAG)
    (tmp_path / "flag.scenario.toml").write_text(FOLLOWS)
    code, output = _mutate(".", "--format", "json")
    assert code == 0, output
    report = json.loads(output)
    assert report["equivalence_checked"] is True
    by_change = {(m["line"], m["change"]): m for m in report["mutants"]}
    removed = by_change[(8, "= F 5.0 -> removed")]
    assert removed["verdict"] == "equivalent", removed
    assert "proved" in removed["detail"]
    assert by_change[(7, "= Q 2.0 -> removed")]["verdict"] == "killed"
    monkeypatch.setattr(mutation, "prove_available", lambda: False)
    report = json.loads(_mutate(".", "--format", "json")[1])
    assert report["equivalence_checked"] is False
    assert {(m["line"], m["change"]): m["verdict"] for m in report["mutants"]}[
        (8, "= F 5.0 -> removed")] == "survived"
