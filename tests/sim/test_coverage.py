"""IL coverage from scenarios: exact counts on a program whose run is known by hand, the
three report formats read by independent readers, the command line and the pytest plugin."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.cli import main
from asictl.sim.session import as_json, prepare, simulate

ROOT = Path(__file__).resolve().parents[2]

MAIN = """\
; coverage: which lines, branches and conditions run
[SETUP]
1: iiii, 0
2: oooo, 0

[DECL]
Latch   FB latch.fb

[PROGRAM]
        A   I 1.0
        AN  I 1.1
        JC  = skip
        O   I 1.2
        =   Q 2.0
***
skip:   A   I 1.3
        JC  FB Latch
***
        A   I 1.0
        BEC
        A   I 1.3
        =   Q 2.2

[GATING]
Q 2.1 = I 1.0 and not I 1.1
"""

#: 21 cycles (0, 5, ... 100 ms): I 1.0 from the first to the 18th, I 1.1 from the 11th,
#: I 1.3 from the 17th
SCENARIO = """\
[master]
cycle_ms = 5
[[step]]
at_ms = 0
set = { "I 1.0" = 1 }
[[step]]
at_ms = 50
set = { "I 1.1" = 1 }
[[step]]
at_ms = 80
set = { "I 1.3" = 1 }
[[step]]
at_ms = 90
set = { "I 1.0" = 0 }
[[step]]
at_ms = 100
expect = { "Q 2.0" = 0, "Q 2.2" = 0 }
"""

#: line -> hits, worked out by hand from the scenario
MAIN_LINES = {
    10: 21, 11: 21, 12: 21,  # always
    13: 11, 14: 11,          # JC not taken: from the 11th cycle (I 1.1)
    16: 21, 17: 21, 19: 21, 20: 21,
    21: 3, 22: 3, 25: 3,     # BEC not taken: I 1.0 off, the last 3 cycles
}
MAIN_BRANCHES = {12: (10, 11), 17: (5, 16), 20: (18, 3)}
MAIN_CONDITIONS = {  # (line, operand): (read as 0, read as 1)
    (10, "I 1.0"): (3, 18), (11, "I 1.1"): (10, 11), (13, "I 1.2"): (11, 0),
    (16, "I 1.3"): (16, 5), (19, "I 1.0"): (3, 18), (21, "I 1.3"): (0, 3),
    (25, "I 1.0"): (3, 0), (25, "I 1.1"): (0, 3),
}
#: the block runs in the 5 cycles with I 1.3; no flag is ever set
LATCH_LINES = {8: 5, 9: 5, 11: 5, 12: 5, 13: 5, 15: 5, 16: 5, 17: 5}


@pytest.fixture
def project(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "plc").mkdir()
    (tmp_path / "plc" / "main.asi").write_text(MAIN)
    (tmp_path / "plc" / "main.scenario.toml").write_text(SCENARIO)
    shutil.copy(ROOT / "demos" / "latch.fb", tmp_path / "plc" / "latch.fb")
    return tmp_path


def _test(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, ["test", "-j", "1", *args])
    return result.exit_code, result.output


def test_json_counts_are_the_ones_worked_out_by_hand(project: Path):
    code, output = _test("plc", "--coverage", "cov.json")
    assert code == 0, output
    report = json.loads((project / "cov.json").read_text())
    assert report["format"] == "asictl-coverage" and report["version"] == 1
    assert sorted(report["files"]) == ["plc/latch.fb", "plc/main.asi"]  # relative, '/'
    main_asi, latch = report["files"]["plc/main.asi"], report["files"]["plc/latch.fb"]
    assert {r["line"]: r["hits"] for r in main_asi["lines"]} == MAIN_LINES
    assert {r["line"]: (r["taken"], r["not_taken"]) for r in main_asi["branches"]} \
        == MAIN_BRANCHES
    assert {(r["line"], r["operand"]): (r["zero"], r["one"])
            for r in main_asi["conditions"]} == MAIN_CONDITIONS
    assert [r["column"] for r in main_asi["conditions"] if r["line"] == 25] == [9, 23]
    assert {r["line"]: r["hits"] for r in latch["lines"]} == LATCH_LINES
    assert latch["branches"] == [{"line": 13, "taken": 0, "not_taken": 5}]
    # 20 statement lines, all run; 8 outcomes of 4 branches, 7 seen; 22 of conditions
    assert report["totals"]["lines"] == {"covered": 20, "total": 20, "percent": 100.0}
    assert report["totals"]["branches"]["covered"] == 7
    assert report["totals"]["conditions"] == {"covered": 15, "total": 22, "percent": 68.18}
    summary = "coverage: lines 100% (20/20), branches 87% (7/8), conditions 68% (15/22)"
    at = output.splitlines().index("1 passed, 0 failed")
    assert output.splitlines()[at + 1] == summary


def test_the_summary_lists_each_missing_outcome_with_the_symbol_names(project: Path):
    """As coverage.py's term-missing: one row per outcome never seen, worked out here from
    the JSON report's counts; a name of the symbol table beside the program is shown."""
    (project / "plc" / "main.symbols.toml").write_text('Spare = "I 1.2"\n')
    code, output = _test("plc", "--coverage", "cov.json")
    assert code == 0, output
    report = json.loads((project / "cov.json").read_text())["files"]
    expected = []
    for file, kinds in report.items():
        expected += [(file, r["line"], 0, f"{file}:{r['line']} never ran")
                     for r in kinds["lines"] if not r["hits"]]
        expected += [(file, r["line"], 0, f"{file}:{r['line']} branch never {what}")
                     for r in kinds["branches"]
                     for what, key in (("taken", "taken"), ("not taken", "not_taken"))
                     if not r[key]]
        for r in kinds["conditions"]:
            name = " (Spare)" if r["operand"] == "I 1.2" and file == "plc/main.asi" else ""
            expected += [(file, r["line"], r["column"],
                          f"{file}:{r['line']}:{r['column']} {r['operand']}{name} never {v}")
                         for v, key in ((0, "zero"), (1, "one")) if not r[key]]
    rows = [line[2:] for line in output.splitlines() if line.startswith("  plc/")]
    assert rows == [text for *_, text in sorted(expected)]
    assert len(rows) == 1 + 7  # the one branch and the 7 condition outcomes never seen
    assert "plc/main.asi:13:13 I 1.2 (Spare) never 1" in rows
    assert "plc/latch.fb:13 branch never taken" in rows


def test_a_line_in_a_loop_counts_each_run_not_each_cycle(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch):
    """docs/testing.md: hits are runs. C 1 is loaded with 3 each cycle and counted down to
    0 by a backward jump: the loop's four lines run 3 times in each of the 5 cycles."""
    monkeypatch.chdir(tmp_path)
    Path("loop.asi").write_text(
        "[SETUP]\n1: iiii, 0\n\n[PROGRAM]\n        L   KC 3\n        AN  F 0.0\n"
        "        S   C 1\nloop:   AN  F 0.0\n        CD  C 1\n        A   C 1\n"
        "        JC  = loop\n        BE\n")
    Path("loop.scenario.toml").write_text(
        '[master]\ncycle_ms = 10\n[[step]]\nat_ms = 40\nexpect = { "C 1" = 0 }\n')
    code, output = _test("loop.scenario.toml", "--coverage", "cov.json")
    assert code == 0, output
    lines = json.loads(Path("cov.json").read_text())["files"]["loop.asi"]["lines"]
    cycles = 5  # at 0, 10, 20, 30 and 40 ms
    assert {r["line"]: r["hits"] for r in lines} == {
        5: cycles, 6: cycles, 7: cycles, 8: 3 * cycles, 9: 3 * cycles, 10: 3 * cycles,
        11: 3 * cycles, 12: cycles}
    doc = " ".join((ROOT / "docs" / "testing.md").read_text().split())
    assert "a loop body run 3 times in a cycle counts 3 for that cycle" in doc


def test_nothing_to_count_reads_n_a_not_100_percent(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch):
    monkeypatch.chdir(tmp_path)
    Path("plain.asi").write_text("[SETUP]\n1: iiii, 0\n\n[PROGRAM]\n"
                                 "        L   KB 1\n        T   FY 10\n")
    Path("plain.scenario.toml").write_text("[[step]]\nat_ms = 10\nexpect = { \"FY 10\" = 1 }\n")
    code, output = _test("plain.scenario.toml", "--coverage", "cov.json")
    assert code == 0, output
    assert "coverage: lines 100% (2/2), branches n/a, conditions n/a" in output


def test_scenarios_add_up_the_same_in_worker_processes(project: Path):
    """Two scenarios of one program: their hits add up, whether -j 1 or 2 ran them."""
    second = SCENARIO.replace("[master]", 'program = "main.asi"\n[master]')
    (project / "plc" / "again.scenario.toml").write_text(second)
    reports = []
    for jobs in ("1", "2"):
        result = CliRunner().invoke(main, ["test", "-j", jobs, "plc", "--coverage", f"{jobs}.json"])
        assert result.exit_code == 0, result.output
        reports.append(json.loads((project / f"{jobs}.json").read_text())["files"])
    assert reports[0] == reports[1]
    lines = {r["line"]: r["hits"] for r in reports[0]["plc/main.asi"]["lines"]}
    assert lines == {line: 2 * hits for line, hits in MAIN_LINES.items()}


def test_coverage_changes_no_result(project: Path):
    """The same run, with and without coverage, for the test program and for a demo that
    calls user and firmware blocks and stops on a configuration error."""
    for scenario in (project / "plc" / "main.scenario.toml", ROOT / "demos" / "fb.scenario.toml"):
        prepared = prepare(None, scenario)
        plain = as_json(simulate(prepared))
        covered_run = simulate(prepare(None, scenario), coverage=True)
        covered = as_json(covered_run)
        assert covered_run.result.coverage is not None
        for report in (plain, covered):
            report.pop("wall_s")
        assert covered == plain


def test_cobertura_is_read_by_pycobertura(project: Path):
    from pycobertura import Cobertura

    code, output = _test("plc", "--coverage", "coverage.xml")
    assert code == 0, output
    report = Cobertura(str(project / "coverage.xml"))
    assert sorted(report.files()) == ["plc/latch.fb", "plc/main.asi"]
    assert report.line_rate() == 1.0
    assert report.total_statements() == 20
    # branch outcomes: 8 of branches (7 seen) and 22 of conditions (15 seen)
    assert report.branch_rate() == pytest.approx(22 / 30, abs=1e-4)
    statuses = dict(report.line_statuses("plc/latch.fb"))
    assert sorted(statuses) == sorted(LATCH_LINES) and statuses[13] == "partial"
    assert "miss" not in statuses.values()  # partial: a line that ran, an outcome missing
    assert report.line_rate("plc/main.asi") == 1.0
    assert report.branch_rate("plc/latch.fb") == pytest.approx(4 / 8)


@pytest.mark.skipif(shutil.which("lcov") is None, reason="needs Debian's lcov (.ci/run)")
def test_lcov_is_read_by_lcov_and_genhtml(project: Path):
    code, output = _test("plc", "--coverage", "coverage.info")
    assert code == 0, output
    summary = subprocess.run(
        ["lcov", "--summary", "coverage.info", "--rc", "lcov_branch_coverage=1"],
        capture_output=True, text=True, check=True,
    )
    text = summary.stdout + summary.stderr
    assert "lines......: 100.0% (20 of 20 lines)" in text
    assert "branches...: 73.3% (22 of 30 branches)" in text
    subprocess.run(["genhtml", "-q", "--branch-coverage", "coverage.info", "-o", "html"],
                   capture_output=True, text=True, check=True)  # finds plc/*.asi from here
    page = (project / "html" / "plc" / "main.asi.gcov.html").read_text()
    assert "JC  FB Latch" in page


def test_lcov_records(project: Path):
    code, _ = _test("plc", "--coverage", "cov.txt", "--coverage-format", "lcov")
    assert code == 0
    records = (project / "cov.txt").read_text().split("end_of_record\n")
    main_asi = next(r for r in records if "SF:plc/main.asi" in r).splitlines()
    assert "DA:13,11" in main_asi and "DA:21,3" in main_asi
    assert {"BRDA:12,0,0,10", "BRDA:12,0,1,11"} <= set(main_asi)  # JC taken, not taken
    assert {"BRDA:25,1,0,0", "BRDA:25,1,1,3"} <= set(main_asi)  # I 1.1 in the gating line
    assert "LF:12" in main_asi and "LH:12" in main_asi


def test_a_line_never_run_and_fail_under(project: Path):
    """A scenario that never switches I 1.0 off: BEC always ends the cycle, the three
    lines after it never run."""
    text = SCENARIO.replace('[[step]]\nat_ms = 90\nset = { "I 1.0" = 0 }\n', "")
    (project / "plc" / "main.scenario.toml").write_text(text)
    code, output = _test("plc", "--coverage", "cov.json", "--coverage-fail-under", "85")
    assert code == 0, output
    assert "coverage: lines 85% (17/20)" in output
    lines = json.loads((project / "cov.json").read_text())["files"]["plc/main.asi"]["lines"]
    assert [r["line"] for r in lines if not r["hits"]] == [21, 22, 25]
    code, output = _test("plc", "--coverage-fail-under", "85.5")
    assert code == 1 and "line coverage 85.00% is below --coverage-fail-under 85.5%" in output


def test_a_report_never_replaces_a_program(project: Path):
    code, output = _test("plc", "--coverage", "plc/main.asi")
    assert code != 0 and "main.asi" in output
    assert (project / "plc" / "main.asi").read_text() == MAIN


def test_pytest_plugin(project: Path, pytester: pytest.Pytester,
                       monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setenv("PYTEST_DISABLE_PLUGIN_AUTOLOAD", "1")
    shutil.copytree(project / "plc", pytester.path / "plc")
    result = pytester.runpytest_subprocess("-p", "asictl.pytest_plugin", "-p", "xdist.plugin",
                                           "-n", "2", "--asictl-coverage", "cov.json", "plc")
    result.assert_outcomes(passed=1)
    result.stdout.fnmatch_lines(["coverage: lines 100% (20/20), branches 87% (7/8), *"])
    report = json.loads((pytester.path / "cov.json").read_text())
    lines = report["files"]["plc/main.asi"]["lines"]
    assert {r["line"]: r["hits"] for r in lines} == MAIN_LINES


def test_sonarqube_generic_coverage(project: Path):
    from xml.etree import ElementTree

    code, _ = _test("plc", "--coverage", "sonar.xml", "--coverage-format", "sonarqube")
    assert code == 0
    root = ElementTree.parse(project / "sonar.xml").getroot()
    assert root.tag == "coverage" and root.get("version") == "1"
    files = {f.get("path"): f for f in root.findall("file")}
    assert sorted(files) == ["plc/latch.fb", "plc/main.asi"]
    lines = {int(e.get("lineNumber", 0)): e.attrib for e in files["plc/main.asi"]}
    assert sorted(lines) == sorted(MAIN_LINES)
    assert all(a["covered"] == "true" for a in lines.values())
    assert (lines[12]["branchesToCover"], lines[12]["coveredBranches"]) == ("2", "2")
    assert (lines[25]["branchesToCover"], lines[25]["coveredBranches"]) == ("4", "2")
    assert "branchesToCover" not in lines[14]


LOOPING = """\
[SETUP]
1: iiii, 0
2: oooo, 0

[PROGRAM]
        A   I 1.0
        =   Q 2.0
        L   KC 200          ; a loop that makes each cycle longer than an AS-i cycle
        AN  F 0.0
        S   C 1
loop:   AN  F 0.0
        CD  C 1
        A   C 1
        JC  = loop
"""


@pytest.mark.parametrize("scenario", [
    *sorted(p.name for p in (ROOT / "demos").glob("*.scenario.toml")), "looping"])
def test_cycles_skipped_as_repeats_count_as_if_each_had_run(
        scenario: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """The hit counts with the master skipping the cycles that repeat the last one (an
    hour of the 1 h timer in a fraction of a second) are those of a master that runs
    every cycle; a program longer than an AS-i cycle among them."""
    from asictl.board.board import Pc2Board

    duration_ms = 120_000.0
    if scenario == "looping":  # each of its cycles runs 200 passes: 10 s of master time
        duration_ms = 10_000.0
        (tmp_path / "loop.asi").write_text(LOOPING)
        path = tmp_path / "loop.scenario.toml"
        path.write_text('program = "loop.asi"\n[master]\ncycle_ms = 1\n[[step]]\nat_ms = 0\n'
                        'set = { "I 1.0" = 1 }\n[[step]]\nat_ms = 2000\nexpect = { "Q 2.0" = 1 }\n')
    else:
        path = ROOT / "demos" / scenario

    def covered() -> object:
        run = simulate(prepare(None, path, duration_ms=duration_ms, allow_partial=True),
                       coverage=True)
        assert run.result.coverage is not None
        return run.result.coverage.to_data()

    skipping = covered()
    monkeypatch.setattr(Pc2Board, "_unchanged", classmethod(lambda cls, runner, before: False))
    assert covered() == skipping
