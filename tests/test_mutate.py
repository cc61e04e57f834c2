"""asictl mutate: a weak suite leaves the mutant on the branch it never takes alive, the
missing scenario kills it, and the score and its bar; each operator on the AST; the
cache of verdicts (a second run reports what a fresh one does, a change to one program
or scenario runs only that program's mutants again, a damaged cache file is ignored)."""

from __future__ import annotations

import json
import os
import signal
import time
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

import asictl.quality.mutate as mutation
from asictl.cli import main
from asictl.diagnostics import DiagnosticError
from asictl.il import ast
from asictl.il.parser import parse_text
from asictl.quality.cache import Cache, default_directory
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


def test_a_killed_mutants_detail_names_the_operand_by_the_symbol_table(project: Path):
    (project / "machine.symbols.toml").write_text('Forward = "Q 2.0"\n')
    code, output = _mutate(".", "--format", "json")
    assert code == 0, output
    detail = {(m["line"], m["change"]): m["detail"]
              for m in json.loads(output)["mutants"]}[(6, "A I 1.0 -> AN I 1.0")]
    assert detail.endswith("Q 2.0 (Forward) expected 1, got 0"), detail


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
    code, output = _mutate(".", "--format", "json", "--timeout", "500ms")
    assert code == 0
    report = json.loads(output)
    ran = [m for m in report["mutants"] if m["detail"] != "no scenario runs this line"]
    assert {m["verdict"] for m in ran} == {"timeout"}
    assert {m["detail"] for m in ran} == {"still running after 500 ms"}  # not 0.5 s
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
    assert code == 2 and "machine.scenario.toml:2:9: error: at_ms is a time" in output
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
    removed = by_change[(8, "= Q 2.0 -> removed")]  # the same store stays on line 7
    assert removed["verdict"] == "equivalent", removed
    assert "proved" in removed["detail"]
    # a flag the outputs never show is still one a scenario may expect: not equivalent
    assert by_change[(9, "= F 5.0 -> removed")]["verdict"] == "survived"
    assert by_change[(9, "= F 5.0 -> = F 5.1")]["verdict"] == "survived"
    assert by_change[(6, "A I 1.0 -> AN I 1.0")]["verdict"] == "killed"
    monkeypatch.setattr(mutation, "prove_available", lambda: False)
    report = json.loads(_mutate(".", "--format", "json")[1])
    assert report["equivalence_checked"] is False
    assert {(m["line"], m["change"]): m["verdict"] for m in report["mutants"]}[
        (8, "= Q 2.0 -> removed")] == "survived"


#: the scenario checks Q 2.0 only after 400 ms: a timer constant one step off survives it
DELAY = """\
[SETUP]
1: iiii, 0
2: oooo, 0

[PROGRAM]
        L   KT 300
        A   I 1.0
        S   T 1
***
        A   T 1
        =   Q 2.0
***
        A   I 1.1
        =   Q 2.1
        BE
"""

DELAY_SCENARIO = """\
[master]
cycle_ms = 5
[[step]]
at_ms = 0
set = { "I 1.0" = 1, "I 1.1" = 1 }
[[step]]
at_ms = 100
expect = { "Q 2.0" = 1, "Q 2.1" = 1 }
set = { "I 1.0" = 0 }
[[step]]
at_ms = 500
expect = { "Q 2.0" = 0 }
"""


def _delay_project(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "delay.asi").write_text(DELAY)
    (tmp_path / "delay.scenario.toml").write_text(DELAY_SCENARIO)


def test_a_survivor_seen_to_differ_on_random_inputs_is_not_given_to_the_prover(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    """The timer constants one step off survive the scenario; random inputs show them
    different (so the prover is not asked, a test of its own below agrees), and the
    report says where they differ: in the timer's remaining time, from its start, the
    timer named by the symbol table."""
    _delay_project(tmp_path, monkeypatch)
    (tmp_path / "delay.symbols.toml").write_text('Lamp = "Q 2.0"\nStart = "I 1.0"\nDelay = "T 1"\n')
    code, output = _mutate(".", "--format", "json")
    assert code == 0, output
    by_change = {m["change"]: m for m in json.loads(output)["mutants"]}
    for change in ("L KT 300 -> L KT 290", "L KT 300 -> L KT 310"):
        assert by_change[change]["verdict"] == "survived"
        assert by_change[change]["detail"].startswith(
            "not equivalent: T 1 (Delay) differs from the original's after ")
        assert by_change[change]["seconds"] < mutation.PROVE_SECONDS  # no proof was tried


def test_symbols_names_the_operands_of_killed_mutants_and_survivors(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    """--symbols FILE names the notes where the table beside the program would; a table
    of other names (or none) is another run, not the cache's."""
    _delay_project(tmp_path, monkeypatch)
    (tmp_path / "names.toml").write_text('Lamp = "Q 2.0"\nDelay = "T 1"\n')

    def details(*args: str) -> dict[str, str]:
        code, output = _mutate(".", "--format", "json", *args)
        assert code == 0, output
        return {m["change"]: m["detail"] for m in json.loads(output)["mutants"]}

    named = details("--symbols", "names.toml")
    assert named["A T 1 -> AN T 1"].endswith("Q 2.0 (Lamp) expected 1, got 0"), named
    assert named["L KT 300 -> L KT 290"].startswith("not equivalent: T 1 (Delay) differs")
    plain = details()  # no table beside delay.asi
    assert plain["A T 1 -> AN T 1"].endswith(": Q 2.0 expected 1, got 0"), plain
    assert plain["L KT 300 -> L KT 290"].startswith("not equivalent: T 1 differs")


def test_a_symbols_file_with_a_mistake_is_refused_at_its_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    _delay_project(tmp_path, monkeypatch)
    (tmp_path / "names.toml").write_text('Lamp = "Q 2.0"\nDelay = "T 99x"\n')
    code, output = _mutate(".", "--symbols", "names.toml")
    assert code == 2, output
    assert "names.toml:2:" in output and "Traceback" not in output


@pytest.mark.parametrize(("name", "every"), [
    ("oscil.asi", 1), ("flipflop.asi", 1), ("edge.asi", 1),
    # fb: GetLAS and SetPP, whose answers the random run cannot give, so each proof
    # takes about a second: every eighth mutant here, all of them in the long run
    ("fb.asi", 8), pytest.param("fb.asi", 1, marks=pytest.mark.slow)])
def test_what_the_random_search_calls_different_the_prover_does_not_call_equivalent(
        name: str, every: int):
    """The independent check: each difference the search finds on the demos' mutants is
    one the prover, asked, does not prove away (and finds itself where it is shallow)."""
    pytest.importorskip("z3")
    from asictl.build import build_file
    from asictl.prove import equivalent
    from asictl.prove.diff import readable
    from asictl.quality.refute import find_difference

    root = Path(__file__).resolve().parent.parent
    original = build_file(root / "demos" / name)
    assert original.program is not None
    checked = 0
    for mutant in mutation.mutants_of(original.program)[::every]:
        try:
            built = mutation.build_mutant(original, mutant)
        except DiagnosticError:  # a mutant the compiler refuses
            continue
        difference = find_difference(original, built)
        if difference is None or difference.at_ms > 6:  # within the prover's depth
            continue
        # what mutation testing compares: outputs, flags, timers and counters
        observe = readable(original.program, built.program)
        answer = equivalent(original, built, timeout_s=20.0, observe=observe)
        assert answer.verdict == "different", (name, mutant.change, answer)
        checked += 1
    assert checked >= 5


def test_the_proof_has_a_time_limit_of_its_own_and_leaves_a_survivor(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    """``--timeout`` limits the scenarios; a proof that runs out of its own time makes the
    mutant a survivor, never a timeout (which would count as killed)."""
    _delay_project(tmp_path, monkeypatch)

    def slow_proof(*args: Any) -> Any:
        time.sleep(60)

    monkeypatch.setattr(mutation, "prove_equivalent", slow_proof)  # forks inherit it
    monkeypatch.setattr(mutation, "PROOF_MARGIN", 0.3)
    code, output = _mutate(".", "--format", "json", "--timeout", "5s", "--proof-timeout", "200ms")
    assert code == 0, output
    survivors = [m for m in json.loads(output)["mutants"] if m["verdict"] == "survived"]
    assert {m["change"] for m in survivors} >= {"L KT 300 -> L KT 290", "L KT 300 -> L KT 310"}
    assert all(m["detail"] == "the proof of equivalence ran out of time" for m in survivors)
    assert "timeout" not in {m["verdict"] for m in json.loads(output)["mutants"]}


def _dying(monkeypatch: pytest.MonkeyPatch, changes: set[str], marker: Path | None) -> None:
    """The workers of mutants with these changes kill themselves with SIGKILL, as the OOM
    killer would (each time, or with ``marker`` only the first time)."""
    real = mutation.verdict

    def verdict(target: Any, mutant: Any, *args: Any) -> Any:
        if mutant.change in changes:
            flag = None if marker is None else marker / mutant.change.replace(" ", "_")
            if flag is None or not flag.exists():
                if flag is not None:
                    flag.touch()
                os.kill(os.getpid(), signal.SIGKILL)
        return real(target, mutant, *args)

    monkeypatch.setattr(mutation, "verdict", verdict)  # forks inherit it


def test_a_worker_that_dies_twice_counts_its_mutant_as_not_killed(
    project: Path, monkeypatch: pytest.MonkeyPatch
):
    clean = json.loads(_mutate(".", "--format", "json")[1])
    _dying(monkeypatch, {"JC = off -> JU = off", "JC = off -> removed"}, None)
    # judged afresh: the cache would answer with the clean run's verdicts
    code, output = _mutate(".", "--format", "json", "--no-cache")
    assert code == 0, output
    report = json.loads(output)
    died = {m["change"]: m["detail"] for m in report["mutants"] if m["verdict"] == "died"}
    assert set(died) == {"JC = off -> JU = off", "JC = off -> removed"}
    assert all("killed by SIGKILL, twice" in detail for detail in died.values())
    # the killed mutant is not killed any more; the survivor's death does not lift the score
    assert report["killed"] == clean["killed"] - 1
    assert report["counted"] == clean["counted"]
    assert report["score"] < clean["score"]
    code, text = _mutate(".", "--min-score", f"{clean['score'] - 0.01}", "--no-cache")
    assert code == 1
    assert "2 died" in text and "died: JC = off -> JU = off (its worker process" in text


def test_a_worker_that_dies_once_is_run_again(
    project: Path, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
):
    clean = json.loads(_mutate(".", "--format", "json")[1])
    (tmp_path / "marks").mkdir()
    _dying(monkeypatch, {"JC = off -> JU = off", "JC = off -> removed"}, tmp_path / "marks")
    report = json.loads(_mutate(".", "--format", "json", "--no-cache")[1])
    assert _verdicts(report) == _verdicts(clean)
    assert len(list((tmp_path / "marks").iterdir())) == 2  # each died once


def _verdicts(report: dict[str, Any]) -> list[tuple[int, str, str]]:
    return [(m["line"], m["change"], m["verdict"]) for m in report["mutants"]]


# ---------------------------------------------------------------------- the cache

LAMP = """\
[SETUP]
1: iiii, 0
2: oooo, 0

[PROGRAM]
        A   I 1.0
        AN  I 1.1
        =   Q 2.0
        BE
"""

LAMP_SCENARIO = """\
[master]
cycle_ms = 5
[[step]]
at_ms = 0
set = { "I 1.0" = 1 }
[[step]]
at_ms = 20
expect = { "Q 2.0" = 1 }
set = { "I 1.1" = 1 }
[[step]]
at_ms = 40
expect = { "Q 2.0" = 0 }
"""


@pytest.fixture
def two_programs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """src/ with two programs and their scenarios (for the cache: quality/cache.py)."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(mutation, "prove_available", lambda: False)  # forks inherit it
    for name, text in (("machine.asi", PROGRAM), ("machine.scenario.toml", WEAK),
                       ("lamp.asi", LAMP), ("lamp.scenario.toml", LAMP_SCENARIO)):
        (tmp_path / "src" / name).parent.mkdir(exist_ok=True)
        (tmp_path / "src" / name).write_text(text)
    return tmp_path


def _cached_run(*args: str) -> dict[str, Any]:
    result = CliRunner().invoke(main, ["mutate", "src", "-j", "2", "--format", "json", *args])
    assert result.exit_code == 0, result.output
    report: dict[str, Any] = json.loads(result.stdout)
    return report


def _timeless(report: dict[str, Any]) -> list[dict[str, Any]]:
    """The report's rows without what may differ between a fresh and a cached run."""
    return [{k: v for k, v in row.items() if k not in ("seconds", "cached")}
            for row in report["mutants"]]


def _judged(report: dict[str, Any], file: str) -> list[dict[str, Any]]:
    """The rows of one program's mutants that a run judges (not 'no scenario runs')."""
    return [row for row in report["mutants"] if row["file"] == file
            and row["detail"] != "no scenario runs this line"]


def test_a_second_run_takes_every_verdict_from_the_cache_and_reports_the_same(
        two_programs: Path):
    cache = two_programs / "cache"
    fresh = _cached_run("--cache", str(cache))
    assert fresh["from_cache"] == 0
    again = _cached_run("--cache", str(cache))
    judged = _judged(again, "src/lamp.asi") + _judged(again, "src/machine.asi")
    assert judged and all(row["cached"] for row in judged)
    assert again["from_cache"] == len(judged)
    assert _timeless(again) == _timeless(fresh)
    assert {k: v for k, v in again.items() if k not in ("mutants", "from_cache")} == \
        {k: v for k, v in fresh.items() if k not in ("mutants", "from_cache")}
    assert _timeless(_cached_run("--no-cache")) == _timeless(fresh)


def test_a_changed_program_runs_only_its_own_mutants_again(two_programs: Path):
    cache = two_programs / "cache"
    _cached_run("--cache", str(cache))
    lamp = two_programs / "src" / "lamp.asi"
    lamp.write_text(LAMP.replace("BE", "BE                  ; the lamp"))
    again = _cached_run("--cache", str(cache))
    assert not any(row["cached"] for row in _judged(again, "src/lamp.asi"))
    machine = _judged(again, "src/machine.asi")
    assert machine and all(row["cached"] for row in machine)
    assert again["from_cache"] == len(machine)
    # and the changed program's new verdicts are kept in turn
    third = _cached_run("--cache", str(cache))
    assert third["from_cache"] == len(machine) + len(_judged(third, "src/lamp.asi"))


def test_a_changed_scenario_runs_its_program_s_mutants_again(two_programs: Path):
    cache = two_programs / "cache"
    fresh = _cached_run("--cache", str(cache))
    scenario = two_programs / "src" / "machine.scenario.toml"
    scenario.write_text(WEAK + """\
[[step]]
at_ms = 120
set = { "I 1.2" = 1, "I 1.1" = 1 }
[[step]]
at_ms = 160
expect = { "Q 2.1" = 0 }
""")
    again = _cached_run("--cache", str(cache))
    assert not any(row["cached"] for row in _judged(again, "src/machine.asi"))
    lamp = _judged(again, "src/lamp.asi")
    assert lamp and all(row["cached"] for row in lamp)
    # the new step presses stop: the mutant removing the jump to 'off' is killed now
    before = {(r["line"], r["change"]): r["verdict"] for r in fresh["mutants"]}
    after = {(r["line"], r["change"]): r["verdict"] for r in again["mutants"]}
    assert before[(10, "JC = off -> removed")] == "survived"
    assert after[(10, "JC = off -> removed")] == "killed"


@pytest.mark.parametrize("damage", [
    b"\x00\xff not json",
    b'{"kind": "something else", "format": 1}',
    b"[" * 100_000,
    "flip",  # a verdict renamed to one asictl never writes
    "extra",  # a row with a key of its own
    "key",  # another program's key
])
def test_a_damaged_or_foreign_cache_file_is_ignored(two_programs: Path, damage: bytes | str):
    cache = two_programs / "cache"
    fresh = _cached_run("--cache", str(cache))
    for file in cache.iterdir():
        if isinstance(damage, bytes):
            file.write_bytes(damage)
            continue
        document = json.loads(file.read_text())
        if damage == "flip":
            document["results"][0]["verdict"] = "killed-ish"
        elif damage == "extra":
            document["results"][0]["trust"] = "me"
        else:
            document["key"] = "0" * 64
        file.write_text(json.dumps(document))
    again = _cached_run("--cache", str(cache))
    assert again["from_cache"] == 0
    assert _timeless(again) == _timeless(fresh)
    # and the file is written again, whole
    assert _cached_run("--cache", str(cache))["from_cache"] > 0


def test_the_cache_lives_where_asictl_s_other_caches_do(monkeypatch: pytest.MonkeyPatch,
                                                       tmp_path: Path):
    """``$XDG_CACHE_HOME/asictl/mutate``; a relative XDG_CACHE_HOME is ignored, as the
    XDG specification says, rather than filling the current folder."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert default_directory() == tmp_path / "asictl" / "mutate"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert default_directory() == tmp_path / "home" / ".cache" / "asictl" / "mutate"


def test_no_cache_neither_reads_nor_writes(two_programs: Path):
    cache = two_programs / "cache"
    assert _cached_run("--no-cache")["from_cache"] == 0
    directory = default_directory()
    assert directory is not None and not directory.exists()
    _cached_run("--cache", str(cache))
    assert _cached_run("--no-cache")["from_cache"] == 0
    result = CliRunner().invoke(main, ["mutate", "src", "--cache", str(cache), "--no-cache"])
    assert result.exit_code == 2
    assert "--no-cache" in result.output and "Traceback" not in result.output


def test_the_default_cache_is_under_xdg_cache_home(two_programs: Path,
                                                     monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(two_programs / "xdg"))
    assert _cached_run()["from_cache"] == 0
    assert len(list((two_programs / "xdg" / "asictl" / "mutate").glob("*.json"))) == 2
    assert _cached_run()["from_cache"] > 0
    result = CliRunner().invoke(main, ["mutate", "src", "-j", "2"])
    assert "verdicts from the cache" in result.output


def test_a_cache_that_cannot_be_written_is_a_warning(two_programs: Path):
    """The folder cannot be made (a file stands where it would go): the run is made and
    reported all the same, with a warning; the exit status is the run's."""
    (two_programs / "plain").write_text("a file, not a folder\n")
    result = CliRunner().invoke(main, ["mutate", "src", "-j", "2",
                                       "--cache", str(two_programs / "plain" / "cache")])
    assert result.exit_code == 0, result.output
    assert "warning:" in result.output and "results not kept" in result.output
    assert "mutants:" in result.output


def test_what_the_cache_never_keeps(tmp_path: Path):
    """A mutant whose worker died, or whose judging failed inside asictl, is judged
    again next time: neither says anything about the program."""
    cache = Cache(tmp_path)
    program = tmp_path / "p.asi"
    cache.store(program, "k", [("a", "killed", "x.toml:3: failed"),
                               ("b", "died", "its worker process was killed by SIGKILL"),
                               ("c", "invalid", "internal error: KeyError: 3"),
                               ("d", "survived", "")])
    assert set(cache.load(program, "k")) == {"a", "d"}
    assert cache.load(program, "another key") == {}
