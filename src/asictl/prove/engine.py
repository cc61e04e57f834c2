"""Deciding properties on the symbolic cycle: bounded model checking and k-induction.

A run of the program is the reset state followed by one ``Cycle`` per program cycle;
a property is judged on the state after every cycle (what a scenario's ``expect``
sees). For each property the engine alternates, for k = 0, 1, ... up to the depth:

- **the base case** (bounded model checking): is there an input sequence of k+1 cycles,
  every cycle within ``[assume]``, that ends in a bad state (or, for ``reachable``, the
  target)? Then the property is refuted (reached) and the model is the counterexample
  (witness).
- **the induction step**: from *any* k+1 consecutive states that satisfy the invariants
  below and are good, is the next one good? Then, with the base case clean up to k, the
  property holds after any number of cycles: proved.

Plain k-induction fails on states no run reaches (a timer holding more than any preset,
the 10 ms clock's phase out of its range). The engine strengthens the induction step
with invariants it proves first (``invariants``): candidates drawn from the program (the
most each timer can hold, the values the constant register can take, the range of the
tick phase, each response monitor's age) are filtered by Houdini's algorithm until what
remains is inductive; only proved facts are assumed.

A ``when A then B within N`` property is checked as a safety property with a monitor:
the age of the oldest trigger not yet answered; it is bad when it reaches N. For one,
the facts that tie a waiting trigger to a running timer (``prove/timers.py``) are proved
the same way, over the monitor, and strengthen its induction step.

Beside the base case, a second path from the reset lets each step stand for a stretch
of idle cycles (``prove/jump.py``), so that a counterexample thousands of cycles behind
a timer is found in a few steps; its checks have a budget, and the first out of it ends
that search.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from enum import StrEnum

import z3

from asictl.il import ast
from asictl.il.language import TC_MAX_VALUE
from asictl.il.loader import Program
from asictl.il.oracle import runs_alone
from asictl.observe.condition import (
    Comparison,
    Connective,
    Duration,
    Expr,
    Negation,
    Number,
    Ref,
    Register,
    Truth,
    is_condition,
    refs,
    show,
)
from asictl.platform.master import TICK_US
from asictl.prove.correspond import Pair
from asictl.prove.falsify import Bit, Goal, falsify
from asictl.prove.jump import MOST, idle
from asictl.prove.props import Kind, Property
from asictl.prove.scope import uses
from asictl.prove.symbolic import (
    CONSTANT,
    TICK,
    UNROLL,
    Cycle,
    Key,
    build_cycle,
    cell_name,
    check_deadline,
    operand_cells,
    operand_value,
    width,
)
from asictl.prove.timers import Candidate, Fact, States, started, waiting
from asictl.readers.units import format_duration, timer_ticks

K = ast.OperandKind
#: Seconds (and four times the plain check's) a check with steps of idle cycles may take.
JUMP_BUDGET_S = 2.0
#: How many cycles further than a failure found with steps of idle cycles the plain
#: search looks for a shorter one.
SHORTER_CYCLES = 8
#: CPU seconds a property's search takes without a verdict before the concrete runs
#: (``prove/falsify.py``) are first tried, and the least seconds they are given. They
#: are tried again, from the start, each time the search has taken four times the CPU
#: time it had when they were last tried, each time for a quarter of that: so they take
#: about a fifth of a property's time at most, and little of one decided in seconds.
FALSIFY_AFTER_CPU_S = 0.5
FALSIFY_S = 0.25


class Verdict(StrEnum):
    PROVED = "proved"
    REFUTED = "refuted"
    REACHED = "reached"
    UNREACHABLE = "unreachable"
    #: no counterexample within the depth, and no proof
    BOUNDED = "bounded"
    #: the time limit ran out
    UNKNOWN = "unknown"

    @property
    def good(self) -> bool:
        return self in (Verdict.PROVED, Verdict.REACHED)


@dataclass(frozen=True)
class Setup:
    """The master a program runs on, as the prover sees it."""

    slaves: tuple[int, ...]
    cycle_us: int
    host_flags: tuple[ast.Operand, ...] = ()
    #: the simulator's time from time 0 to the first 10 ms tick (counterexamples use it,
    #: so that they replay); None: only the free phase
    phase_us: int | None = None


@dataclass
class Step:
    """One program cycle of a counterexample: what the slaves and the host gave it."""

    inputs: dict[int, int]
    host: dict[int, int]


@dataclass
class Outcome:
    prop: Property
    verdict: Verdict
    #: cycles checked by the base case, or the induction depth of a proof
    depth: int
    seconds: float
    trace: list[Step] | None = None
    note: str = ""
    #: the property's operands (as written) after the last cycle of the trace
    values: dict[str, int] = field(default_factory=dict)
    #: why a proof holds whatever the program does ("": it is a real proof)
    trivially: str = ""
    #: the phase the trace assumes: microseconds from time 0 to the first 10 ms tick;
    #: None when the property does not depend on the clock (any phase does)
    phase_us: int | None = None


def _value(expr: Expr, read: Callable[[ast.Operand], z3.BitVecRef]) -> z3.BitVecRef:
    match expr:
        case Number(value=number) | Duration(ms=number):
            return z3.BitVecVal(number, 32)
        case Ref():
            return read(expr.operand.node)
        case _:
            return z3.If(condition(expr, read), z3.BitVecVal(1, 32), z3.BitVecVal(0, 32))


_COMPARE: dict[str, Callable[[z3.BitVecRef, z3.BitVecRef], z3.BoolRef]] = {
    "==": lambda x, y: x == y, "!=": lambda x, y: x != y, "<": z3.ULT, "<=": z3.ULE,
    ">": z3.UGT, ">=": z3.UGE,
}


def condition(expr: Expr, read: Callable[[ast.Operand], z3.BitVecRef]) -> z3.BoolRef:
    """A condition (``observe/condition.py``) on one state, as the prover's term: the
    translation of what ``observe.condition.holds`` computes on concrete values (``read``
    gives an operand's value). Values are unsigned 32-bit, as no operand goes beyond."""
    match expr:
        case Ref():
            result: z3.BoolRef = read(expr.operand.node) == 1
            return result
        case Truth(value=value):
            return z3.BoolVal(value)
        case Negation(arg=arg):
            return z3.Not(condition(arg, read))
        case Connective(op=op, parts=parts):
            terms = [condition(part, read) for part in parts]
            if op == "and":
                return z3.And(*terms)
            if op == "or":
                return z3.Or(*terms)
            odd = terms[0]
            for term in terms[1:]:
                odd = z3.Xor(odd, term)
            return odd
        case Comparison(op="==" | "!=" as op, left=left, right=right) if is_condition(
                left) and is_condition(right):
            p, q = condition(left, read), condition(right, read)  # two conditions
            return p == q if op == "==" else z3.Xor(p, q)
        case Comparison(op=op, left=left, right=right):
            return _COMPARE[op](_value(left, read), _value(right, read))
        case Number() | Duration() | Register():
            raise AssertionError(f"{expr} is no condition of a property")


def _round_up(cycles: int) -> int:
    """Up to two significant digits: 2021 -> 2100, a depth a person would type."""
    step: int = 10 ** max(0, len(str(cycles)) - 2)
    return math.ceil(cycles / step) * step


def watched_cells(exprs: Iterable[Expr], map_counters: bool) -> list[Key]:
    return [cell for expr in exprs for ref in refs(expr)
            for cell in operand_cells(ref.operand.node, map_counters)]


# ---------------------------------------------------------------------- unrolling


class _Path:
    """States after consecutive cycles, as solver variables, with the constraints that
    tie each to the one before."""

    def __init__(self, machine: Machine, solver: z3.Solver, tag: str, *, initial: bool,
                 jumps: bool = False) -> None:
        self.machine = machine
        self.solver = solver
        self.tag = tag
        #: a step after the first may stand for many idle cycles (``prove/jump.py``)
        self.jumps = jumps
        #: per state: the cycles of the step that led to it (1 without jumps)
        self.cycles: list[z3.BitVecRef] = []
        self.states: list[dict[Key, z3.BitVecRef]] = []
        self.inputs: list[dict[str, z3.BitVecRef]] = []
        self.monitors: list[dict[str, z3.ExprRef]] = []
        #: per state: the cycle that led to it followed a backward jump too often
        self.overruns: list[z3.BoolRef] = []
        self.phase: z3.BitVecRef | None = None
        #: the cells followed: those the property depends on (its cone of influence)
        self.cells = machine.scope if machine.scope is not None else frozenset(
            machine.cycle.post)
        cycle = machine.cycle
        if initial:
            self._advance(cycle.initial())
            if TICK in self.cells:  # the first cycle: the phase of the 10 ms clock
                self.phase = self.states[0][TICK]
                solver.add(z3.UGE(self.phase, 1), z3.ULE(self.phase, TICK_US))
            machine.start_monitors(self, 0)
        else:
            self.states.append(self._fresh(0))
            self.cycles.append(z3.BitVecVal(1, 32))
            self.inputs.append({})
            self.overruns.append(z3.BoolVal(False))
            machine.free_monitors(self, 0)
        self._assume(0)

    def _fresh(self, index: int) -> dict[Key, z3.BitVecRef]:
        return {cell: z3.BitVec(f"{self.tag}{cell_name(cell)}@{index}", width(cell))
                for cell in self.cells}

    def _advance(self, before: dict[Key, z3.BitVecRef]) -> None:
        cycle = self.machine.cycle
        index = len(self.states)
        inputs = {name: z3.BitVec(f"{self.tag}{name}@{index}", var.size())
                  for name, var in cycle.inputs.items()}
        pairs = [(var, before[cell]) for cell, var in cycle.pre.items() if cell in self.cells]
        pairs += [(var, inputs[name]) for name, var in cycle.inputs.items()]
        after = self._fresh(index)
        nexts: dict[Key, z3.ExprRef] = {cell: z3.substitute(cycle.post[cell], *pairs)
                                        for cell in self.cells}
        cycles = z3.BitVecVal(1, 32)
        if self.jumps and index:
            cycles = z3.BitVec(f"{self.tag}cycles@{index}", 32)
            stored = {n: z3.substitute(term, *pairs) for n, term in cycle.stored.items()}
            nexts, rules = idle(cycles, self.states[-1], nexts, stored, cycle.cycle_us,
                                f"{self.tag}{index}.")
            self.solver.add(*rules)
        for cell in self.cells:
            if not (index == 0 and cell == TICK):  # set as the phase
                self.solver.add(after[cell] == nexts[cell])
        self.cycles.append(cycles)
        self.overruns.append(z3.substitute(cycle.overrun, *pairs))
        self.states.append(after)
        self.inputs.append(inputs)

    def extend(self) -> int:
        self._advance(self.states[-1])
        index = len(self.states) - 1
        self.machine.step_monitors(self, index)
        self._assume(index)
        return index

    def _assume(self, index: int) -> None:
        for assumption in self.machine.assume:
            self.solver.add(condition(assumption, self.reader(index)))

    def reader(self, index: int) -> Callable[[ast.Operand], z3.BitVecRef]:
        state = self.states[index]
        return lambda operand: operand_value(operand, state.__getitem__,
                                             self.machine.map_counters)

    def holds(self, expr: Expr, index: int) -> z3.BoolRef:
        return condition(expr, self.reader(index))


def _quiet(path: _Path, model: z3.ModelRef, last: int, wanted: list[z3.BoolRef],
           deadline: float) -> z3.ModelRef:
    """The same failure (``wanted`` still true after cycle ``last``) with as few input
    changes as the search can find, so that a counterexample shows what matters: each
    slave's and host flag's bits, cycle by cycle from the first, hold their value (0
    before the first cycle) unless holding it makes the failure impossible. Inputs
    outside the property's cone of influence appear in no constraint of the path, so
    they always hold and are never set; within the cone, an input is changed only where
    the failure needs it. The search is greedy, first the whole input and then bit by
    bit, and stops at ``deadline`` with the best found so far."""
    solver = path.solver
    solver.push()
    scopes = 1
    try:
        solver.add(*wanted)
        for index in range(last + 1):
            for name, var in path.inputs[index].items():
                if not name.startswith(("in.", "host.")):
                    continue  # a firmware block's answer: not the scenario's to set
                before = (path.inputs[index - 1][name] if index
                          else z3.BitVecVal(0, var.size()))
                holds = [var == before] + [
                    z3.Extract(b, b, var) == z3.Extract(b, b, before)
                    for b in range(var.size())]
                for hold in holds:
                    if z3.is_true(model.eval(hold, model_completion=True)):
                        solver.add(hold)
                        if hold is holds[0]:
                            break
                        continue
                    left = int((deadline - time.monotonic()) * 1000)
                    if left < 50:
                        return model
                    solver.set("timeout", left)
                    solver.push()
                    solver.add(hold)
                    if solver.check() == z3.sat:
                        model = solver.model()
                        scopes += 1  # kept
                        if hold is holds[0]:
                            break
                    else:
                        solver.pop()
    finally:
        solver.pop(scopes)
    return model


def _ms_until(until: float) -> int:
    """A solver's time-out (ms, at least 1) that ends at ``until`` (time.monotonic)."""
    return max(1, int((until - time.monotonic()) * 1000))


def _fewest_cycles(path: _Path, model: z3.ModelRef, last: int, wanted: list[z3.BoolRef],
                  deadline: float) -> tuple[z3.ModelRef, z3.BoolRef]:
    """The same failure after as few cycles as steps of idle cycles allow: the solver
    picks any length for a step that may stand for many cycles (16,000 where 2 do), so
    the length is halved down while a failure remains (shortest first, as the plain
    search finds it), within ``deadline``; and the constraint that keeps that length."""
    total = z3.Sum([z3.ZeroExt(32, c) for c in path.cycles[: last + 1]])

    def length(found: z3.ModelRef) -> int:
        return int(found.eval(total, model_completion=True).as_long())

    low, best = last + 1, length(model)  # each step is at least one cycle
    solver = path.solver
    while low < best:
        left = int((deadline - time.monotonic()) * 1000)
        if left < 50:
            break
        middle = (low + best) // 2
        solver.push()
        solver.add(*wanted, z3.ULE(total, middle))
        solver.set("timeout", left)
        result = solver.check()
        if result == z3.sat:
            model = solver.model()
            best = length(model)
        elif result == z3.unsat:
            low = middle + 1
        solver.pop()
        if result not in (z3.sat, z3.unsat):
            break
    return model, total == best


class _Collector:
    """Constraints gathered for Horn clauses instead of a solver."""

    def __init__(self) -> None:
        self.constraints: list[z3.BoolRef] = []

    def add(self, *constraints: z3.BoolRef) -> None:
        self.constraints.extend(constraints)


def _constants(term: z3.ExprRef) -> set[z3.ExprRef]:
    """The free constants of a term (the variables of a Horn clause)."""
    found: set[z3.ExprRef] = set()
    seen: set[int] = set()
    todo = [term]
    while todo:
        node = todo.pop()
        if node.get_id() in seen:
            continue
        seen.add(node.get_id())
        if z3.is_const(node) and node.decl().kind() == z3.Z3_OP_UNINTERPRETED:
            found.add(node)
        else:
            todo.extend(node.children())
    return found


def _same(pair: Pair) -> Fact:
    """Two programs compared: an element of the first equal to one of the second (or to
    its complement)."""
    (first, i), (second, j) = pair.first, pair.second

    def fact(path: States, index: int) -> z3.BoolRef:
        x, y = path.states[index][first], path.states[index][second]
        if i < 0:
            whole: z3.BoolRef = x == y
            return whole
        result: z3.BoolRef = (z3.Extract(i, i, x) == z3.Extract(j, j, y)) != pair.inverted
        return result

    return fact


def _element_text(element: tuple[Key, int]) -> str:
    cell, bit = element
    return cell_name(cell[1:]) + ("" if bit < 0 else f".{bit}")


def _at_most(cell: Key, bound: int) -> Fact:
    def fact(path: States, index: int) -> z3.BoolRef:
        result: z3.BoolRef = z3.ULE(path.states[index][cell], bound)
        return result

    return fact


# ---------------------------------------------------------------------- the machine


@dataclass
class Machine:
    """A program's cycle with what every property of one file shares: the assumptions
    and the invariants proved about it."""

    program: Program
    setup: Setup
    assume: list[Expr]
    properties: list[Property]
    #: the cycle, when the caller built it (two programs side by side); else the program's
    prebuilt: Cycle | None = None
    #: how often a backward jump is followed in one cycle
    unroll: int = UNROLL
    cycle: Cycle = field(init=False)
    map_counters: bool = field(init=False)
    #: the cells the loop bound (the cycle's overrun) depends on
    overrun_cells: frozenset[Key] = field(init=False)
    #: for two programs compared: the cells that must be equal after every cycle
    observed: list[tuple[Key, Key]] = field(default_factory=list)
    #: for two programs compared: elements that may always be equal, one of each
    #: program (``prove/correspond.py``), the cells under their side ("a", "b")
    twins: list[Pair] = field(default_factory=list)
    #: for two programs compared: the second (``program`` is the first)
    second: Program | None = None
    #: proved facts about every reachable state, as functions of a state, with their cells
    invariants: list[tuple[Fact, frozenset[Key]]] = field(default_factory=list)
    invariant_names: list[str] = field(default_factory=list)
    #: the property being decided now (its monitor)
    current: Property | None = None
    #: the cells paths follow now (None: all)
    scope: frozenset[Key] | None = None
    #: each cell -> the cells its value after a cycle depends on
    depends: dict[Key, frozenset[Key]] = field(default_factory=dict)
    #: how notes name an operand (``Q 3.1`` -> ``Q 3.1 (PumpB)``, observe/names.py)
    label: Callable[[str], str] = str
    #: when (time.monotonic) building the model must be done: past it, ``TimeLimit``
    deadline: float | None = None
    #: whether a counterexample or witness found by concrete runs replays in the
    #: simulator as it should (None: no simulator, so no concrete runs)
    replay: Callable[[Outcome], bool] | None = None

    def __post_init__(self) -> None:
        self.map_counters = self.program.options.map_counters
        exprs: list[Expr] = [*self.assume]
        for prop in self.properties:
            exprs.append(prop.expr)
            if prop.then is not None:
                exprs.append(prop.then)
        if self.prebuilt is not None:
            self.cycle = self.prebuilt
        else:
            self.cycle = build_cycle(
                self.program, slaves=self.setup.slaves, cycle_us=self.setup.cycle_us,
                host_flags=self.setup.host_flags,
                watch=watched_cells(exprs, self.map_counters), unroll=self.unroll,
                deadline=self.deadline,
            )
        names = {var.decl().name(): cell for cell, var in self.cycle.pre.items()}
        for cell, term in self.cycle.post.items():
            check_deadline(self.deadline)
            self.depends[cell] = frozenset(names[c.decl().name()] for c in _constants(term)
                                           if c.decl().name() in names)
        self.overrun_cells = frozenset(
            names[c.decl().name()] for c in _constants(self.cycle.overrun)
            if c.decl().name() in names)

    def cone(self, prop: Property | None) -> frozenset[Key]:
        """The cells a property (and the assumptions, and the loop bound) depends on,
        after any number of cycles: the only ones a proof of it needs to follow."""
        exprs: list[Expr] = [*self.assume]
        if prop is not None:
            exprs += [prop.expr] + ([prop.then] if prop.then is not None else [])
        todo = set(watched_cells(exprs, self.map_counters))
        todo |= self.overrun_cells
        todo |= {cell for pair in self.observed for cell in pair}
        found: set[Key] = set()
        while todo:
            cell = todo.pop()
            if cell in found or cell not in self.depends:
                continue
            found.add(cell)
            todo |= self.depends[cell] - found
        return frozenset(found)

    # -------------------------------------------------------------- response monitors

    def window(self, prop: Property) -> int:
        if prop.within_cycles is not None:
            return prop.within_cycles
        assert prop.within_ms is not None
        return int(prop.within_ms * 1000 // self.setup.cycle_us)

    def start_monitors(self, path: _Path, index: int) -> None:
        prop = self.current
        if prop is None or prop.kind is not Kind.RESPONSE:
            path.monitors.append({})
            return
        trigger, answer = self._response(path, index)
        active = z3.And(trigger, z3.Not(answer))
        path.monitors.append({"active": active, "age": z3.BitVecVal(0, 16)})

    def free_monitors(self, path: _Path, index: int) -> None:
        prop = self.current
        if prop is None or prop.kind is not Kind.RESPONSE:
            path.monitors.append({})
            return
        active = z3.Bool(f"{path.tag}active@{index}")
        age = z3.BitVec(f"{path.tag}age@{index}", 16)
        window = self.window(prop)
        path.solver.add(z3.ULE(age, window), z3.Implies(z3.Not(active), age == 0))
        path.solver.add(z3.Implies(active, z3.Not(self._response(path, index)[1])))
        path.monitors.append({"active": active, "age": age})

    def step_monitors(self, path: _Path, index: int) -> None:
        before = path.monitors[-1]
        if not before:
            path.monitors.append({})
            return
        trigger, answer = self._response(path, index)
        active, age = before["active"], before["age"]
        assert isinstance(age, z3.BitVecRef)
        cycles = path.cycles[index]  # a trigger waits through all of a step's cycles
        if path.jumps:
            path.solver.add(z3.ULE(z3.ZeroExt(16, age) + cycles, 0xFFFF))
        waited = z3.Extract(15, 0, cycles)
        path.monitors.append({
            "active": z3.And(z3.Not(answer), z3.Or(active, trigger)),
            "age": z3.If(answer, z3.BitVecVal(0, 16),
                         z3.If(active, age + waited,
                               z3.If(trigger, waited - 1, z3.BitVecVal(0, 16)))),
        })

    def _response(self, path: _Path, index: int) -> tuple[z3.BoolRef, z3.BoolRef]:
        prop = self.current
        assert prop is not None and prop.then is not None
        return path.holds(prop.expr, index), path.holds(prop.then, index)

    def bad(self, path: _Path, index: int) -> z3.BoolRef:
        """The current property violated (or, for reachable, its target) after cycle
        ``index``."""
        prop = self.current
        assert prop is not None
        if self.observed:
            state = path.states[index]
            differs: z3.BoolRef = z3.Or(*(state[a] != state[b] for a, b in self.observed))
            return differs
        if prop.kind is Kind.RESPONSE:
            monitor = path.monitors[index]
            result: z3.BoolRef = z3.And(monitor["active"],
                                        z3.UGE(monitor["age"], self.window(prop)))
            return result
        holds = path.holds(prop.expr, index)
        return z3.Not(holds) if prop.kind is Kind.ALWAYS else holds

    # -------------------------------------------------------------- invariants

    def candidates(self) -> list[Candidate]:
        """Facts that may hold in every reachable state, drawn from the program, each
        with the cells it reads."""
        found: list[Candidate] = []
        cells = self.cycle.post
        if TICK in cells:
            found.append(("the 10 ms clock's next tick within 10 ms", lambda p, i: z3.And(
                z3.UGE(p.states[i][TICK], 1), z3.ULE(p.states[i][TICK], TICK_US)),
                frozenset({TICK})))
        constants = sorted(self._constants())
        if CONSTANT in cells:
            found.append(("the constant register holds a constant the program loads",
                          lambda p, i: z3.Or(*(p.states[i][CONSTANT] == c
                                               for c in constants)),
                          frozenset({CONSTANT})))
        presets = sorted({min(c, TC_MAX_VALUE) for c in constants})
        for n in self.cycle.timers:
            if ("T", n) not in cells:
                continue
            for bound in presets:
                found.append((f"timer {n} holds at most {bound * 10} ms",
                              _at_most(("T", n), bound), frozenset({("T", n)})))
        found += started(self.program, frozenset(cells), self.map_counters)
        for cell in cells:
            if cell[0] == "C":
                found.append((f"counter {cell[1]} at most {TC_MAX_VALUE}",
                              _at_most(cell, TC_MAX_VALUE), frozenset({cell})))
        for pair in self.twins:
            a, b = pair.first[0], pair.second[0]
            if a in cells and b in cells:
                relation = "the complement of" if pair.inverted else "equal to"
                found.append((f"{_element_text(pair.first)} in the first {relation} "
                              f"{_element_text(pair.second)} in the second", _same(pair),
                              frozenset({a, b})))
        return found

    def _constants(self) -> set[int]:
        """Every value the constant register can be loaded with (and its reset value)."""
        values = {0}
        values.update(timer_ticks(ms) for ms in self._loaded(K.KT))
        values.update(self._loaded(K.KC))
        values.update(address << 4 | bit for address, bit in self._loaded_pairs(K.KP))
        return values

    def _loaded_pairs(self, kind: ast.OperandKind) -> list[tuple[int, int]]:
        """(address, bit) of every constant of ``kind`` an ``L`` loads."""
        return [(node.operand.address, node.operand.bit)
                for module in self.program.modules() for section in module.sections
                for node in ast.nodes(section)
                if isinstance(node, ast.Load) and node.operand.kind is kind]

    def _loaded(self, kind: ast.OperandKind) -> list[int]:
        return [address for address, _ in self._loaded_pairs(kind)]

    def find_invariants(self, deadline: float) -> None:
        """The facts every reachable state satisfies, proved among ``candidates``."""
        self.current = None
        self.scope = None
        remaining = self.houdini(self.candidates(), deadline)
        self.invariants = [(fact, cells) for _, fact, cells in remaining]
        self.invariant_names = [name for name, _, _ in remaining]

    def unsettled(self, deadline: float) -> list[tuple[Key, Key]]:
        """The compared pairs the invariants proved so far do not make equal. Only they
        can differ in a reachable state, so only their cone needs following: a
        difference behind a timer in one part of two long programs is searched for over
        that part alone. Out of time, all of them."""
        solver = z3.SolverFor("QF_BV")
        path = _Path(self, solver, "u.", initial=False)
        self._strengthen(path, 0, self.invariants)
        state = path.states[0]
        found = []
        for a, b in self.observed:
            solver.set("timeout", _ms_until(deadline))
            result = solver.check(state[a] != state[b])
            if result == z3.sat:
                found.append((a, b))
            elif result != z3.unsat:
                return list(self.observed)
        return found

    def houdini(self, candidates: list[Candidate], deadline: float) -> list[Candidate]:
        """Houdini: drop every candidate a reachable state (the first one) or a step from
        states satisfying all remaining candidates (and the invariants already proved)
        violates, until none is violated; out of time, none. Over the current property's
        cone and with its monitor, when one is being decided: a fact about the monitor
        then holds in every state of a run that was good before it. Each of the two
        checks builds its cycle once and asks again under assumptions (a literal per
        candidate), so that a round costs a solver call, not a model."""
        remaining = list(candidates)
        for initial in (True, False):
            if not remaining:
                break
            solver = z3.SolverFor("QF_BV")
            path = _Path(self, solver, "h.", initial=initial)
            assumed = [z3.Bool(f"h.assume.{n}") for n in range(len(remaining))]
            if not initial:
                for literal, (_, fact, _) in zip(assumed, remaining, strict=True):
                    solver.add(z3.Implies(literal, fact(path, 0)))
                self._strengthen(path, 0, self.invariants)
                path.extend()
            last = len(path.states) - 1
            checks = [fact(path, last) for _, fact, _ in remaining]
            alive = list(range(len(remaining)))
            for round_ in range(len(remaining) + 1):
                violated = z3.Bool(f"h.violated.{round_}")
                solver.add(z3.Implies(violated, z3.Or(*(z3.Not(checks[n]) for n in alive))))
                solver.set("timeout", _ms_until(deadline))
                result = solver.check(violated, *(assumed[n] for n in alive))
                if result == z3.unsat:
                    break
                if result != z3.sat:
                    return []  # out of time: assume nothing
                model = solver.model()
                alive = [n for n in alive
                         if z3.is_true(model.eval(checks[n], model_completion=True))]
                if not alive:
                    break
            remaining = [remaining[n] for n in alive]
        return remaining

    def _waiting_facts(self, prop: Property, deadline: float) -> list[
            tuple[Fact, frozenset[Key]]]:
        """For a response whose cone holds timers: the proved facts that tie its waiting
        trigger to a running timer (``timers.waiting``), found within a quarter of the
        time left."""
        assert self.scope is not None
        if prop.kind is not Kind.RESPONSE:
            return []
        timers = [n for n in self.cycle.timers if ("T", n) in self.scope]
        presets = sorted({min(c, TC_MAX_VALUE) for c in self._constants()})
        candidates = waiting(timers, presets, self.setup.cycle_us, self.scope)
        if not candidates:
            return []
        now = time.monotonic()
        found = self.houdini(candidates, now + max(0.0, deadline - now) / 4)
        return [(fact, cells) for _, fact, cells in found]

    # -------------------------------------------------------------- deciding

    def decide(self, prop: Property, *, depth: int, timeout_s: float,
               since: float | None = None, horizon: int | None = None) -> Outcome:
        """One property's verdict within ``timeout_s`` from ``since`` (time.monotonic;
        default now: a command's first property counts the model's building too);
        ``horizon``: how many cycles the concrete runs go to (default: ``horizon``)."""
        start = time.monotonic()
        origin = start if since is None else since
        deadline = origin + timeout_s

        def out_of_time(k: int) -> Outcome:
            return Outcome(prop, Verdict.UNKNOWN, k, time.monotonic() - start,
                           note=f"time limit ({format_duration(timeout_s * 1000)}) after {k} "
                                f"cycles, {format_duration((time.monotonic() - origin) * 1000)}"
                                " since it started")

        self.current = prop
        self.scope = self.cone(prop)
        if prop.kind is Kind.RESPONSE:  # a response is judged over its whole window
            depth = max(depth, self.window(prop) + 2)
        step = _Path(self, z3.Solver(), "s.", initial=False)
        facts = self.invariants + self._waiting_facts(prop, deadline)
        self._strengthen(step, 0, facts)
        reach = prop.kind is Kind.REACHABLE
        base, fixed = self._base_path("b.", jumps=False)
        # beside it, steps of idle cycles (prove/jump.py): each check within a budget,
        # as they can be much harder; the first out of its budget ends them
        jumping = self._base_path("j.", jumps=True) if self.jumps_possible(prop) else None
        steps = 0  # the steps of idle cycles searched
        # the concrete runs (prove/falsify.py): when the search has taken some CPU time
        # without a verdict, again after four times that, and at its end
        cpu, tried, falsify_at = time.process_time(), False, FALSIFY_AFTER_CPU_S

        # a failure found with steps of idle cycles, kept while the plain search looks a
        # few cycles further for a shorter one (a step may stand for more cycles than
        # the failure needs): (the outcome, the step it was found at)
        pending: tuple[Outcome, int] | None = None
        for k in range(depth + 1):
            if pending is not None and (k >= len(pending[0].trace or ()) - 1
                                        or k > pending[1] + SHORTER_CYCLES):
                return pending[0]
            if k:
                base.extend()
                if pending is None:
                    step.extend()
                    self._strengthen(step, k, facts)
            began = time.monotonic()
            result, any_phase = self._base_check(base, k, fixed, deadline)
            if result == z3.sat:
                return self._failure(prop, base, k, start, deadline,
                                     fixed=None if any_phase else fixed)
            if result != z3.unsat:
                return pending[0] if pending is not None else out_of_time(k)
            if pending is not None:
                continue
            spent = time.monotonic() - began
            step.solver.set("timeout", _ms_until(deadline))
            step_bad = z3.Or(self.bad(step, k), step.overruns[k])
            outcome = step.solver.check(step_bad)
            if outcome == z3.unsat:
                verdict = Verdict.UNREACHABLE if reach else Verdict.PROVED
                return Outcome(prop, verdict, k, time.monotonic() - start,
                               trivially=self.trivially(prop))
            step.solver.add(z3.Not(step_bad))
            if outcome != z3.sat:
                return out_of_time(k)
            if jumping is not None:
                path, switch = jumping
                if k:
                    path.extend()
                until = min(deadline, time.monotonic() + JUMP_BUDGET_S + 4 * spent)
                result, any_phase = self._base_check(path, k, switch, until)
                if result == z3.sat:
                    found = self._failure(prop, path, k, start, deadline,
                                          fixed=None if any_phase else switch)
                    if found.verdict is Verdict.UNKNOWN:
                        return found
                    pending = (found, k)
                elif result == z3.unsat:
                    steps = k + 1
                else:
                    jumping = None
            used = time.process_time() - cpu
            if used >= falsify_at:  # not decided quickly: perhaps a failure far behind
                tried, falsify_at = True, 4 * used
                ran = self.falsify(prop, searched=k + 1, depth=depth, horizon=horizon,
                                   start=start, deadline=min(deadline, time.monotonic()
                                                             + max(FALSIFY_S, used / 4)))
                if ran is not None:
                    return ran
        if pending is not None:
            return pending[0]
        if not tried:
            ran = self.falsify(prop, searched=depth + 1, depth=depth, horizon=horizon,
                               start=start, deadline=min(deadline, time.monotonic() + max(
                                   FALSIFY_S, (deadline - time.monotonic()) / 3)))
            if ran is not None:
                return ran
        if self._pdr(prop, deadline, facts) is True:
            verdict = Verdict.UNREACHABLE if reach else Verdict.PROVED
            return Outcome(prop, verdict, depth, time.monotonic() - start,
                           note="by an inductive invariant (PDR), beyond k-induction",
                           trivially=self.trivially(prop))
        note = self.beyond(depth)
        if steps and note:
            note += (f"; runs of up to {steps} steps were searched too, each stretch of "
                     "idle cycles (where only timers count down) one step")
        return Outcome(prop, Verdict.BOUNDED, depth, time.monotonic() - start, note=note)

    def _base_path(self, tag: str, *, jumps: bool) -> tuple[_Path, z3.BoolRef]:
        """A path from the reset for the base case, and the switch that holds its clock
        to the simulator's phase (so that a counterexample replays tick for tick)."""
        path = _Path(self, z3.Solver(), tag, initial=True, jumps=jumps)
        fixed = z3.Bool(f"{tag}simulator_phase")
        if self.setup.phase_us is not None and path.phase is not None:
            path.solver.add(z3.Implies(fixed, path.phase == self.setup.phase_us))
        return path, fixed

    def _base_check(self, path: _Path, k: int, fixed: z3.BoolRef,
                    until: float) -> tuple[z3.CheckSatResult, bool]:
        """Whether the state after step ``k`` of ``path`` can be bad: first with the
        simulator's phase of the clock, then with any (the second of the answer: found
        only so), both checks by ``until`` (time.monotonic)."""
        bad = z3.Or(self.bad(path, k), path.overruns[k])
        path.solver.set("timeout", _ms_until(until))
        result = path.solver.check(bad, fixed)
        if result == z3.unsat and self.setup.phase_us is not None:
            path.solver.set("timeout", _ms_until(until))  # what the first check left
            return path.solver.check(bad), True
        return result, False

    def _failure(self, prop: Property, path: _Path, k: int, start: float, deadline: float,
                 *, fixed: z3.BoolRef | None) -> Outcome:
        """The counterexample or witness of the model ``path``'s solver found after step
        ``k`` (``fixed``: found with the simulator's phase of the clock, which it then
        keeps), made quiet; unknown when the cycle overran its loop bound. A step of idle
        cycles is as many cycles in the trace, so its length counts the cycles."""
        model = path.solver.model()
        if z3.is_true(model.eval(path.overruns[k], model_completion=True)):
            trace = self._trace(path, model, k)
            loops = ", ".join(f"line {loop.line}" for loop in self.cycle.loops)
            return Outcome(prop, Verdict.UNKNOWN, len(trace) - 1, time.monotonic() - start,
                           trace, f"in cycle {len(trace)} a backward jump ({loops}) is taken "
                                  f"more than {self.cycle.loops[0].bound} times, the most "
                                  "the model follows")
        wanted = [self.bad(path, k)] + ([] if fixed is None else [fixed])
        if path.jumps:
            model, shortest = _fewest_cycles(path, model, k, wanted, deadline)
            wanted.append(shortest)
        model = _quiet(path, model, k, wanted, deadline)
        verdict = Verdict.REACHED if prop.kind is Kind.REACHABLE else Verdict.REFUTED
        phase = (None if path.phase is None
                 else model.eval(path.phase, model_completion=True).as_long())
        note = ""
        if fixed is None and phase is not None and self.setup.phase_us is not None:
            note = (f"found only with the first 10 ms tick {phase / 1000:g} ms after time 0 "
                    "(the scenario's first_tick_ms), where asictl sim has it at "
                    f"{self.setup.phase_us / 1000:g} ms unless told")
        note = "; ".join(n for n in (note, self._firmware_note()) if n)
        trace = self._trace(path, model, k)
        return Outcome(prop, verdict, len(trace) - 1, time.monotonic() - start, trace,
                       note, self._values(prop, path, model, k), phase_us=phase)

    def span(self) -> int:
        """How long, in cycles, what the current property depends on can take to play
        out: the presets of its timers (their sum, each with the cycle that starts it and
        the one that sees it end) times the largest counter preset the program loads (a
        counter that counts the runs of a timer)."""
        assert self.scope is not None
        cycle_us = self.setup.cycle_us
        timers = sum(-(-ms * 1000 // cycle_us) + 2 for n, ms in self.presets().items()
                     if ("T", n) in self.scope)
        counts = max(self._loaded(K.KC), default=0) if any(
            isinstance(node, ast.Count) or (isinstance(node, ast.Store)
                                            and node.operand.kind is K.C)
            for module in self.program.modules() for node in module.code()) else 0
        return timers * (counts + 1)

    def _cone_inputs(self) -> list[Bit]:
        """The input bits the current property depends on: each bit the program reads of
        a slave whose inputs reach the property's cells, and each host-written bit that
        does."""
        assert self.scope is not None
        names = {var.decl().name(): name for name, var in self.cycle.inputs.items()}
        used = {names[c.decl().name()] for cell in self.scope if cell in self.cycle.post
                for c in _constants(self.cycle.post[cell]) if c.decl().name() in names}
        read: set[tuple[int, int]] = set()
        for operand, _ in uses(self.program):
            if operand.kind in (K.I, K.I2):
                read.add((operand.address, operand.bit))
            elif operand.kind in (K.IB, K.I2B):
                first = operand.address & ~1
                read.update((a, b) for a in (first, first + 1) for b in range(4))
        bits: list[Bit] = [("in", a, b) for a, b in sorted(read) if f"in.{a}" in used]
        bits += [("host", n, b) for n, mask in sorted(self.cycle.host_masks.items())
                 if f"host.{n}" in used for b in range(8) if mask >> b & 1]
        return bits

    def goal(self, prop: Property, horizon: int) -> Goal:
        """What runs of held inputs of the current property (its cone, ``scope``) look
        for, up to ``horizon`` cycles, on the simulator's phase of the clock."""
        assert self.scope is not None and self.setup.phase_us is not None
        exprs = [*self.assume, prop.expr] + ([prop.then] if prop.then is not None else [])
        words = any(ref.operand.node.kind is K.T and ref.operand.node.width is not
                    ast.Width.BIT for expr in exprs for ref in refs(expr)) or any(
            isinstance(node, ast.Load) and node.operand.kind is K.T
            for module in self.program.modules() for node in module.code())
        return Goal(prop, self.assume, self._cone_inputs(), self.cycle.slaves,
                    self.cycle.host_masks, self.setup.cycle_us, self.setup.phase_us,
                    self.window(prop) if prop.kind is Kind.RESPONSE else 0, horizon,
                    jumps=not words)

    def falsify(self, prop: Property, *, searched: int, depth: int, horizon: int | None,
                start: float, deadline: float) -> Outcome | None:
        """A counterexample (witness) found by running the program on input sequences of
        few changes (``prove/falsify.py``) by ``deadline`` (time.monotonic), replayed in
        the simulator before it is told (``replay``); None
        when none is found, or the runs cannot be made (no simulator to replay them, two
        programs compared, firmware blocks the run cannot answer). They go to
        ``horizon`` cycles (``--depth`` given), else to ``span`` cycles past ``depth``,
        and only if that is beyond what the search of every input sequence covers: the
        ``searched`` cycles it did, and ``depth`` for the span."""
        if (self.replay is None or self.observed or self.twins
                or self.setup.phase_us is None or not runs_alone(self.program)):
            return None
        self.current = prop
        self.scope = self.cone(prop)
        reach = horizon
        if reach is None:  # beyond the depth the search of every input sequence goes to
            span = self.span()
            if span <= depth:
                return None
            reach = min(MOST, span + depth)
        if reach <= searched:
            return None
        goal = self.goal(prop, reach)
        found = falsify(self.program, goal, deadline)
        if found is None:
            return None
        trace: list[Step] = []
        for inputs, host in found.inputs:
            if not trace or trace[-1].inputs is not inputs:
                trace.append(Step(inputs, host))
            else:
                trace.append(trace[-1])
        changes = f"{found.changes} change{'s' if found.changes != 1 else ''}"
        note = (f"found by running the program on input sequences of few changes, each "
                f"held, up to {reach:,} cycles ({changes} here): not necessarily the "
                f"shortest; the search of every input sequence found none within "
                f"{searched:,} cycles")
        verdict = Verdict.REACHED if prop.kind is Kind.REACHABLE else Verdict.REFUTED
        outcome = Outcome(prop, verdict, len(trace) - 1, 0.0, trace, note,
                          {ref.text: found.read(ref.operand) for expr in [prop.expr] + (
                              [prop.then] if prop.then is not None else [])
                           for ref in refs(expr)},
                          phase_us=self.setup.phase_us if TICK in self.scope else None)
        if not self.replay(outcome):
            return None
        outcome.seconds = time.monotonic() - start
        return outcome

    def presets(self) -> dict[int, int]:
        """Timer -> the longest time (ms, in whole ticks) a ``S T n`` starts it with: the
        last ``L KT`` before it in the same module, or else any the program loads."""
        found: dict[int, int] = {}
        loaded = [timer_ticks(c) * 10 for c in self._loaded(K.KT)]
        for module in self.program.modules():
            last: int | None = None
            for section in module.sections:
                for node in ast.nodes(section):
                    if isinstance(node, ast.Load) and node.operand.kind is K.KT:
                        last = timer_ticks(node.operand.address) * 10
                    elif (isinstance(node, ast.Store) and node.op is ast.StoreOp.SET
                          and node.operand.kind is K.T):
                        n = node.operand.address
                        ms = last if last is not None else max(loaded, default=0)
                        found[n] = max(found.get(n, 0), ms)
        return found

    def beyond(self, depth: int) -> str:
        """What a bounded verdict of the current property misses: each timer in its cone
        that runs longer than the cycles searched, and a depth that would cover them."""
        cycle_ms = self.setup.cycle_us / 1000
        cycles = depth + 1
        parts: list[str] = []
        most = 0
        for n, ms in sorted(self.presets().items()):
            if self.scope is not None and ("T", n) not in self.scope:
                continue
            needed = math.ceil(ms / cycle_ms)
            if needed < cycles:
                continue
            timer = self.label(f"T {n}")
            parts.append(f"{timer} is loaded with {ms} ms = {needed} cycles of {cycle_ms:g} "
                         f"ms: not covered by depth {cycles}")
            most = max(most, needed)
        if not parts:
            return ""
        suggested = _round_up(most + cycles)
        seconds = math.ceil(suggested * cycle_ms / 1000)
        return "; ".join(parts) + f"; try --depth {suggested} or --depth {seconds}s"

    def _firmware_note(self) -> str:
        """A counterexample or witness of a property that depends on a firmware block's
        answer (left free: any answer) says so, since the master's firmware gives one
        answer and the simulator may not replay it."""
        answers = {var.decl().name() for name, var in self.cycle.inputs.items()
                   if name.startswith("fw.")}
        cells = self.scope if self.scope is not None else frozenset(self.cycle.post)
        if not any(c.decl().name() in answers for cell in cells if cell in self.cycle.post
                   for c in _constants(self.cycle.post[cell])):
            return ""
        return ("it may rest on a firmware block's answer (PSeg after GetLAS, SetPP, "
                "PARAM ...), which the proof leaves free: the simulator's firmware answers "
                "as the master does, so the scenario may not show it")

    def trivially(self, prop: Property) -> str:
        """Why a proved ``prop`` holds whatever the program does, or "" if it does not:
        its condition decides alike in every state (a tautology, or a contradiction for
        never and reachable), or no cycle can change its value, so the reset decides it
        (it names nothing the program writes). Such a verdict says nothing about the
        program, and the report says so rather than a bare "proved"."""
        if self.observed:
            return ""
        cycle = self.cycle
        decides = prop.then if prop.kind is Kind.RESPONSE else prop.expr
        assert decides is not None
        wanted = prop.kind in (Kind.ALWAYS, Kind.RESPONSE)

        def read(cells: dict[Key, z3.BitVecRef]) -> Callable[[ast.Operand], z3.BitVecRef]:
            return lambda operand: operand_value(operand, cells.__getitem__,
                                                 self.map_counters)

        def written(expr: Expr) -> str:  # each operand named as the verdicts name it
            return show(expr, lambda ref: self.label(str(ref.operand)))

        before = read(cycle.pre)
        solver = z3.Solver()
        solver.set("timeout", 2000)
        says = "every state" if wanted else "no state"
        if solver.check(condition(decides, before) != wanted) == z3.unsat:
            return f"'{written(decides)}' holds in {says}"
        solver.add(*(condition(a, before) for a in self.assume))
        if solver.check(condition(decides, before) != wanted) == z3.unsat:
            return f"'{written(decides)}' holds in {says} [assume] allows"
        if prop.kind is Kind.RESPONSE:
            return ""
        after = read(cycle.post)
        solver.add(*(condition(a, after) for a in self.assume))
        if solver.check(condition(prop.expr, before) != condition(prop.expr, after)) \
                == z3.unsat:
            return (f"no cycle of the program changes '{written(prop.expr)}', so it is as "
                    "after the reset")
        return ""

    def _pdr(self, prop: Property, deadline: float,
             known: list[tuple[Fact, frozenset[Key]]]) -> bool | None:
        """Property-directed reachability (z3's Spacer engine) on the cycle as Horn
        clauses: True when it finds an inductive invariant that excludes every bad state,
        None when it cannot say in the time left."""
        left = int((deadline - time.monotonic()) * 1000)
        if left < 100:
            return None
        first = _Collector()
        start = _Path(self, first, "p0.", initial=True)
        rules = _Collector()
        path = _Path(self, rules, "p.", initial=False)
        path.extend()
        cells = sorted(path.cells, key=cell_name)
        response = prop.kind is Kind.RESPONSE

        def arguments(which: _Path, index: int, tag: str) -> tuple[list[z3.ExprRef],
                                                                  list[z3.BoolRef]]:
            args: list[z3.ExprRef] = [which.states[index][c] for c in cells]
            ties: list[z3.BoolRef] = []
            if response:
                monitor = which.monitors[index]
                active, age = z3.Bool(f"{tag}active"), z3.BitVec(f"{tag}age", 16)
                ties = [active == monitor["active"], age == monitor["age"]]
                args += [active, age]
            return args, ties

        sorts = [z3.BitVecSort(width(c)) for c in cells]
        if response:
            sorts += [z3.BoolSort(), z3.BitVecSort(16)]
        invariant = z3.Function("Inv", *sorts, z3.BoolSort())
        error = z3.Function("Err", z3.BoolSort())
        fp = z3.Fixedpoint()
        fp.set(engine="spacer")
        fp.set("timeout", left)
        fp.register_relation(invariant, error)
        head, ties = arguments(start, 0, "p0.m.")
        before, ties0 = arguments(path, 0, "p.m0.")
        after, ties1 = arguments(path, 1, "p.m1.")
        facts = [fact(path, 0) for fact, cells in known if cells <= path.cells]
        constants = {v for term in [*head, *before, *after, *ties, *ties0, *ties1,
                                    *first.constraints, *rules.constraints]
                     for v in _constants(term)}
        fp.declare_var(*constants)
        fp.rule(invariant(*head), [*first.constraints, *ties])
        fp.rule(invariant(*after), [invariant(*before), *rules.constraints, *facts,
                                    *ties0, *ties1])
        fp.rule(error(), [invariant(*before), self.bad(path, 0), *ties0])
        fp.rule(error(), [invariant(*before), *rules.constraints, *ties0,
                          path.overruns[1]])
        try:
            result = fp.query(error())
        except z3.Z3Exception:
            return None
        return True if result == z3.unsat else None

    @staticmethod
    def _strengthen(path: _Path, index: int,
                    facts: list[tuple[Fact, frozenset[Key]]]) -> None:
        for fact, cells in facts:
            if cells <= path.cells:
                path.solver.add(fact(path, index))

    def _values(self, prop: Property, path: _Path, model: z3.ModelRef,
                index: int) -> dict[str, int]:
        if self.observed:
            state = path.states[index]
            return {cell_name(cell): model.eval(state[cell], model_completion=True).as_long()
                    for pair in self.observed for cell in pair}
        read = path.reader(index)
        exprs = [prop.expr] + ([prop.then] if prop.then is not None else [])
        return {ref.text: model.eval(read(ref.operand.node), model_completion=True).as_long()
                for expr in exprs for ref in refs(expr)}

    def _trace(self, path: _Path, model: z3.ModelRef, last: int) -> list[Step]:
        """The input of every cycle: a step of many idle cycles, its inputs as often."""
        steps = []
        for index in range(last + 1):
            inputs = path.inputs[index]
            slaves = {a: model.eval(inputs[f"in.{a}"], model_completion=True).as_long()
                      for a in self.cycle.slaves}
            host = {n: model.eval(inputs[f"host.{n}"], model_completion=True).as_long()
                    for n in self.cycle.host_masks}
            repeat = model.eval(path.cycles[index], model_completion=True).as_long()
            steps += [Step(slaves, host) for _ in range(repeat)]
        return steps

    def jumps_possible(self, prop: Property) -> bool:
        """Whether a step of the search may stand for many idle cycles (``prove/jump.py``):
        a timer the property depends on is followed, the program (both, when two are
        compared) reads those timers only as bits (never ``L T n``), and nothing judged
        reads a timer's word (an assumption's or the property's ``TV n``, a compared
        timer)."""
        timers = {cell for cell in self.cycle.stored
                  if self.scope is None or cell in self.scope}
        if not timers:
            return False  # (no timer the property depends on: no idle cycles to jump)
        sides = ([((), self.program)] if self.second is None
                 else [(("a",), self.program), (("b",), self.second)])
        if any(isinstance(node, ast.Load) and node.operand.kind is K.T
               and (*side, "T", node.operand.address) in timers
               for side, program in sides for module in program.modules()
               for section in module.sections for node in ast.nodes(section)):
            return False
        if any(cell in timers for pair in self.observed for cell in pair):
            return False
        exprs = [*self.assume, prop.expr] + ([prop.then] if prop.then is not None else [])
        return not any(ref.operand.node.kind is K.T
                       and ref.operand.node.width is not ast.Width.BIT
                       for expr in exprs for ref in refs(expr))
