"""asictl mutate keeps its verdicts (quality/cache.py): a second run takes them from the
cache and reports what a fresh run reports; a change to one program or to its scenario
runs only that program's mutants again; a cache file that is not exactly what asictl
writes is ignored; --no-cache neither reads nor writes."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

import asictl.quality.mutate as mutation
from asictl.cli import main
from asictl.quality.cache import Cache, default_directory

MACHINE = """\
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

MACHINE_SCENARIO = """\
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
def project(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(mutation, "prove_available", lambda: False)  # forks inherit it
    for name, text in (("machine.asi", MACHINE), ("machine.scenario.toml", MACHINE_SCENARIO),
                       ("lamp.asi", LAMP), ("lamp.scenario.toml", LAMP_SCENARIO)):
        (tmp_path / "src" / name).parent.mkdir(exist_ok=True)
        (tmp_path / "src" / name).write_text(text)
    return tmp_path


def _run(*args: str) -> dict[str, Any]:
    result = CliRunner().invoke(main, ["mutate", "src", "-j", "2", "--format", "json", *args])
    assert result.exit_code == 0, result.output
    report: dict[str, Any] = json.loads(result.stdout)
    return report


def _verdicts(report: dict[str, Any]) -> list[dict[str, Any]]:
    """The report's rows without what may differ between a fresh and a cached run."""
    return [{k: v for k, v in row.items() if k not in ("seconds", "cached")}
            for row in report["mutants"]]


def _judged(report: dict[str, Any], file: str) -> list[dict[str, Any]]:
    """The rows of one program's mutants that a run judges (not 'no scenario runs')."""
    return [row for row in report["mutants"] if row["file"] == file
            and row["detail"] != "no scenario runs this line"]


def test_a_second_run_takes_every_verdict_from_the_cache_and_reports_the_same(
        project: Path):
    cache = project / "cache"
    fresh = _run("--cache", str(cache))
    assert fresh["from_cache"] == 0
    again = _run("--cache", str(cache))
    judged = _judged(again, "src/lamp.asi") + _judged(again, "src/machine.asi")
    assert judged and all(row["cached"] for row in judged)
    assert again["from_cache"] == len(judged)
    assert _verdicts(again) == _verdicts(fresh)
    assert {k: v for k, v in again.items() if k not in ("mutants", "from_cache")} == \
        {k: v for k, v in fresh.items() if k not in ("mutants", "from_cache")}
    assert _verdicts(_run("--no-cache")) == _verdicts(fresh)


def test_a_changed_program_runs_only_its_own_mutants_again(project: Path):
    cache = project / "cache"
    _run("--cache", str(cache))
    lamp = project / "src" / "lamp.asi"
    lamp.write_text(LAMP.replace("BE", "BE                  ; the lamp"))
    again = _run("--cache", str(cache))
    assert not any(row["cached"] for row in _judged(again, "src/lamp.asi"))
    machine = _judged(again, "src/machine.asi")
    assert machine and all(row["cached"] for row in machine)
    assert again["from_cache"] == len(machine)
    # and the changed program's new verdicts are kept in turn
    third = _run("--cache", str(cache))
    assert third["from_cache"] == len(machine) + len(_judged(third, "src/lamp.asi"))


def test_a_changed_scenario_runs_its_program_s_mutants_again(project: Path):
    cache = project / "cache"
    fresh = _run("--cache", str(cache))
    scenario = project / "src" / "machine.scenario.toml"
    scenario.write_text(MACHINE_SCENARIO + """\
[[step]]
at_ms = 120
set = { "I 1.2" = 1, "I 1.1" = 1 }
[[step]]
at_ms = 160
expect = { "Q 2.1" = 0 }
""")
    again = _run("--cache", str(cache))
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
def test_a_damaged_or_foreign_cache_file_is_ignored(project: Path, damage: bytes | str):
    cache = project / "cache"
    fresh = _run("--cache", str(cache))
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
    again = _run("--cache", str(cache))
    assert again["from_cache"] == 0
    assert _verdicts(again) == _verdicts(fresh)
    # and the file is written again, whole
    assert _run("--cache", str(cache))["from_cache"] > 0


def test_no_cache_neither_reads_nor_writes(project: Path):
    cache = project / "cache"
    assert _run("--no-cache")["from_cache"] == 0
    assert not default_directory().exists()
    _run("--cache", str(cache))
    assert _run("--no-cache")["from_cache"] == 0
    result = CliRunner().invoke(main, ["mutate", "src", "--cache", str(cache), "--no-cache"])
    assert result.exit_code == 2
    assert "--no-cache" in result.output and "Traceback" not in result.output


def test_the_default_cache_is_under_xdg_cache_home(project: Path,
                                                     monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(project / "xdg"))
    assert _run()["from_cache"] == 0
    assert len(list((project / "xdg" / "asictl" / "mutate").glob("*.json"))) == 2
    assert _run()["from_cache"] > 0
    result = CliRunner().invoke(main, ["mutate", "src", "-j", "2"])
    assert "verdicts from the cache" in result.output


def test_a_cache_that_cannot_be_written_is_a_warning(project: Path):
    """The folder cannot be made (a file stands where it would go): the run is made and
    reported all the same, with a warning; the exit status is the run's."""
    (project / "plain").write_text("a file, not a folder\n")
    result = CliRunner().invoke(main, ["mutate", "src", "-j", "2",
                                       "--cache", str(project / "plain" / "cache")])
    assert result.exit_code == 0, result.output
    assert "warning:" in result.output and "results not kept" in result.output
    assert "mutants:" in result.output


def test_what_is_never_kept(tmp_path: Path):
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
