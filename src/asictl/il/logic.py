"""Mistakes in a program's logic that compile and run (W711-W718).

Each check answers one question a commissioning engineer would otherwise answer with
the PLC running: does a second '=' overwrite the first one in the same cycle, is a timer
started that nothing reads, does the program read a flag nothing writes, can this code
run at all, is this label or block ever used?
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field

from asictl.codes import AnalysisCode
from asictl.diagnostics import Related, Reporter, Span
from asictl.il import ast
from asictl.il.answers import answers_read_early
from asictl.il.ast import key
from asictl.il.flow import Flow, flow_of
from asictl.il.language import BUILTIN_TC, COUNTER_FLAG_BASE, MAPPED_COUNTERS
from asictl.il.loader import Program
from asictl.il.usage import Access, Key, Name, Usage, Use, is_firmware_block
from asictl.il.wiring import has_logic

#: The flag operands, and the bytes map_counters gives the counters 0..14.
_K = ast.OperandKind
_FLAGS = (_K.F, _K.FY, _K.FW)
_MAPPED_FLAGS = range(COUNTER_FLAG_BASE, COUNTER_FLAG_BASE + 2 * MAPPED_COUNTERS)
#: What sets a timer or counter going (R only stops or clears it).
_SETS: dict[ast.OperandKind | Name, tuple[str, ...]] = {
    _K.T: ("S", "T"), _K.C: ("S", "T", "CU", "CD", "STP"),
}


def check_logic(
    program: Program,
    index: Usage,
    report: Reporter,
    *,
    whole_program: bool,
    host_flags: Iterable[ast.Operand] = (),
) -> None:
    """Every W71x. ``whole_program``: the main file is a whole program ([OPTIONS] or
    [SETUP]), not a fragment, so its flags are its interface and are checked (W714)."""
    flows = {module.file: flow_of(module) for module in program.modules()}
    assignments = Counter(
        u.operand for u in index.uses if u.mark == "=" and u.operand.kind in _ASSIGNABLE
    )
    if any(count > 1 for count in assignments.values()):  # else no bit can be assigned twice
        _assigned_twice(program, flows, report)
    for flow in flows.values():
        _unreachable(flow, report)
    answers_read_early(program, flows, report)
    by_operand = index.by_operand()
    _unused_labels_and_blocks(program, index, by_operand, report)
    if index.has_assembly:
        return  # assembler code may read and write anything: the balances would guess
    map_counters = program.options.map_counters
    _timers_and_counters(by_operand, map_counters, report)
    if whole_program:
        _flags_never_written(index, by_operand, map_counters, host_flags, report)


# ------------------------------------------------------------ '=' twice in one cycle


@dataclass(frozen=True)
class _Assignment:
    """An '=' of a Q or F bit, reached through ``calls`` (calls of blocks, outermost first)."""

    operand: Key
    site: Span
    calls: tuple[Span, ...] = ()


_ASSIGNABLE = (_K.Q, _K.F)


def _assignment(node: object) -> _Assignment | None:
    if isinstance(node, ast.Store):
        if node.op is not ast.StoreOp.ASSIGN:
            return None
        target = node.operand
    elif isinstance(node, ast.GatingLine):
        target = node.target
    else:
        return None
    if target.kind not in _ASSIGNABLE or target.span is None:
        return None
    return _Assignment(Key.of(target), target.span)


@dataclass
class _Summaries:
    """The '=' assignments each block makes, with those of the blocks it calls."""

    program: Program
    flows: dict[str, Flow]
    done: dict[str, tuple[_Assignment, ...]] = field(default_factory=dict)

    def of_call(self, node: ast.CallFB) -> tuple[_Assignment, ...]:
        name = key(node.name)
        block = self.program.blocks.get(name)
        if block is None or node.span is None:
            return ()
        if name not in self.done:
            self.done[name] = ()  # a recursive call (an error reported elsewhere) adds nothing
            flow = self.flows[block.file]
            reachable = flow.reachable
            self.done[name] = tuple(
                a for i, n in enumerate(flow.nodes) if reachable[i] for a in self.events(n)
            )
        return tuple(
            _Assignment(a.operand, a.site, (node.span, *a.calls)) for a in self.done[name]
        )

    def events(self, node: object) -> tuple[_Assignment, ...]:
        if isinstance(node, ast.CallFB):
            return self.of_call(node)
        assignment = _assignment(node)
        return (assignment,) if assignment else ()


@dataclass(frozen=True)
class _Event:
    """An assignment as its module's flow sees it: at node ``node`` of basic block ``block``
    (a call's assignments all stand at the call)."""

    assignment: _Assignment
    block: int
    node: int


def _reaching(flow: Flow, blocks: list[range], reachable: list[bool]) -> list[int]:
    """Per basic block, the set (a bit mask) of reachable blocks from which some path
    leads into it: a block is in its own set only if it is in a loop."""
    block_at = {b.start: n for n, b in enumerate(blocks)}
    predecessors: list[list[int]] = [[] for _ in blocks]
    for n, b in enumerate(blocks):
        if reachable[b.start]:
            for j in flow.successors[b[-1]]:
                predecessors[block_at[j]].append(n)
    reach = [0] * len(blocks)
    changed = True
    while changed:  # most jumps go forward: a pass or two more per loop
        changed = False
        for n, preds in enumerate(predecessors):
            mask = reach[n]
            for m in preds:
                mask |= reach[m] | 1 << m
            if mask != reach[n]:
                reach[n], changed = mask, True
    return reach


def _assigned_twice(program: Program, flows: dict[str, Flow], report: Reporter) -> None:
    """W711: two '=' of one bit that can both run in one cycle (the last one wins).

    Within each module: assignment a and assignment b of one bit both run in some cycle
    when a path leads from a to b, that is, when a's basic block reaches b's (or a comes
    first in the same block). A call stands for the assignments of the block it calls;
    assignments on paths that exclude each other (the two ways of a JC) are fine.
    """
    summaries = _Summaries(program, flows)
    reported: set[frozenset[Span]] = set()
    for module in program.modules():
        flow = flows[module.file]
        blocks = flow.blocks()
        reachable = flow.reachable
        reach = _reaching(flow, blocks, reachable)
        by_operand: dict[Key, list[_Event]] = {}
        for n, b in enumerate(blocks):
            if reachable[b.start]:
                for i in b:
                    for assignment in summaries.events(flow.nodes[i]):
                        by_operand.setdefault(assignment.operand, []).append(
                            _Event(assignment, n, i))
        for events in by_operand.values():
            if len(events) < 2:
                continue
            in_blocks: dict[int, list[_Event]] = {}
            for event in events:
                in_blocks.setdefault(event.block, []).append(event)
            mask = sum(1 << n for n in in_blocks)
            for event in events:
                earlier = _earlier(event, in_blocks, reach[event.block] & mask)
                if earlier is not None:
                    _report_twice(event.assignment, earlier.assignment, reported, report)


def _earlier(event: _Event, in_blocks: dict[int, list[_Event]], mask: int) -> _Event | None:
    """Another assignment of the same bit from which a path leads to ``event``."""
    site = event.assignment.site
    for other in in_blocks[event.block]:
        if other.node >= event.node:
            break
        if other.assignment.site != site:
            return other
    while mask:
        n = (mask & -mask).bit_length() - 1
        mask &= mask - 1
        for other in in_blocks[n]:
            if other.assignment.site != site and other.node != event.node:
                return other
    return None


def _report_twice(
    assignment: _Assignment, earlier: _Assignment, reported: set[frozenset[Span]],
    report: Reporter,
) -> None:
    pair = frozenset((earlier.site, assignment.site))
    if pair in reported:
        return
    reported.add(pair)
    text = assignment.operand.text()
    notes: list[Related] = [(earlier.site, f"{text} is assigned here too")]
    notes += [(call, "in the block called here") for call in earlier.calls[:1]]
    notes += [(call, "this assignment runs in the block called here")
              for call in assignment.calls[:1]]
    report.warning(
        AnalysisCode.ASSIGNED_TWICE,
        f"{text} is assigned with '=' here and at line {earlier.site.line}"
        f"{_other_file(earlier.site, assignment.site)} in the same cycle: the last '=' wins, "
        "the first one has no effect",
        assignment.site, tuple(notes),
    )


def _other_file(span: Span, here: Span) -> str:
    return f" of {span.file}" if span.file != here.file else ""


# ------------------------------------------------------------------ unreachable code


def _unreachable(flow: Flow, report: Reporter) -> None:
    """W715: code no path reaches, reported once per run of it at its first instruction."""
    reachable = flow.reachable
    if all(reachable):
        return
    last_end: ast.Statement | None = None
    in_run = False
    for i, node in enumerate(flow.nodes):
        if reachable[i]:
            in_run = False
            if isinstance(node, ast.Jump | ast.BlockEnd):
                last_end = node
            continue
        if in_run or isinstance(node, ast.Label | ast.SegmentEnd) or node.span is None:
            continue
        in_run = True
        after = (f" (after '{last_end.to_source()}' at line {last_end.span.line})"
                 if last_end is not None and last_end.span is not None else "")
        report.warning(
            AnalysisCode.UNREACHABLE,
            f"unreachable code: no jump leads here and the code before never goes on{after}, "
            "so this never runs",
            node.span,
        )


# ----------------------------------------------------------------- labels and blocks


def _unused_labels_and_blocks(
    program: Program, index: Usage, by_operand: dict[Key, list[Use]],
    report: Reporter,
) -> None:
    """W716 labels no jump names; W717 declared blocks no call names."""
    has_code = any(has_logic(m) for m in program.modules())
    for operand, uses in by_operand.items():
        if operand.kind not in (Name.LABEL, Name.BLOCK):
            continue
        if any(r.access is Access.USE for r in uses):
            continue
        for definition in (r for r in uses if r.access is Access.DEFINE):
            if operand.kind is Name.LABEL:
                report.warning(
                    AnalysisCode.LABEL_UNUSED,
                    f"label '{index.text(operand)}' is never jumped to",
                    definition.span,
                )
            elif has_code and not is_firmware_block(operand):
                report.warning(
                    AnalysisCode.BLOCK_UNUSED,
                    f"function block '{index.text(operand)}' is declared but never called, "
                    "so its file is not even read",
                    definition.span,
                )
            break


# ------------------------------------------------------------ timers and counters


def _timers_and_counters(
    by_operand: dict[Key, list[Use]], map_counters: bool, report: Reporter
) -> None:
    """W712 set and never read; W713 read and never set. With map_counters, counters
    0..14 are flag bytes the host reads and writes too, so they are not judged."""
    for operand, uses in by_operand.items():
        if operand.kind not in _SETS:
            continue
        kind = "timer" if operand.kind is _K.T else "counter"
        if operand.kind is _K.C and map_counters and operand.address < BUILTIN_TC:
            continue
        sets = [r for r in uses if r.access is Access.WRITE
                and r.mark in _SETS[operand.kind]]
        reads = [r for r in uses if r.access is Access.READ]
        text = operand.text()
        if sets and not reads:
            first = sets[0]
            report.warning(
                AnalysisCode.SET_NEVER_READ,
                f"{kind} {operand.address} is {'started' if kind == 'timer' else 'set'} "
                f"('{first.mark} {text}') but never read: nothing uses its "
                f"{'status or time' if kind == 'timer' else 'status or count'}",
                first.span,
            )
        elif reads and not sets:
            verb = "started (S T" if kind == "timer" else "set or counted (S, CU, CD, STP"
            report.warning(
                AnalysisCode.READ_NEVER_SET,
                f"{kind} {operand.address} is read ('{reads[0].mark} {text}') but never "
                f"{verb} {operand.address}): it is always 0",
                reads[0].span,
            )


# --------------------------------------------------------------------------- flags


def _flags_never_written(
    index: Usage,
    by_operand: dict[Key, list[Use]],
    map_counters: bool,
    host_flags: Iterable[ast.Operand],
    report: Reporter,
) -> None:
    """W714: a flag the program reads and nothing writes: not the program, not PARAM
    (F 127), not the counters (map_counters), not the host (an ``asictl: host`` line)."""
    bits: set[tuple[int, int]] = set()  # written bit by bit
    whole: set[int] = set(_MAPPED_FLAGS) if map_counters else set()  # written as bytes
    writers = [r.operand for r in index.of_kind(*_FLAGS) if r.access is Access.WRITE]
    for operand in [*writers, *map(Key.of, host_flags)]:
        if operand.kind is _K.F:
            bits.add((operand.address, operand.bit))
        else:
            whole.update(_flag_bytes(operand))
    touched = whole | {byte for byte, _ in bits}
    for operand, uses in by_operand.items():
        if operand.kind not in _FLAGS:
            continue
        if operand.kind is _K.F:
            written = (operand.address, operand.bit) in bits or operand.address in whole
        else:
            written = any(b in touched for b in _flag_bytes(operand))
        reads = [r for r in uses if r.access is Access.READ]
        if written or not reads:
            continue
        text = operand.text()
        report.warning(
            AnalysisCode.FLAG_NEVER_WRITTEN,
            f"{text} is read but nothing in the program writes it; if the host writes it, "
            f"say so with '; asictl: host {text}'",
            reads[0].span,
        )


def _flag_bytes(operand: Key) -> range:
    assert isinstance(operand.kind, ast.OperandKind)  # (only flags are asked about)
    return ast.flag_bytes(operand.kind, operand.address)
