"""A slave's answer read in the cycle that asked for it (W718).

PARAM and the firmware blocks that send on the AS-i cable (SendPrm, Command, Address)
leave what the slave answered in F 127 (PARAM: bits 0-3 and 7) and in PSeg. The manual
(3.4.6) has a real master send them in its management phase, reached within 5 ms;
asictl's emulated master answers at once, so a program that reads the answer right after
asking behaves in the emulation as it may not on hardware (docs/verify.md, Timing).
Reading it in the next cycle is right on both.

The rule, as a forward "may" analysis over each module's flow (``il.flow``): from the
start of the module nothing is pending; PARAM and those blocks make their answer bits
pending, a call of a user block makes pending what may still be pending when the block
returns; a write of a bit clears it; a read of a pending bit is reported. The cycle
boundary is where the flow ends (BE, BEU, the last line): a backward jump stays in the
cycle, so a read above a PARAM that a loop reaches again after it is reported too. A
block's own reads are judged against what the block itself asked for (the flow of a
module starts empty), which keeps each report at the line that reads.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import assert_never

from asictl.codes import AnalysisCode
from asictl.diagnostics import Reporter, Span
from asictl.il import ast
from asictl.il.ast import key
from asictl.il.flow import Flow
from asictl.il.language import PARAM_FLAG
from asictl.il.loader import Program
from asictl.runtime.firmware import FIRMWARE_BLOCKS

K = ast.OperandKind

#: The bits of F 127 PARAM answers in: the slave's answer (0-3) and success (7); it keeps 4-6.
PARAM_ANSWER_BITS = 0x8F
#: The bits of a PSeg byte a block answers in.
_WHOLE = 0xFF


@dataclass(frozen=True)
class Pending:
    """Answer bits not yet in place on a real master: ``space`` "F" (flags) or "P" (PSeg),
    the byte and its bits, and the PARAM or call that asked (its name and place)."""

    space: str
    byte: int
    bits: int
    asked_by: str
    asked_at: Span | None


State = frozenset[Pending]


def places(operand: ast.Operand) -> list[tuple[str, int, int]]:
    """The (space, byte, bits) an operand covers among the places answers land in."""
    match operand.kind:
        case K.F:
            return [("F", operand.address, 1 << operand.bit)]
        case K.FY:
            return [("F", operand.address, _WHOLE)]
        case K.FW:
            return [("F", operand.address, _WHOLE), ("F", operand.address + 1, _WHOLE)]
        case K.PSEG:
            return [("P", operand.address, _WHOLE)]
        case (K.I | K.I2 | K.Q | K.IB | K.I2B | K.QB | K.T | K.C | K.VAR | K.KT | K.KC
              | K.KB | K.KW | K.KP):
            return []
        case _:
            assert_never(operand.kind)


def _asked(name: str, span: Span | None, flag_bits: int, pseg: Iterable[int]) -> State:
    flag = [Pending("F", PARAM_FLAG, flag_bits, name, span)] if flag_bits else []
    return frozenset([*flag, *(Pending("P", n, _WHOLE, name, span) for n in pseg)])


def _without(state: State, written: list[tuple[str, int, int]]) -> State:
    """``state`` after the program wrote ``written``: those bits hold what it wrote."""
    result = set()
    for pending in state:
        bits = pending.bits
        for space, byte, covered in written:
            if space == pending.space and byte == pending.byte:
                bits &= ~covered
        if bits:
            result.add(Pending(pending.space, pending.byte, bits, pending.asked_by,
                               pending.asked_at))
    return frozenset(result)


def _read(state: State, read: list[tuple[str, int, int]]) -> Pending | None:
    """The first pending answer (in a fixed order) a read of ``read`` takes."""
    hits = [
        p for p in state for space, byte, bits in read
        if p.space == space and p.byte == byte and p.bits & bits
    ]
    return min(hits, key=_order) if hits else None


def _order(pending: Pending) -> tuple[tuple[str, int, int], str, int]:
    at = pending.asked_at
    return ((at.file, at.line, at.column) if at else ("", 0, 0), pending.space, pending.byte)


@dataclass
class _Analysis:
    program: Program
    flows: dict[str, Flow]
    report: Reporter
    #: user block (key) -> what may still be pending when it returns
    returns: dict[str, State] = field(default_factory=dict)
    reported: set[Span] = field(default_factory=set)

    def module(self, flow: Flow) -> State:
        """Run the analysis over one module's flow, report, and return what may be pending
        where the module ends."""
        nodes, successors = flow.nodes, flow.successors
        before: list[State | None] = [None] * len(nodes)
        if nodes:
            before[0] = frozenset()
        work = [0] if nodes else []
        end: State = frozenset()
        while work:
            i = work.pop()
            state = before[i]
            assert state is not None
            after = self.step(nodes[i], state, report=False)
            if not successors[i]:
                end |= after
            for j in successors[i]:
                old = before[j]
                new = after if old is None else old | after
                if new != old:
                    before[j] = new
                    work.append(j)
        for i, node in enumerate(nodes):
            state = before[i]
            if state:
                self.step(node, state, report=True)
        return end

    def step(self, node: ast.Statement | ast.GatingLine, state: State, *, report: bool) -> State:
        if isinstance(node, ast.Param):
            block = FIRMWARE_BLOCKS["sendprm"]
            return state | _asked("PARAM", node.span, PARAM_ANSWER_BITS, block.slave_answer)
        if isinstance(node, ast.CallFB):
            return state | self.call(node)
        uses = ast.operands(node)
        for operand, access in uses:
            if access is not ast.Access.WRITE and report:
                self.check_read(operand, state)
        for operand, access in uses:
            if access is not ast.Access.READ:
                state = _without(state, places(operand))
        return state

    def call(self, node: ast.CallFB) -> State:
        name = key(node.name)
        block = self.program.blocks.get(name)
        if block is not None:
            if name not in self.returns:
                self.returns[name] = frozenset()  # recursion (an error) adds nothing
                self.returns[name] = self.module(self.flows[block.file])
            return self.returns[name]
        firmware = FIRMWARE_BLOCKS.get(name)
        if firmware is None or not firmware.slave_answer:
            return frozenset()
        return _asked(firmware.name, node.span, 0, firmware.slave_answer)

    def check_read(self, operand: ast.Operand, state: State) -> None:
        pending = _read(state, places(operand))
        span = operand.span
        if pending is None or span is None or span in self.reported:
            return
        self.reported.add(span)
        asked = f" (line {pending.asked_at.line})" if pending.asked_at else ""
        self.report.warning(
            AnalysisCode.ANSWER_READ_EARLY,
            f"{operand} is read in the cycle in which {pending.asked_by}{asked} asks a slave "
            "for it: asictl's master answers at once, a real master in its management "
            "phase (up to 5 ms later); read it in the next cycle",
            span,
            [(pending.asked_at, f"{pending.asked_by} asks here")] if pending.asked_at else (),
        )


def answers_read_early(program: Program, flows: dict[str, Flow], report: Reporter) -> None:
    """W718 over every module: the main program, then each block not called from it."""
    analysis = _Analysis(program, flows, report)
    analysis.module(flows[program.main.file])
    for name, block in program.blocks.items():
        if name not in analysis.returns:
            analysis.returns[name] = analysis.module(flows[block.file])
