"""The control flow of one module (the main program or one block) within a cycle.

The analyses that ask "can this run?" and "can both of these run in one cycle?" see a
module as one list of nodes, the [PROGRAM] statements and [GATING] lines in source
order, with the edges a cycle can take: on to the next node, to a jump's label, nowhere
after BE/BEU (the cycle, or the block, ends there). Jumps stay inside their module, and
a call returns to the node after it, so each module's flow stands alone.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

from asictl.il import ast
from asictl.il.ast import key

Node = ast.Statement | ast.GatingLine


@dataclass(frozen=True)
class Flow:
    nodes: tuple[Node, ...]
    #: the nodes each node may go on to, within the cycle
    successors: tuple[tuple[int, ...], ...]

    @cached_property
    def reachable(self) -> list[bool]:
        """Which nodes some cycle reaches from the start of the module."""
        seen = [False] * len(self.nodes)
        work = [0] if self.nodes else []
        successors = self.successors
        while work:
            i = work.pop()
            if not seen[i]:
                seen[i] = True
                work.extend(successors[i])
        return seen

    def blocks(self) -> list[range]:
        """Basic blocks: runs of nodes entered only at their first and left at their last."""
        if not self.nodes:
            return []
        leaders = {0}
        for i, successors in enumerate(self.successors):
            if successors != (i + 1,):  # a jump, an end, or a jump target after it
                leaders.add(i + 1)
                leaders.update(successors)
        starts = sorted(s for s in leaders if s < len(self.nodes))
        ends = [*starts[1:], len(self.nodes)]
        return [range(a, b) for a, b in zip(starts, ends, strict=True)]


def flow_of(module: ast.Module) -> Flow:
    nodes = list(module.code())
    labels: dict[str, int] = {}
    for i, node in enumerate(nodes):
        if type(node) is ast.Label:
            labels.setdefault(key(node.name), i)
    return Flow(tuple(nodes), tuple(_successors(nodes, labels)))


def _successors(nodes: Sequence[Node], labels: dict[str, int]) -> list[tuple[int, ...]]:
    end = len(nodes)
    result: list[tuple[int, ...]] = []
    for i, node in enumerate(nodes):
        after = (i + 1,) if i + 1 < end else ()
        kind = type(node)  # most nodes go on to the next: one test for them
        if kind is ast.Jump:
            assert isinstance(node, ast.Jump)
            target = labels.get(key(node.label))
            jump = (target,) if target is not None else ()
            result.append(tuple(dict.fromkeys(jump + after)) if node.conditional else jump)
        elif kind is ast.BlockEnd:
            assert isinstance(node, ast.BlockEnd)
            result.append(after if node.kind is ast.EndKind.BEC else ())
        else:
            result.append(after)
    return result
