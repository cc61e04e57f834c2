"""Counterexamples and witnesses as scenario files.

A counterexample is the input sequence the engine found, one ``set`` step per program
cycle (only what changed), and at the end one ``expect`` of what the property wanted:
the operands of the property at values that would have satisfied it, so that ``asictl
sim`` of the file fails at that step and its trace, ``--plot``, ``--trace-il`` and
``asictl debug`` show why. A witness of a ``reachable`` property expects what the
program reached there, so it passes.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import z3

from asictl.il import ast
from asictl.observe.condition import Expr, Negation, refs
from asictl.observe.names import bits_of, named
from asictl.observe.symbols import SymbolTable
from asictl.prove.engine import Outcome, Step, Verdict, condition
from asictl.prove.props import Kind, Properties, Property
from asictl.sim.scenario import SlaveSpec
from asictl.sim.scenario_writer import ScenarioWriter

K = ast.OperandKind
#: The first line of every file written here (what may be replaced without --force).
_MARKED = "asictl prove:"
MARK = f"# {_MARKED}"


@dataclass(frozen=True)
class Expectation:
    #: the operand as the property wrote it, and the value expected of it
    text: str
    value: int


def _goal(prop: Property) -> Expr:
    """What the last state should have satisfied."""
    if prop.kind is Kind.RESPONSE:
        assert prop.then is not None
        return prop.then
    if prop.kind is Kind.NEVER:
        return Negation(prop.expr)
    return prop.expr


def expectations(prop: Property, outcome: Outcome, values: dict[str, int]) -> list[Expectation]:
    """The ``expect`` of the last step: for a refuted property, the fewest operands
    changed from what the program left (``values``, by operand text) so that the
    property would hold; for a reached one, what the program left."""
    goal = _goal(prop)
    seen: dict[str, ast.Operand] = {}
    maxima: dict[str, int] = {}
    for ref in refs(goal):
        seen.setdefault(ref.text, ref.operand.node)
        maxima[ref.text] = ref.operand.maximum
    names = list(seen)
    if outcome.verdict is Verdict.REACHED:
        return [Expectation(name, values[name]) for name in names]
    variables = {name: z3.BitVec(f"x.{name}", 32) for name in names}
    by_node = {seen[name]: variables[name] for name in names}
    wanted = condition(goal, by_node.__getitem__)
    bounds = [z3.ULE(variables[name], maxima[name]) for name in names]
    for changed in [[name] for name in names] + [names]:
        solver = z3.Optimize()
        solver.add(wanted, *bounds)
        for name in names:
            if name not in changed:
                solver.add(variables[name] == values[name])
            else:  # the value nearest to what the program left
                x, was = variables[name], values[name]
                solver.minimize(z3.If(z3.UGT(x, was), x - was, was - x))
        if solver.check() == z3.sat:
            model = solver.model()
            found = [Expectation(name, model.eval(variables[name]).as_long())
                     for name in changed]
            return [e for e in found if e.value != values[e.text]] or found
    # the property holds in no state: expect the first operand to differ
    first = names[0]
    return [Expectation(first, 0 if values[first] else 1)]


def _number(value: int, bits: int) -> str:
    return f"0b{value:0{bits}b}" if bits == 4 else f"0x{value:02X}" if bits == 8 else str(value)


def scenario_text(props: Properties, program: Path, target: Path, prop: Property,
                  outcome: Outcome, masks: dict[int, int], cycle_ms: float,
                  expected: list[Expectation]) -> str:
    """The scenario of one counterexample or witness, to be written at ``target``."""
    assert outcome.trace is not None
    what = "witness" if outcome.verdict is Verdict.REACHED else "counterexample"
    source = Path(props.file).name
    cycles = len(outcome.trace)
    fate = ("passes" if outcome.verdict is Verdict.REACHED
            else "fails at the last step")
    out = ScenarioWriter()
    out.comment(f"{_MARKED} {what} for property '{prop.name}' of {source}\n"
                f"{prop.text()}\n"
                f"{cycles} program cycle{'s' if cycles != 1 else ''}; asictl sim --scenario "
                f"{target.name} {fate}.")
    if outcome.phase_us is None:
        out.comment("phase: any (the property does not depend on the 10 ms clock)")
    if outcome.note:
        out.comment(f"note: {outcome.note}")
    names = _names(outcome.trace, masks, expected, props.symbols)
    if names:
        out.comment(f"names: {names}")
    out.program(Path(os.path.relpath(program.resolve(), target.resolve().parent)).as_posix())
    out.master(cycle_ms, props.slaves, _first_tick_ms(outcome.phase_us))
    _steps(out, outcome.trace, masks, cycle_ms, expected)
    return out.text()


def _first_tick_ms(phase_us: int | None) -> float | None:
    """The phase of the clock a trace assumes, as a scenario's ``first_tick_ms``: the
    prover leaves it free, and the scenario replays only on the one it found."""
    return None if phase_us is None else phase_us / 1000


def _steps(out: ScenarioWriter, trace: list[Step], masks: dict[int, int], cycle_ms: float,
           expected: list[Expectation]) -> None:
    """The steps of a trace: a ``set`` of what changed at each cycle's start and the
    ``expect`` just after the last cycle."""
    for index, sets in _changed(trace, masks):
        out.step(index * cycle_ms, set=sets)
    out.step((len(trace) - 1) * cycle_ms + 0.001,
             expect={e.text: e.value for e in expected})


def difference_text(old: Path, new: Path, target: Path, trace: list[Step],
                    masks: dict[int, int], cycle_ms: float,
                    differences: dict[str, tuple[int, int]],
                    slaves: list[SlaveSpec] | None = None,
                    symbols: SymbolTable | None = None,
                    phase_us: int | None = None) -> str:
    """The scenario that tells two programs apart: it expects what ``old`` does, so it
    passes on ``old`` and fails on ``new`` at its last step (on the clock's phase
    ``phase_us`` the trace needs, if any). A byte that differs is expected bit by bit,
    only the bits that differ, the first of them (an output, where one differs) named in
    a comment with its symbol."""
    symbols = symbols if symbols is not None else SymbolTable()
    bits = [bit for text, (first, second) in differences.items()
            for bit in bits_of(text, first, second)]
    out = ScenarioWriter()
    out.comment(f"{_MARKED} a difference between {old.name} and {new.name}\n"
                f"passes on {old.name}; asictl sim {new.name} --scenario {target.name} "
                "fails at the last step.")
    if bits:
        text, first, second = bits[0]
        out.comment(f"first difference: {named(text, symbols)} is {first} in {old.name}, "
                    f"{second} in {new.name}")
    out.program(Path(os.path.relpath(old.resolve(), target.resolve().parent)).as_posix())
    out.master(cycle_ms, slaves, _first_tick_ms(phase_us))
    _steps(out, trace, masks, cycle_ms, [Expectation(text, first) for text, first, _ in bits])
    return out.text()


def _names(trace: list[Step], masks: dict[int, int], expected: list[Expectation],
           symbols: SymbolTable) -> str:
    """``I 1.0 (Start), Q 3.1 (PumpB)``: the operands the scenario sets and expects that
    the program's symbol table names."""
    texts = [key for _, sets in _changed(trace, masks) for key in sets]
    texts += [e.text for e in expected]
    shown = [named(text, symbols) for text in dict.fromkeys(texts)]
    return ", ".join(text for text in shown if text.endswith(")"))


def _changed(trace: list[Step], masks: dict[int, int]) -> Iterator[tuple[int, dict[str, str]]]:
    """The cycles (by index) at which some input changes, and what changes there. A step
    that is the step before it (a run of held inputs: an hour of them, say) changes
    nothing and is passed over at once."""
    inputs: dict[int, int] = {}
    flags: dict[int, int] = {}
    before: Step | None = None
    for index, step in enumerate(trace):
        if step is before:
            continue
        before = step
        sets = _changes(step, inputs, flags, masks)
        if sets:
            yield index, sets


def _changes(step: Step, inputs: dict[int, int], flags: dict[int, int],
             masks: dict[int, int]) -> dict[str, str]:
    sets = {}
    for address, value in sorted(step.inputs.items()):
        old = inputs.get(address, 0)
        # bit by bit, only the bits that change: a slave's other inputs hold their value
        sets.update({f"I {address}.{b}": _number(value >> b & 1, 1)
                     for b in range(4) if (old ^ value) >> b & 1})
        inputs[address] = value
    for n, value in sorted(step.host.items()):
        mask = masks[n]
        value &= mask
        if flags.get(n, 0) == value:
            continue
        if mask == 0xFF:
            sets[f"FY {n}"] = _number(value, 8)
        else:
            old = flags.get(n, 0)
            sets.update({f"F {n}.{b}": _number(value >> b & 1, 1)
                         for b in range(8) if mask >> b & 1 and (old ^ value) >> b & 1})
        flags[n] = value
    return sets


def file_name(props_path: Path, prop: Property) -> str:
    """``NAME.cex.<slug>.scenario.toml`` for ``NAME.props.toml``."""
    name = props_path.name
    stem = name[: -len(".props.toml")] if name.endswith(".props.toml") else props_path.stem
    return f"{stem}.cex.{prop.slug}.scenario.toml"
