"""``--shard I/N`` of test, mutate and prove, and ``asictl report merge``: the merged
reports of the shards are the report of one run over all files, byte for byte once the
times (JUnit ``time``, json ``seconds``, Cobertura's ``timestamp``) are blanked, since
they differ between any two runs."""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner, Result

from asictl.cli import main

DEMOS = Path(__file__).resolve().parent.parent / "demos"
#: small programs, each with its scenario and properties; three files for two shards
#: make the shards unequal, for five leave two empty
PROGRAMS = ("blink", "logic", "edge")


def _timeless(text: str) -> str:
    text = re.sub(r'\b(time|timestamp)="[^"]*"', r'\1=""', text)
    return re.sub(r'"seconds": [^,\n}]+', '"seconds": 0', text)


@pytest.fixture
def project(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A folder with copies of a few demos (Cobertura names the current folder)."""
    folder = tmp_path / "demos"
    folder.mkdir()
    for name in PROGRAMS:
        for suffix in (".asi", ".scenario.toml", ".props.toml"):
            shutil.copy(DEMOS / f"{name}{suffix}", folder)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _asictl(*args: str) -> Result:
    return CliRunner().invoke(main, list(args), catch_exceptions=False)


def _ok(*args: str) -> Result:
    result = _asictl(*args)
    assert result.exit_code == 0, (args, result.output)
    return result


def _read(path: str) -> str:
    return Path(path).read_text(encoding="utf-8")


@pytest.mark.parametrize("total", [2, 5])
def test_the_merged_junit_and_coverage_are_those_of_one_run(project: Path, total: int):
    _ok("test", "demos", "-j", "1", "--junit", "all.xml", "--coverage", "all.json")
    shards = [str(i) for i in range(1, total + 1)]
    for i in shards:
        result = _ok("test", "demos", "-j", "1", "--shard", f"{i}/{total}",
                     "--junit", f"junit-{i}.xml", "--coverage", f"coverage-{i}.json")
        if int(i) > len(PROGRAMS):
            assert "0 passed, 0 failed" in result.output
            assert f"shard {i}/{total} has no scenario files (3 in all)" in result.output
    _ok("report", "merge", *[f"junit-{i}.xml" for i in shards], "-o", "merged.xml")
    assert _timeless(_read("merged.xml")) == _timeless(_read("all.xml"))
    assert "<testcase" in _read("merged.xml")
    _ok("report", "merge", *[f"coverage-{i}.json" for i in shards], "-o", "merged.json")
    assert _read("merged.json") == _read("all.json")
    # the merged json written in each of test's coverage formats is what test writes
    for name, fmt in [("all.xml", "cobertura"), ("all.info", "lcov"),
                      ("all.sonar.xml", "sonarqube")]:
        _ok("test", "demos", "-j", "1", "--coverage", f"full-{name}",
            "--coverage-format", fmt)
        _ok("report", "merge", *[f"coverage-{i}.json" for i in shards],
            "-o", f"merged-{name}", "--coverage-format", fmt)
        if fmt == "cobertura":  # the only one with a time in it
            assert _timeless(_read(f"merged-{name}")) == _timeless(_read(f"full-{name}"))
        else:
            assert _read(f"merged-{name}") == _read(f"full-{name}")


def test_each_scenario_runs_in_one_shard(project: Path):
    ran = []
    for i in (1, 2, 3):
        result = _ok("test", "demos", "-j", "1", "--shard", f"{i}/3", "--format", "json")
        scenarios = [s["path"] for s in json.loads(result.stdout)["scenarios"]]
        assert len(scenarios) == 1
        ran += scenarios
    assert sorted(ran) == sorted(f"demos/{p}.scenario.toml" for p in PROGRAMS)


def test_the_merged_mutation_report_is_that_of_one_run(project: Path):
    # judged afresh, as the shards are (they would otherwise take it from the cache)
    whole = _ok("mutate", "demos", "-j", "1", "--format", "json", "--no-cache").stdout
    for i in (1, 2):
        Path(f"mutants-{i}.json").write_text(
            _ok("mutate", "demos", "-j", "1", "--format", "json", "--shard", f"{i}/2").stdout,
            encoding="utf-8")
    merged = _ok("report", "merge", "mutants-1.json", "mutants-2.json").stdout
    assert _timeless(merged) == _timeless(whole)
    shards = [{m["file"] for m in json.loads(_read(f"mutants-{i}.json"))["mutants"]}
              for i in (1, 2)]
    assert not shards[0] & shards[1]
    assert shards[0] | shards[1] == {f"demos/{p}.asi" for p in PROGRAMS}


@pytest.mark.parametrize("total", [2, 4])
def test_the_merged_proof_report_is_that_of_one_run(project: Path, total: int):
    files = sorted(str(p.relative_to(project)) for p in project.glob("demos/*.props.toml"))
    whole = _ok("prove", *files, "--format", "json").stdout
    shards = range(total, 0, -1)  # the order of the inputs does not matter
    for i in shards:
        Path(f"proofs-{i}.json").write_text(
            _ok("prove", *files, "--format", "json", "--shard", f"{i}/{total}").stdout,
            encoding="utf-8")
    merged = _ok("report", "merge", *[f"proofs-{i}.json" for i in shards]).stdout
    assert _timeless(merged) == _timeless(whole)
    assert len(json.loads(merged)["files"]) == len(PROGRAMS)


@pytest.mark.parametrize("command", [["test", "demos"], ["mutate", "demos"],
                                     ["prove", "demos/blink.asi"]])
@pytest.mark.parametrize(("value", "says"), [
    ("0/2", "'0/2': I counts from 1 to N (2)"),
    ("3/2", "'3/2': I counts from 1 to N (2)"),
    ("1/0", "'1/0': N is at least 1"),
    ("half", "'half' is not I/N (e.g. 1/4) or auto"),
])
def test_a_shard_that_is_none_is_a_usage_error(project: Path, command: list[str],
                                                value: str, says: str):
    result = _asictl(*command, "--shard", value)
    assert result.exit_code == 2
    assert f"Invalid value for '--shard': {says}" in result.output
    assert "Traceback" not in result.output


def test_shard_auto_takes_gitlab_parallel(project: Path, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setenv("CI_NODE_INDEX", "2")
    monkeypatch.setenv("CI_NODE_TOTAL", "3")
    result = _ok("test", "demos", "-j", "1", "--shard", "auto", "--format", "json")
    assert [s["path"] for s in json.loads(result.stdout)["scenarios"]] == sorted(
        f"demos/{p}.scenario.toml" for p in PROGRAMS)[1:2]
    monkeypatch.setenv("CI_NODE_INDEX", "4")
    result = _asictl("test", "demos", "--shard", "auto")
    assert result.exit_code == 2
    assert "CI_NODE_INDEX/CI_NODE_TOTAL '4/3': I counts from 1 to N (3)" in result.output


@pytest.fixture
def shards(project: Path) -> Path:
    for i in (1, 2):
        _ok("test", "demos", "-j", "1", "--shard", f"{i}/2", "--junit", f"junit-{i}.xml",
            "--coverage", f"coverage-{i}.json")
    return project


@pytest.mark.parametrize(("files", "says"), [
    (["junit-1.xml", "coverage-2.json"], "coverage-2.json: json coverage (test --coverage "
     "FILE.json), but junit-1.xml is JUnit XML (test --junit): merge reports of one kind"),
    (["junit-1.xml", "copy.xml"], "demos/blink.scenario.toml is in both junit-1.xml and "
     "copy.xml: these are not the shards of one split"),
    (["junit-1.xml", "junit-1.xml"], "junit-1.xml: given twice"),
    (["cobertura.xml"], "cobertura.xml: XML coverage cannot be merged exactly: write each "
     "shard's coverage as json"),
    (["demos/blink.props.toml"], "demos/blink.props.toml: neither XML nor JSON"),
    (["other.json"], "other.json: not a report asictl merges"),
    (["broken.xml"], "broken.xml: not well-formed XML"),
    (["bad-coverage.json"], "bad-coverage.json: not json coverage (test --coverage "
     "FILE.json) as asictl writes it"),
    (["missing.xml"], "missing.xml: cannot read"),
    (["deep.json"], "deep.json: JSON nested too deeply for a report"),
    (["deep.xml"], "deep.xml: not JUnit XML (test --junit) as asictl writes it"),
    (["nameless.xml"], "nameless.xml: not JUnit XML (test --junit) as asictl writes it"),
    (["bad-mutants.json"], "bad-mutants.json: not a mutation report (mutate --format json) "
     "as asictl writes it"),
    (["bad-proofs.json"], "bad-proofs.json: not a proof report (prove --format json) as "
     "asictl writes it"),
])
def test_what_merge_refuses(shards: Path, files: list[str], says: str):
    shutil.copy("junit-1.xml", "copy.xml")
    _ok("test", "demos", "-j", "1", "--coverage", "cobertura.xml")
    Path("other.json").write_text('{"scenarios": []}', encoding="utf-8")
    Path("broken.xml").write_text("<testsuite>", encoding="utf-8")
    Path("bad-coverage.json").write_text('{"format": "asictl-coverage", "files": {"a": 1}}',
                                         encoding="utf-8")
    Path("deep.json").write_text("[" * 100_000 + "]" * 100_000, encoding="utf-8")
    Path("deep.xml").write_text('<testsuite><testcase name="a">' + "<x>" * 5000
                                + "</x>" * 5000 + "</testcase></testsuite>", encoding="utf-8")
    Path("nameless.xml").write_text("<testsuite><testcase/></testsuite>", encoding="utf-8")
    Path("bad-mutants.json").write_text('{"mutants": [{"file": 1}]}', encoding="utf-8")
    Path("bad-proofs.json").write_text('{"files": [{"program": "a.asi"}]}', encoding="utf-8")
    result = _asictl("report", "merge", *files, "-o", "out.xml")
    assert result.exit_code == 2, result.output
    assert f"asictl: error: {says}" in result.output
    assert not Path("out.xml").exists()


def test_merge_never_writes_over_a_shard(shards: Path):
    before = _read("junit-1.xml")
    result = _asictl("report", "merge", "junit-1.xml", "junit-2.xml", "-o", "junit-1.xml")
    assert result.exit_code == 2
    assert _read("junit-1.xml") == before


#: one program, a scenario for each way of its jump: each shard alone covers 4 of its 6
#: lines, the two together all
JUMP = """\
[SETUP]
1: iiii, 0
2: oooo, 0

[PROGRAM]
        A   I 1.0
        JC  = high
        R   Q 2.0
        BE
high:   S   Q 2.0
        BE
"""


def test_coverage_fail_under_judges_the_merged_run(project: Path):
    folder = project / "jump"
    folder.mkdir()
    (folder / "jump.asi").write_text(JUMP, encoding="utf-8")
    for name, value in (("high", 1), ("low", 0)):
        (folder / f"{name}.scenario.toml").write_text(
            f'program = "jump.asi"\n[[step]]\nat_ms = 0\nset = {{ "I 1.0" = {value} }}\n'
            f'[[step]]\nat_ms = 50\nexpect = {{ "Q 2.0" = {value} }}\n', encoding="utf-8")
    for i in (1, 2):
        result = _asictl("test", "jump", "-j", "1", "--shard", f"{i}/2",
                         "--coverage", f"jump-{i}.json", "--coverage-fail-under", "100")
        assert result.exit_code == 1
        assert "coverage: lines 66% (4/6)" in result.output
    merged = _ok("report", "merge", "jump-1.json", "jump-2.json",
                 "--coverage-fail-under", "100", "-o", "merged.json")
    assert "coverage: lines 100% (6/6), branches 100% (2/2), conditions 100% (2/2)" in (
        merged.output)
    _ok("test", "jump", "-j", "1", "--coverage", "all.json")
    assert _read("merged.json") == _read("all.json")
    result = _asictl("report", "merge", "jump-1.json", "--coverage-fail-under", "70.5")
    assert result.exit_code == 1
    assert "line coverage 66.67% is below --coverage-fail-under 70.5%" in result.output


def test_a_bar_for_another_kind_is_a_usage_error(shards: Path):
    result = _asictl("report", "merge", "junit-1.xml", "junit-2.xml", "--min-score", "80")
    assert result.exit_code == 2
    assert ("--min-score is a bar for a mutation report (mutate --format json); "
            "junit-1.xml is JUnit XML") in result.output


def test_min_score_on_merged_mutants(project: Path):
    mutants = []
    for i in (1, 2):
        Path(f"mutants-{i}.json").write_text(
            _ok("mutate", "demos/blink.scenario.toml", "demos/edge.scenario.toml", "-j", "1",
                "--format", "json", "--shard", f"{i}/2").stdout, encoding="utf-8")
        mutants += json.loads(_read(f"mutants-{i}.json"))["mutants"]
    killed = sum(m["verdict"] in ("killed", "timeout") for m in mutants)
    counted = sum(m["verdict"] in ("killed", "timeout", "survived", "died") for m in mutants)
    share = 100 * killed / counted
    assert share < 100  # some survive, so the bar can be missed
    merged = _ok("report", "merge", "mutants-1.json", "mutants-2.json",
                 "--min-score", repr(share), "-o", "merged.json")
    assert json.loads(_read("merged.json"))["score"] == round(share, 2)
    assert merged.exit_code == 0
    result = _asictl("report", "merge", "mutants-1.json", "mutants-2.json",
                     "--min-score", "100", "-o", "merged.json")
    assert result.exit_code == 1
    assert f"mutation score {share:.1f}% is below --min-score 100%" in result.output


def _recipes() -> dict[str, str]:
    """The CI recipes of docs/testing.md's section on shards, by what runs them."""
    page = (Path(__file__).resolve().parent.parent / "docs" / "testing.md").read_text()
    section = page.split("\n## Shards", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"^```yaml\n(.*?)^```$", section, re.M | re.S)
    return {"github": next(b for b in blocks if "matrix:" in b),
            "gitlab": next(b for b in blocks if "parallel:" in b)}


def _commands(job: str) -> list[str]:
    return re.findall(r"^\s*- (?:run: )?(asictl .*)$", job, re.M)


def _bash(command: str, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    define = f'asictl() {{ {shlex.quote(sys.executable)} -m asictl "$@"; }}\n'
    return subprocess.run(["bash", "-c", define + command], capture_output=True, text=True,
                          env={**os.environ, **env}, timeout=600)


def _recipe_env(project: Path) -> dict[str, str]:
    return {"PYTHONPATH": os.pathsep.join(
        [str(Path(__file__).resolve().parent.parent / "src"), os.environ.get("PYTHONPATH", "")]),
        "ASICTL_STATE_DIR": str(project / "state")}


def _found(pattern: str, text: str) -> str:
    match = re.search(pattern, text)
    assert match, pattern
    return match[1]


def test_the_github_actions_recipe_runs_as_its_matrix_would(
        project: Path, monkeypatch: pytest.MonkeyPatch):
    recipe = _recipes()["github"]
    tests, merge = recipe.split("\n  plc-report:", 1)
    total = len(_found(r"shard: \[([\d, ]+)\]", tests).split(","))
    assert "SHARD: ${{ matrix.shard }}" in tests and f"/{total} " in tests
    monkeypatch.chdir(project / "demos")  # the repository's root: the programs are in it
    env = _recipe_env(project)
    for i in range(1, total + 1):
        for command in _commands(tests):
            result = _bash(command, {**env, "SHARD": str(i)})
            assert result.returncode == 0, (i, command, result.stdout, result.stderr)
    summary = project / "summary.md"
    for command in _commands(merge):
        result = _bash(command, {**env, "GITHUB_STEP_SUMMARY": str(summary)})
        assert result.returncode == 0, (command, result.stdout, result.stderr)
    assert _read("junit.xml").count("<testcase") == len(PROGRAMS)
    assert summary.read_text().startswith("coverage: lines ")
    assert "end_of_record" in _read("coverage.info")


def test_the_gitlab_parallel_recipe_runs_as_gitlab_would(
        project: Path, monkeypatch: pytest.MonkeyPatch):
    recipe = _recipes()["gitlab"]
    tests, merge = recipe.split("\nplc-coverage:", 1)
    total = int(_found(r"parallel: (\d+)", tests))
    monkeypatch.chdir(project / "demos")
    env = _recipe_env(project)
    for i in range(1, total + 1):
        for command in _commands(tests):
            result = _bash(command, {**env, "CI_NODE_INDEX": str(i),
                                     "CI_NODE_TOTAL": str(total)})
            assert result.returncode == 0, (i, command, result.stdout, result.stderr)
    (command,) = _commands(merge)
    result = _bash(command, env)
    assert result.returncode == 0, (command, result.stdout, result.stderr)
    # GitLab's coverage regex finds the merged line coverage in the job's log
    found = re.search(_found(r"coverage: '/(.*)/'", merge), result.stdout + result.stderr)
    _ok("test", ".", "-j", "1", "--coverage", "all.json")
    lines = json.loads(_read("all.json"))["totals"]["lines"]
    assert found and int(found[1]) == lines["covered"] * 100 // lines["total"]
    assert _read("coverage.xml").count("<class ") == len(PROGRAMS)
    assert sorted(Path().glob("junit-*.xml")) == [Path(f"junit-{i}.xml")
                                                   for i in range(1, total + 1)]
