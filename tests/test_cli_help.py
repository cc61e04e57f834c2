"""``asictl --help`` in sections, an example ending every command's help, the generated
command reference (docs/commands.md) and shell completion."""

from __future__ import annotations

import sys
from pathlib import Path

import click
from click.testing import CliRunner

from asictl.cli import COMMANDS, SECTIONS, main

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))

import commands_doc  # noqa: E402 - tools/ is not a package


def test_every_command_is_in_exactly_one_section():
    placed = [name for names in SECTIONS.values() for name in names]
    missing = sorted(set(COMMANDS) - set(placed))
    assert not missing, (
        f"commands without a section in 'asictl --help': {missing}; add each to one "
        "section of SECTIONS in src/asictl/cli/__init__.py"
    )
    twice = sorted({name for name in placed if placed.count(name) > 1})
    assert not twice, f"commands in more than one section of SECTIONS: {twice}"
    unknown = sorted(set(placed) - set(COMMANDS))
    assert not unknown, f"SECTIONS names commands that COMMANDS does not have: {unknown}"


def _listed(output: str) -> dict[str, list[str]]:
    """Section title -> the command names listed under it, as ``--help`` prints them."""
    sections: dict[str, list[str]] = {}
    current = None
    for line in output.splitlines():
        if line and not line.startswith(" ") and line.endswith(":"):
            current = line[:-1]
            sections[current] = []
        elif current is not None and line.startswith("  ") and not line.startswith("   "):
            sections[current].append(line.split()[0])
    return sections


def test_help_lists_every_command_under_its_section_in_order():
    result = CliRunner().invoke(main, ["--help"])
    assert result.exit_code == 0, result.output
    listed = _listed(result.output)
    listed.pop("Options")
    assert listed == {title: list(names) for title, names in SECTIONS.items()}


def test_a_command_without_a_section_is_still_listed(monkeypatch):
    """A command added to COMMANDS before it has a section shows up, under "Other"."""
    monkeypatch.setitem(COMMANDS, "newcomer", ("asictl.cli.check:check", "A new command."))
    result = CliRunner().invoke(main, ["--help"])
    assert _listed(result.output)["Other"] == ["newcomer"]


def test_subcommand_groups_keep_a_plain_listing():
    result = CliRunner().invoke(main, ["bus", "--help"])
    assert _listed(result.output)["Commands"] == ["inputs", "match", "plug", "show", "unplug"]


def test_every_command_and_subcommand_ends_with_an_example_of_itself():
    """An ``Example:`` block ends each help, and one of its lines runs the command."""
    without, not_itself = [], []
    for ctx, command in commands_doc.commands():
        lines = commands_doc.examples(command)
        if not lines:
            without.append(ctx.command_path)
        elif not any(f"{ctx.command_path} " in f"{line} " for line in lines):
            not_itself.append(ctx.command_path)
    assert not without, f"no Example: block at the end of the help of {without}"
    assert not not_itself, f"the examples of {not_itself} do not run the command itself"


def test_the_examples_show_in_help_as_written():
    """Click keeps the block's lines (the \\b before it), indented under the heading."""
    result = CliRunner().invoke(main, ["test", "--help"])
    assert "  Examples:\n    asictl test demos\n    asictl test demos/blink" in result.output


def test_an_example_block_is_found_only_at_the_end():
    @click.command()
    def early() -> None:
        """Does something.

        \b
        Example:
          asictl early

        More text after the example.
        """

    @click.command()
    def late() -> None:
        """Does something.

        \b
        Examples:
          asictl late
          asictl late --twice   # a comment
        """

    assert commands_doc.examples(early) == []
    assert commands_doc.examples(late) == ["asictl late", "asictl late --twice   # a comment"]


def test_the_command_reference_is_generated_from_the_click_tree(capsys):
    assert commands_doc.run(["--check"]) == 0, capsys.readouterr().out


def test_a_stale_command_reference_is_reported(tmp_path, monkeypatch, capsys):
    stale = tmp_path / "commands.md"
    stale.write_text(commands_doc.DOC.read_text().replace("asictl check demos\n", ""))
    monkeypatch.setattr(commands_doc, "DOC", stale)
    assert commands_doc.run(["--check"]) == 1
    assert "out of date: run python3 tools/commands_doc.py" in capsys.readouterr().out
    assert commands_doc.run([]) == 0 and commands_doc.run(["--check"]) == 0


def test_the_command_reference_has_every_command_long_option_and_example():
    text = (ROOT / "docs" / "commands.md").read_text(encoding="utf-8")
    for ctx, command in commands_doc.commands():
        assert f"#{'##' if ctx.parent is ctx.find_root() else '###'} {ctx.command_path}\n" in text
        for param in command.params:
            if isinstance(param, click.Option) and "--help" not in param.opts:
                name = max(param.opts, key=len)
                assert f"`{name}" in text or f", {name}" in text, (ctx.command_path, name)
        for line in commands_doc.examples(command):
            assert f"\n{line}\n" in text, (ctx.command_path, line)


def _complete(env: dict[str, str]) -> str:
    result = CliRunner().invoke(main, [], prog_name="asictl", env=env)
    assert result.exit_code == 0, result.output
    return result.output


def test_shell_completion_scripts_are_produced():
    """The scripts docs/commands.md tells users to load, for bash, zsh and fish."""
    assert "complete -o nosort -F _asictl_completion asictl" in _complete(
        {"_ASICTL_COMPLETE": "bash_source"})
    assert "compdef _asictl_completion asictl" in _complete({"_ASICTL_COMPLETE": "zsh_source"})
    assert "complete --no-files --command asictl" in _complete(
        {"_ASICTL_COMPLETE": "fish_source"})


def test_completion_completes_commands_and_options():
    """What the bash script asks for: the lazily loaded commands and their options."""
    words = _complete({"_ASICTL_COMPLETE": "bash_complete", "COMP_WORDS": "asictl st",
                       "COMP_CWORD": "1"})
    assert words.split() == ["plain,start", "plain,status", "plain,stop", "plain,store"]
    options = _complete({"_ASICTL_COMPLETE": "bash_complete",
                         "COMP_WORDS": "asictl check --for", "COMP_CWORD": "2"})
    assert options.split() == ["plain,--format"]
