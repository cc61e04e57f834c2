"""The one build pipeline: every kind of program file builds the same image and runs the same.

The bar: a program's scenario passes whether the program is given as source, as the
.hex image ``compile`` writes, or as the [RAW]-only file an upload writes for an image
without source.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.build import Origin, build, build_file, check, is_hex
from asictl.cli import main
from asictl.codes import ImageCode
from asictl.host.program_files import uploaded_source
from asictl.source import from_string

ROOT = Path(__file__).resolve().parents[1]
DEMOS = ROOT / "demos"
SCENARIOS = sorted(DEMOS.glob("*.scenario.toml"))


def demo_of(scenario: Path) -> Path:
    return scenario.with_name(scenario.name.removesuffix(".scenario.toml") + ".asi")


def sim(runner: CliRunner, program: Path, scenario: Path, *extra: str):
    return runner.invoke(main, ["sim", str(program), "--scenario", str(scenario), *extra])


def passed(result) -> bool:
    return result.exit_code == 0 and re.search(r"\d+ expectations?, 0 failed", result.output)


@pytest.mark.parametrize("scenario", SCENARIOS, ids=lambda p: p.name)
def test_every_demo_passes_as_source_hex_and_raw(
    scenario: Path, tmp_path: Path, runner: CliRunner
):
    source = demo_of(scenario)
    built = build_file(source)
    assert built.image is not None and built.origin is Origin.SOURCE
    assert passed(sim(runner, source, scenario))

    hex_file = tmp_path / "program.hex"
    hex_file.write_text(built.image.to_hex())
    result = sim(runner, hex_file, scenario)
    assert passed(result), result.output + result.stderr

    no_source = build_file(source, with_source=False).image
    assert no_source is not None
    raw_file = tmp_path / "uploaded.asi"
    raw_file.write_text(uploaded_source(no_source))
    result = sim(runner, raw_file, scenario)
    assert passed(result), result.output + result.stderr


def test_a_trace_of_an_image_without_source_says_what_it_cannot_show(
    tmp_path: Path, runner: CliRunner
):
    no_source = build_file(DEMOS / "blink.asi", with_source=False).image
    assert no_source is not None
    raw_file = tmp_path / "uploaded.asi"
    raw_file.write_text(uploaded_source(no_source))
    result = sim(runner, raw_file, DEMOS / "blink.scenario.toml",
                 "--csv", str(tmp_path / "trace.csv"))
    assert passed(result), result.output + result.stderr
    assert "the image carries no source" in result.stderr
    assert (tmp_path / "trace.csv").read_text().startswith("time_ms,")


def test_an_uploaded_raw_file_simulates_after_a_real_download_and_upload(
    tmp_path: Path, runner: CliRunner
):
    """The user's path of the bug report: compile --no-source, download, upload, sim."""
    source = DEMOS / "blink.asi"
    image = tmp_path / "b.hex"
    state = ["--state-dir", str(tmp_path / "boards")]
    assert runner.invoke(main, ["compile", str(source), "--no-source", "-o", str(image)]
                         ).exit_code == 0
    assert runner.invoke(main, ["download", str(image), *state]).exit_code == 0
    uploaded = tmp_path / "raw" / "b.asi"
    uploaded.parent.mkdir()
    assert runner.invoke(main, ["upload", "-o", str(uploaded), *state]).exit_code == 0
    assert "[RAW]" in uploaded.read_text()
    result = sim(runner, uploaded, DEMOS / "blink.scenario.toml")
    assert passed(result), result.output + result.stderr
    result = sim(runner, image, DEMOS / "blink.scenario.toml")
    assert passed(result), result.output + result.stderr


def test_hex_with_source_traces_the_programs_own_operands(tmp_path: Path, runner: CliRunner):
    source = DEMOS / "logic.asi"
    hex_file = tmp_path / "logic.hex"
    assert runner.invoke(main, ["compile", str(source), "-o", str(hex_file)]).exit_code == 0
    from_source, from_hex = tmp_path / "a.csv", tmp_path / "b.csv"
    scenario = DEMOS / "logic.scenario.toml"
    assert passed(sim(runner, source, scenario, "--csv", str(from_source)))
    result = sim(runner, hex_file, scenario, "--csv", str(from_hex))
    assert passed(result) and "no source" not in result.stderr
    assert from_hex.read_text() == from_source.read_text()


def test_sim_shows_the_warnings_check_shows(tmp_path: Path, runner: CliRunner):
    program = tmp_path / "w.asi"
    program.write_text("[SETUP]\n1: iiii, 0\n[PROGRAM]\n    L KT 505\n    A I 1.0\n    = F 1.0\n")
    checked = runner.invoke(main, ["check", str(program)])
    warning = next(line for line in checked.stderr.splitlines() if "warning" in line)
    result = runner.invoke(main, ["sim", str(program), "--duration", "50ms"])
    assert result.exit_code == 0
    assert warning in result.stderr


def test_hex_is_recognised_by_its_content_not_its_name(tmp_path: Path, runner: CliRunner):
    image = build_file(DEMOS / "blink.asi").image
    assert image is not None
    disguised = tmp_path / "blink.txt"
    disguised.write_text(image.to_hex())
    assert is_hex(disguised.read_text()) and not is_hex((DEMOS / "blink.asi").read_text())
    result = sim(runner, disguised, DEMOS / "blink.scenario.toml")
    assert passed(result), result.output + result.stderr


def test_raw_problems_are_diagnostics_at_the_raw_section():
    image = build_file(DEMOS / "blink.asi", with_source=False).image
    assert image is not None
    text = uploaded_source(image)
    edited = text.replace("auto_start: yes", "auto_start: no")
    built = build(from_string("u.asi", edited))
    (problem,) = built.diagnostics
    raw_line = edited.split("\n").index("[RAW]") + 1
    assert problem.code == ImageCode.RAW_MISMATCH and problem.span is not None
    assert problem.span.line == raw_line and built.image is None
    lines = text.split("\n")
    at = next(i for i, line in enumerate(lines) if line.startswith(":10"))
    lines[at] = lines[at][:-2] + ("00" if lines[at][-2:] != "00" else "01")  # bad checksum
    checked = check(from_string("u.asi", "\n".join(lines)))
    assert [d.code for d in checked.diagnostics] == [ImageCode.RAW_INVALID]
    assert "checksum" in checked.diagnostics[0].message.lower()
