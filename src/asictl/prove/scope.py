"""What a property may name: the operands of the program and of the master it runs on.

A property over an operand that does not exist is decided on a constant: ``never =
"Q 9.0"`` with no slave 9 on the bus reads 0 after every cycle and would come out
``proved``, a typo for ``Q 3.0`` reported as a proved interlock. So every operand a
property or ``[assume]`` names is checked here before anything is proved: a slave's
data needs the slave on the bus, a timer or counter needs the program to use it. What
exists but is never written by the program (a flag it only reads) is no mistake: the
prover reports such a property as proved trivially (``prove/engine.py``).

Nothing here needs z3: the properties reader calls ``Scope.problem`` for each operand.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import assert_never

from asictl.il import ast
from asictl.il.loader import Program
from asictl.il.pragmas import read_directives
from asictl.observe.operands import Operand

K = ast.OperandKind
_SLAVE_KINDS = (K.I, K.I2, K.Q)
_PAIR_KINDS = (K.IB, K.I2B, K.QB)
_INPUTS = (K.I, K.I2, K.IB, K.I2B)
#: A place in memory, a byte at a time: (what, number); a bit names its byte
Place = tuple[str, str | int]


def places(node: ast.Operand) -> tuple[Place, ...]:
    """The bytes an operand occupies (a bit its byte, a slave's data its image byte)."""
    match node.kind:
        case K.F | K.FY:
            return (("F", node.address),)
        case K.FW:
            return (("F", node.address), ("F", node.address + 1))
        case K.I | K.I2 | K.Q | K.IB | K.I2B | K.QB:
            return ((node.kind.value.rstrip("B"), node.address >> 1),)
        case K.VAR:
            return ((ast.key(node.name), node.address),)
        case K.PSEG | K.T | K.C | K.KT | K.KC | K.KB | K.KW | K.KP:
            return ((node.kind.value, node.address),)
        case _:
            assert_never(node.kind)


def uses(program: Program) -> Iterator[ast.Use]:
    """Every operand the program's statements and gating lines read or write, over all
    its modules, with how."""
    for module in program.modules():
        for section in module.sections:
            for node in ast.nodes(section):
                if isinstance(node, ast.Statement | ast.GatingLine):
                    yield from ast.operands(node)


@dataclass(frozen=True)
class Scope:
    """The slaves a program's [SETUP] projects, and the timers and counters it uses (the
    ones that can ever change)."""

    setup: frozenset[int]
    timers: frozenset[int]
    counters: frozenset[int]
    #: the bytes some line of the program writes
    written: frozenset[Place]
    #: the flag bytes the host writes (``; asictl: host ...``)
    host: frozenset[Place]

    @classmethod
    def of(cls, program: Program) -> Scope:
        used: dict[K, set[int]] = {K.T: set(), K.C: set()}
        written: set[Place] = set()
        for operand, access in uses(program):
            if operand.kind in used:
                used[operand.kind].add(operand.address)
            if access is not ast.Access.READ:
                written.update(places(operand))
        host = {place for flag, _ in read_directives(program.sources).host_flags
                for place in places(flag)}
        return cls(frozenset(s.address for s in program.slaves), frozenset(used[K.T]),
                   frozenset(used[K.C]), frozenset(written), frozenset(host))

    def environment(self, operand: Operand) -> bool:
        """Whether only the environment changes ``operand``: an input, or a flag the
        host writes and no line of the program does."""
        node = operand.node
        if node.kind in _INPUTS:
            return True
        found = places(node)
        return (all(p in self.host for p in found)
                and not any(p in self.written for p in found))

    def problem(self, operand: Operand, slaves: Iterable[int] | None) -> str | None:
        """Why ``operand`` names nothing of this program on a bus of ``slaves`` (None: the
        program's [SETUP]), with the nearest that exists; None when it exists."""
        node = operand.node
        on_bus = sorted(set(self.setup if slaves is None else slaves))
        if node.kind in _SLAVE_KINDS or node.kind in _PAIR_KINDS:
            addresses = [node.address]
            if node.kind in _PAIR_KINDS:
                addresses.append(node.address + 1)
            if any(a in on_bus for a in addresses):
                return None
            shown = " or ".join(str(a) for a in addresses)
            bus = " ".join(map(str, on_bus)) or "none"
            message = (f"'{operand}': slave {shown} is not on the bus (slaves {bus}: the "
                       "program's [SETUP], or slaves in [master])")
            return message + _nearest(operand, node.address, on_bus)
        if node.kind in (K.T, K.C):
            what = "timer" if node.kind is K.T else "counter"
            used = sorted(self.timers if node.kind is K.T else self.counters)
            if node.address in used:
                return None
            if not used:
                return f"'{operand}': the program uses no {what}"
            return (f"'{operand}': the program does not use {what} {node.address}"
                    + _nearest(operand, node.address, used))
        return None


def _nearest(operand: Operand, address: int, choices: list[int]) -> str:
    """``; did you mean 'Q 3.0'?``: the operand at the nearest address that exists."""
    if not choices:
        return ""
    best = min(choices, key=lambda a: (abs(a - address), a))
    if operand.node.kind in _PAIR_KINDS:
        best -= best % 2
    written = str(operand)
    number = str(address)
    head, _, tail = written.partition(" ")
    if tail.startswith(number):
        written = f"{head} {best}{tail[len(number):]}"
    return f"; did you mean '{written}'?"
