"""A program's networks, and two versions of it compared network by network.

A network is what a program section holds between two ``***`` (and each [GATING] line);
function blocks are compared by name. Networks are compared as their statements with
label names replaced by their place in the network, so a renamed label is no change;
a network found unchanged at another place is reported as moved. ``asictl diff`` shows
it; ``fleet verify`` says with it what changed in a master's program.
"""

from __future__ import annotations

import dataclasses
import difflib
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from asictl.il import ast
from asictl.il.ast import key
from asictl.il.loader import Program


@dataclass(frozen=True)
class Network:
    """One network: where it is, its statements' source lines, and its canonical form."""

    module: str
    index: int
    first_line: int
    last_line: int
    lines: tuple[str, ...]
    canonical: str


def _source_line(texts: dict[str, list[str]], node: ast.Statement | ast.GatingLine) -> str:
    if isinstance(node, ast.Label):  # its line may hold the next statement too
        return f"{node.name}:"
    span = node.span
    if span is None:
        return repr(dataclasses.replace(node, span=None))
    source = texts.get(span.file)
    if source is None:
        return repr(dataclasses.replace(node, span=None))
    text = source[span.line - 1].split(";", 1)[0]
    label = re.match(r"\s*[A-Za-z_][A-Za-z0-9_]*\s*:(?!=)", text)
    return " ".join(text[label.end() if label else 0:].split())


def _canonical(nodes: Sequence[ast.Statement | ast.GatingLine]) -> str:
    labels: dict[str, str] = {}

    def place(name: str) -> str:
        return labels.setdefault(key(name), f"L{len(labels)}")

    parts = []
    for node in nodes:
        if isinstance(node, ast.Label):
            node = dataclasses.replace(node, name=place(node.name))
        elif isinstance(node, ast.Jump):
            node = dataclasses.replace(node, label=place(node.label))
        parts.append(repr(dataclasses.replace(node, span=None)))
    return "\n".join(parts)


def _network(texts: dict[str, list[str]], module: str, index: int,
             nodes: list[ast.Statement | ast.GatingLine]) -> Network | None:
    kept = [n for n in nodes if not isinstance(n, ast.SegmentEnd)]
    if not kept:
        return None
    lines = [n.span.line for n in kept if n.span is not None] or [0]
    return Network(module, index, min(lines), max(lines),
                   tuple(_source_line(texts, n) for n in kept), _canonical(kept))


def networks(program: Program) -> list[Network]:
    """Every network of the program and of its function blocks, in source order."""
    found: list[Network] = []
    texts = {name: source.text.split("\n") for name, source in program.sources.items()}
    for module in program.modules():
        name = Path(module.file).name
        groups: list[list[ast.Statement | ast.GatingLine]] = [[]]
        for section in module.sections:
            if isinstance(section, ast.GatingSection):
                for line in section.lines:
                    groups += [[line], []]
            elif isinstance(section, ast.ProgramSection):
                for statement in section.statements:
                    groups[-1].append(statement)
                    if isinstance(statement, ast.SegmentEnd):
                        groups.append([])
                groups.append([])
        count = 0
        for group in groups:
            network = _network(texts, name, count + 1, group)
            if network is not None:
                count += 1
                found.append(network)
    return found


@dataclass(frozen=True)
class Change:
    #: same, moved, changed, added, removed
    kind: str
    old: Network | None
    new: Network | None

    def lines(self) -> list[str]:
        old, new = self.old, self.new
        if self.kind == "added":
            assert new is not None
            return [f"added    {_where(new)}", *(f"  + {line}" for line in new.lines)]
        if self.kind == "removed":
            assert old is not None
            return [f"removed  {_where(old)}", *(f"  - {line}" for line in old.lines)]
        assert old is not None and new is not None
        if self.kind == "same":
            return [f"same     {_where(old)} -> {_where(new)}"]
        if self.kind == "moved":
            return [f"moved    {_where(old)} -> {_where(new)}"]
        if self.kind == "renamed":
            return [f"labels   {_where(old)} -> {_where(new)}: only labels renamed"]
        body = [f"  {line}" for line in difflib.unified_diff(
            old.lines, new.lines, lineterm="", n=1)][2:]
        return [f"changed  {_where(old)} -> {_where(new)}", *body]


def _where(network: Network) -> str:
    span = (f"line {network.first_line}" if network.first_line == network.last_line
            else f"lines {network.first_line}-{network.last_line}")
    return f"{network.module} network {network.index} ({span})"


def compare(old: Program, new: Program) -> list[Change]:
    """The networks of two programs paired: unchanged ones in order, moved ones found
    anywhere, the rest as changed (the most alike pairs first) or added/removed; in the
    order of the new program."""
    a, b = networks(old), networks(new)
    matcher = difflib.SequenceMatcher(a=[n.canonical for n in a], b=[n.canonical for n in b],
                                      autojunk=False)
    changes: list[Change] = []
    loose_old: list[Network] = []
    loose_new: list[Network] = []
    for tag, i1, i2, j1, j2 in matcher.get_opcodes():
        if tag == "equal":
            for x, y in zip(a[i1:i2], b[j1:j2], strict=True):
                kind = "same" if x.lines == y.lines else "renamed"
                changes.append(Change(kind, x, y))
        else:
            loose_old += a[i1:i2]
            loose_new += b[j1:j2]
    for x in list(loose_old):  # the same network elsewhere: moved
        twin = next((y for y in loose_new if y.canonical == x.canonical), None)
        if twin is not None:
            changes.append(Change("moved", x, twin))
            loose_old.remove(x)
            loose_new.remove(twin)
    scored = sorted(
        ((difflib.SequenceMatcher(a=x.lines, b=y.lines).ratio(), i, j)
         for i, x in enumerate(loose_old) for j, y in enumerate(loose_new)),
        reverse=True)
    paired_old: set[int] = set()
    paired_new: set[int] = set()
    for ratio, i, j in scored:  # the most alike first: changed
        if ratio >= 0.5 and i not in paired_old and j not in paired_new:
            changes.append(Change("changed", loose_old[i], loose_new[j]))
            paired_old.add(i)
            paired_new.add(j)
    changes += [Change("removed", x, None) for i, x in enumerate(loose_old)
                if i not in paired_old]
    changes += [Change("added", None, y) for j, y in enumerate(loose_new)
                if j not in paired_new]
    return sorted(changes, key=_order)


def _order(change: Change) -> tuple[int, int]:
    network = change.new or change.old
    assert network is not None
    return (0 if change.new is not None else 1, network.first_line)
