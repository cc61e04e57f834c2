"""Write the command reference of docs/commands.md from asictl's click tree.

Below the marker in docs/commands.md, every command and subcommand in the sections of
``asictl --help``: its usage line, its help, every long option with its help text and
default, and its examples. What is above the marker is written by hand. Run it after
changing a command's help or options:

    python3 tools/commands_doc.py          # rewrite the reference
    python3 tools/commands_doc.py --check  # exit 1 if the document is out of date

``examples`` and ``commands`` are also what tests/test_cli_examples.py reads: the
``Example:`` block that ends every command's help is the one the tests run.
"""

from __future__ import annotations

import inspect
import re
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

import click  # noqa: E402 - after the path is set
from drawn import redraw  # noqa: E402 - beside this file

from asictl.cli import SECTIONS, main  # noqa: E402

DOC = ROOT / "docs" / "commands.md"
BEGIN = "<!-- reference: written from the click tree by tools/commands_doc.py -->"
END = "<!-- end of reference -->"

#: Options most master commands share, described once in the reference (an option of the
#: same name whose help differs, such as ``gateway serve --port``, is listed with its
#: command). The reference wording is that of the command named here.
SHARED_FROM = ("status",)
SHARED_TITLE = "Board options"
SHARED = ("--port", "--io", "--state-dir", "--wait", "--modbus", "--unit", "--baud",
          "--parity", "--stopbits", "--timeout", "--retries")

_EXAMPLE_HEAD = re.compile(r"\x08\nExamples?:\n")
#: What click puts in an option's default when none was given (click 8.3 and later).
_NO_DEFAULT = (None, (), "", getattr(click.core, "UNSET", None))


def help_text(command: click.Command) -> str:
    """The command's help as click shows it: the docstring's indentation removed."""
    return inspect.cleandoc(command.help or "")


def commands() -> Iterator[tuple[click.Context, click.Command]]:
    """Every command and subcommand with its context, in the order of ``asictl --help``
    (subcommands in their group's order, right after their group)."""
    root = click.Context(main, info_name="asictl")
    placed = [name for names in SECTIONS.values() for name in names]
    others = sorted(set(main.list_commands(root)) - set(placed))
    for name in [*placed, *others]:
        yield from _walk(root, name)


def _walk(parent: click.Context, name: str) -> Iterator[tuple[click.Context, click.Command]]:
    group = parent.command
    assert isinstance(group, click.Group)
    command = group.get_command(parent, name)
    assert command is not None, name
    ctx = click.Context(command, info_name=name, parent=parent)
    yield ctx, command
    if isinstance(command, click.Group):
        for sub in command.list_commands(ctx):
            yield from _walk(ctx, sub)


def _last_example_head(text: str) -> re.Match[str] | None:
    matches = list(_EXAMPLE_HEAD.finditer(text))
    return matches[-1] if matches else None


def examples(command: click.Command) -> list[str]:
    """The command lines of the ``Example:`` block that ends the command's help (``\\b``,
    then ``Example:`` or ``Examples:``, then one indented command line each); [] if the
    help does not end with one."""
    text = help_text(command)
    head = _last_example_head(text)
    if head is None or "\n\n" in text[head.end():]:
        return []
    return [line.strip() for line in text[head.end():].splitlines() if line.strip()]


def _prose(text: str) -> str:
    """The help without its Example block, as Markdown: paragraphs joined into lines, a
    ``\\b`` paragraph (kept as written) as a code block."""
    head = _last_example_head(text)
    if head is not None:
        text = text[: head.start()]
    out = []
    for paragraph in re.split(r"\n\s*\n", text.strip()):
        if paragraph.startswith("\x08"):
            kept = textwrap.dedent(paragraph.removeprefix("\x08\n")).rstrip()
            out.append(f"```\n{kept}\n```")
        else:
            out.append(_escape(" ".join(line.strip() for line in paragraph.splitlines())))
    return "\n\n".join(out)


def _anchor(title: str) -> str:
    """The anchor GitHub gives a heading."""
    return title.lower().replace(" ", "-")


def _escape(text: str) -> str:
    return re.sub(r"([\\*_<`])", r"\\\1", text)


def _option_record(ctx: click.Context, param: click.Parameter) -> tuple[str, str] | None:
    """``("-o, --output FILE", "help [default: ...]")``, the default added where click's
    help does not show it; None for arguments and --help."""
    if not isinstance(param, click.Option) or param.hidden or "--help" in param.opts:
        return None
    record = param.get_help_record(ctx)
    if record is None:
        return None
    names, text = record
    default = param.default
    shown = "[default:" in text or "default:" in text
    if not shown and not param.is_flag and default not in _NO_DEFAULT and not callable(
        default
    ):
        text = f"{text}  [default: {default}]".strip()
    return names, text


def _long_name(param: click.Parameter) -> str:
    return max(param.opts, key=len)


def _shared_records() -> dict[str, tuple[str, str]]:
    for ctx, command in commands():
        if ctx.command_path.split()[1:] == list(SHARED_FROM):
            return {
                _long_name(p): record for p in command.params
                if (record := _option_record(ctx, p)) and _long_name(p) in SHARED
            }
    raise AssertionError(f"no command {SHARED_FROM}")


def _options(ctx: click.Context, shared: dict[str, tuple[str, str]]) -> list[str]:
    lines, uses_shared = [], False
    for param in ctx.command.params:
        record = _option_record(ctx, param)
        if record is None:
            continue
        if shared.get(_long_name(param)) == record:
            uses_shared = True
            continue
        names, text = record
        lines.append(f"- `{names}`: {_escape(text)}")
    if uses_shared:
        lines.append(f"- the [board options](#{_anchor(SHARED_TITLE)}) (`--port`, `--modbus`, ...)")
    return lines


def _command_text(ctx: click.Context, shared: dict[str, tuple[str, str]]) -> str:
    command = ctx.command
    usage = " ".join([ctx.command_path, *command.collect_usage_pieces(ctx)])
    level = "###" if ctx.parent is not None and ctx.parent.parent is None else "####"
    parts = [f"{level} {ctx.command_path}", f"Usage: `{usage}`", _prose(help_text(command))]
    if isinstance(command, click.Group):
        names = command.list_commands(ctx)
        parts.append("Subcommands: " + ", ".join(
            f"[{name}](#{(ctx.command_path + ' ' + name).replace(' ', '-')})" for name in names
        ) + ".")
    options = _options(ctx, shared)
    if options:
        parts.append("Options:\n\n" + "\n".join(options))
    lines = examples(command)
    parts.append("Examples:\n\n```bash\n" + "\n".join(lines) + "\n```")
    return "\n\n".join(parts)


def reference() -> str:
    """The generated part of docs/commands.md."""
    shared = _shared_records()
    section_of = {name: title for title, names in SECTIONS.items() for name in names}
    listed: dict[str, list[str]] = {}
    for ctx, _command in commands():
        if ctx.parent is ctx.find_root():
            listed.setdefault(section_of.get(ctx.info_name or "", "Other"), []).append(
                f"[{ctx.info_name}](#{ctx.command_path.replace(' ', '-')})")
    contents = "\n".join(
        f"- [{title}](#{_anchor(title)}): {', '.join(names)}" for title, names in listed.items()
    )
    parts = [contents, f"## {SHARED_TITLE}", (
        "The master commands reach a board through these options (an emulated PC2 board "
        "by default); each command's entry below says when it takes them."
    ), "\n".join(f"- `{names}`: {_escape(text)}" for names, text in shared.values())]
    current = None
    for ctx, _command in commands():
        top = ctx.command_path.split()[1]
        title = section_of.get(top, "Other")
        if title != current:
            parts.append(f"## {title}")
            current = title
        parts.append(_command_text(ctx, shared))
    return "\n" + "\n\n".join(parts) + "\n\n"


def run(argv: list[str]) -> int:
    return redraw(DOC, BEGIN, END, reference(), argv, "python3 tools/commands_doc.py")


if __name__ == "__main__":
    sys.exit(run(sys.argv[1:]))
