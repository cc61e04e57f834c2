"""The README's set-up commands cannot rot: CI runs its test command verbatim."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def readme_commands() -> list[str]:
    text = (ROOT / "README.md").read_text()
    block = re.search(r"```sh\n(.*?)```", text, re.S)
    assert block, "README must open with a sh block of set-up commands"
    return [line for line in block.group(1).splitlines() if line.strip()]


def test_readme_opens_with_exactly_two_commands():
    text = (ROOT / "README.md").read_text()
    assert text.index("```sh") < text.index("\n## "), "the set-up commands come first"
    assert len(readme_commands()) == 2


def test_ci_runs_the_readme_test_command():
    test_command = readme_commands()[1]
    assert "pytest" in test_command
    assert test_command in (ROOT / ".ci" / "run").read_text().splitlines()


def test_the_readme_installs_what_ci_installs_for_the_tests():
    """The one line next to the test command that installs the Debian and npm tools the
    suite needs names every package .ci/run installs, and nothing else."""
    text = " ".join((ROOT / "README.md").read_text().split())
    line = re.search(r"`apt-get install -y ([^`&]*) && (npm ci [^`]*)`", text)
    assert line, "the README gives the one install line next to the test command"
    ci = (ROOT / ".ci" / "run").read_text()
    installed = re.findall(r"apt-get install -y (.*)", ci)
    assert sorted(line[1].split()) == sorted(" ".join(installed).split())
    assert line[2].split() == re.search(r"(npm ci .*?) --no-audit", ci)[1].split()


def _yaml_blocks() -> list[str]:
    return re.findall(r"```yaml\n(.*?)```", (ROOT / "README.md").read_text(), re.S)


def test_the_pre_commit_recipe_names_the_hook():
    (pre_commit,) = [b for b in _yaml_blocks() if "hooks:" in b]
    hook = re.search(r"id: ([\w-]+)", pre_commit)
    assert hook and f"- id: {hook.group(1)}" in (ROOT / ".pre-commit-hooks.yaml").read_text()


def test_the_ci_recipe_is_ten_lines_and_its_commands_pass_on_the_demos(tmp_path):
    """The workflow's asictl steps, run as CI would in a project holding the demos."""
    import os
    import shutil
    import subprocess
    import sys

    (workflow,) = [b for b in _yaml_blocks() if "runs-on:" in b]
    assert len(workflow.splitlines()) <= 10
    commands = re.findall(r"- run: (asictl .*)", workflow)
    assert [c.split()[1] for c in commands] == ["check", "test"]
    project = tmp_path / "project"
    shutil.copytree(ROOT / "demos", project)
    for command in commands:
        result = subprocess.run(
            [sys.executable, "-m", *command.split()], cwd=project, capture_output=True,
            text=True, env={**os.environ, "ASICTL_STATE_DIR": str(tmp_path / "state")},
            timeout=600,
        )
        assert result.returncode == 0, (command, result.stdout, result.stderr)
        assert "::error" not in result.stdout and "::warning" not in result.stdout
    assert (project / "scenarios.xml").read_text().count("<testcase") == len(
        list((ROOT / "demos").glob("*.scenario.toml"))
    )
