"""Two versions of a program: whether they behave the same (what changed, network by
network, is ``il/networks.py``'s).

``equivalent`` runs both programs side by side on one symbolic master (the same slaves,
the same host writes, the same firmware answers call for call, one 10 ms clock) and asks
whether any input sequence makes what is compared differ after some cycle. What is
compared is what a user of the program can see: the outputs, the flags the host writes
(``; asictl: host``, which it also reads) and the ``observe`` operands; every other flag,
timer and counter is the program's own, so renaming it changes nothing (mutation testing
passes all of them as ``observe``: ``readable``).

The proof matches the two programs' states rather than unrolling them: candidate pairs
of elements that held the same value on a random run of both (``prove/correspond.py``),
kept by Houdini's algorithm while their conjunction holds after the first cycle and is
kept by one cycle of both (``Machine.find_invariants``); when that invariant makes the
compared cells equal, the verdict is ``equivalent`` at depth 0. Otherwise only the
compared cells it leaves open are searched further, over their cone alone
(``Machine.unsettled``: a difference behind a timer in one part of two long programs is
looked for in that part): k-induction on top of the invariant, or PDR, may still prove
them equal; ``different`` comes with the distinguishing input sequence (bounded model
checking, beside it steps of idle cycles that cross a running timer in one step,
``prove/jump.py``), ``unknown`` when time runs out first.
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import dataclass, field

from asictl.build import Build
from asictl.il import ast
from asictl.il.ast import key
from asictl.il.loader import Program
from asictl.il.pragmas import read_directives
from asictl.observe.condition import Truth
from asictl.platform.master import asi_cycle_us
from asictl.prove.correspond import SECONDS, Correspondence, Pair, corresponding
from asictl.prove.engine import Machine, Outcome, Setup, Step, Verdict
from asictl.prove.props import Kind, Property
from asictl.prove.scope import uses
from asictl.prove.session import cycles_of, simulator_phase
from asictl.prove.symbolic import (
    TICK,
    Cycle,
    Key,
    TimeLimit,
    Unmodelled,
    build_cycle,
    cell_name,
    host_masks,
    operand_cells,
    product,
)
from asictl.readers.units import Cycles, format_duration

# ---------------------------------------------------------------------- behaviour


@dataclass
class Equivalence:
    """What ``equivalent`` found: ``verdict`` is "equivalent", "different" or
    "unknown"."""

    verdict: str
    #: cycles the search went to, or the induction depth of the proof
    cycles: int
    seconds: float
    #: for "different": the input of every cycle up to the one where they differ
    trace: list[Step] | None = None
    #: for "different": each observed operand's value in the first and second program
    differences: dict[str, tuple[int, int]] = field(default_factory=dict)
    slaves: tuple[int, ...] = ()
    cycle_ms: float = 0.0
    host_masks: dict[int, int] = field(default_factory=dict)
    note: str = ""
    #: the construct that could not be modelled, when that made the verdict "unknown"
    refused: Unmodelled | None = None
    #: for "different": the phase of the 10 ms clock the trace needs (us from time 0 to
    #: the first tick; None: any)
    phase_us: int | None = None


_FLAGS = (ast.OperandKind.F, ast.OperandKind.FY, ast.OperandKind.FW)


def _observed(host: Iterable[ast.Operand], extra: Iterable[ast.Operand],
              map_counters: bool) -> list[Key]:
    """The cells compared after every cycle: the outputs, the host's flags and ``extra``
    (flags, timers, counters, variables)."""
    extra = list(extra)
    cells: list[Key] = [("Q", n) for n in range(16)]
    for n in sorted(host_masks([*host, *(o for o in extra if o.kind in _FLAGS)])):
        cells.append(("F", n))
    for operand in extra:
        if operand.kind not in _FLAGS:
            cells += [c for c in operand_cells(operand, map_counters) if c not in cells]
    return cells


def readable(*programs: Program) -> list[ast.Operand]:
    """Everything of these programs a scenario can expect or a host can read besides the
    outputs: each flag byte, timer, counter and variable byte they use. Two programs the
    same on all of it are the same for every test (mutation testing's ``equivalent``)."""
    found: dict[tuple[object, ...], ast.Operand] = {}
    K = ast.OperandKind
    for program in programs:
        for operand, _ in uses(program):
            if operand.kind in (K.F, K.FY):
                found[("F", operand.address)] = ast.Operand.of(K.FY, operand.address)
            elif operand.kind is K.FW:
                for n in (operand.address, operand.address + 1):
                    found[("F", n)] = ast.Operand.of(K.FY, n)
            elif operand.kind in (K.T, K.C, K.VAR):
                width = ast.Width.WORD if operand.kind is not K.VAR else ast.Width.BYTE
                found[(operand.kind, key(operand.name), operand.address)] = ast.Operand(
                    operand.kind, operand.address, -1, width, operand.name)
    return list(found.values())


def equivalent(
    first: Program | Build,
    second: Program | Build,
    *,
    timeout_s: float = 10.0,
    depth: int | Cycles = 20,
    slaves: Iterable[int] | None = None,
    cycle_ms: float | None = None,
    observe: Iterable[ast.Operand] = (),
) -> Equivalence:
    """Do two programs give the same outputs (and host flags, and ``observe``) after every
    cycle, for every input sequence? ``first`` and ``second`` are programs, or builds
    of them (``asictl.build``: their IL program is taken). ``slaves`` default to both
    programs' [SETUP], ``cycle_ms`` to the AS-i cycle of that bus. A construct either
    program cannot be modelled with (or a build without IL source) makes the verdict
    "unknown", with the reason in ``note`` and the refusal in ``refused``."""
    start = time.monotonic()
    programs = [_program_of(side) for side in (first, second)]
    if programs[0] is None or programs[1] is None:
        return Equivalence("unknown", 0, 0.0, note="a build without IL source")
    try:
        return _equivalent(programs[0], programs[1], start, timeout_s=timeout_s,
                           depth=depth, slaves=slaves, cycle_ms=cycle_ms, observe=observe,
                           built=first if isinstance(first, Build) else None)
    except Unmodelled as exc:
        return Equivalence("unknown", 0, time.monotonic() - start, note=str(exc),
                           refused=exc)
    except TimeLimit:
        seconds = time.monotonic() - start
        return Equivalence("unknown", 0, seconds,
                           note=f"time limit ({format_duration(timeout_s * 1000)}) while "
                           f"building the model, {format_duration(seconds * 1000)} since the "
                           "start")


def _program_of(side: Program | Build) -> Program | None:
    return side.source_program() if isinstance(side, Build) else side


def _equivalent(first: Program, second: Program, start: float, *, timeout_s: float,
                depth: int | Cycles, slaves: Iterable[int] | None, cycle_ms: float | None,
                observe: Iterable[ast.Operand], built: Build | None) -> Equivalence:
    bus = tuple(sorted(set(slaves) if slaves is not None else
                       {s.address for p in (first, second) for s in p.slaves}))
    cycle_us = (round(cycle_ms * 1000) if cycle_ms is not None
                else asi_cycle_us(len(bus)))
    depth = cycles_of(depth, cycle_us / 1000)
    host = [operand for program in (first, second)
            for operand, _ in read_directives(program.sources).host_flags]
    observed = _observed(host, observe, first.options.map_counters)
    deadline = start + timeout_s  # building the two models counts
    cycles = [build_cycle(program, slaves=bus, cycle_us=cycle_us, host_flags=host,
                          watch=observed, prefix=f"{side}.", deadline=deadline)
              for side, program in (("a", first), ("b", second))]
    both = product(*cycles)
    # the scenario written runs the first program: its clock phase in the simulator
    phase = simulator_phase(built, cycle_us) if built is not None else None
    # the run takes at most a quarter of the time left: the proof needs the rest
    budget = min(SECONDS, (deadline - time.monotonic()) / 4)
    run = _correspondence(first, second, cycles, observed, both.host_masks, phase, budget)

    def seen() -> Equivalence:
        """The difference the run of both programs showed."""
        result = Equivalence("different", len(run.steps), time.monotonic() - start,
                             [Step(inputs, host) for inputs, host in run.steps],
                             slaves=bus, cycle_ms=cycle_us / 1000,
                             host_masks=both.host_masks, phase_us=phase,
                             note="found on a random run of both programs")
        for (cell, _), values in run.differences.items():
            _tell(result, cell, *values)
        return result

    if len(run.steps) > depth + 1 and run.differences:
        # later than the search goes: no proof can make them the same; a difference
        # within the depth is searched for below, as the shortest
        return seen()
    pairs = [(("a", *cell), ("b", *cell)) for cell in observed]
    same = Property("same outputs", Kind.ALWAYS, Truth(True), 0)
    twins = [Pair((("a", *pair.first[0]), pair.first[1]),
                  (("b", *pair.second[0]), pair.second[1]), pair.inverted)
             for pair in run.pairs]
    machine = Machine(first, Setup(bus, cycle_us, tuple(host), phase), [], [], prebuilt=both,
                      observed=pairs, twins=twins, second=second, deadline=deadline)
    if not run.differences:
        machine.find_invariants(deadline)
        machine.observed = machine.unsettled(deadline)
        if not machine.observed:  # the invariant makes every compared cell equal
            return Equivalence("equivalent", 0, time.monotonic() - start, slaves=bus,
                               cycle_ms=cycle_us / 1000, host_masks=both.host_masks)
    outcome: Outcome = machine.decide(same, depth=depth, timeout_s=timeout_s, since=start)
    if run.differences and outcome.verdict is not Verdict.REFUTED:
        return seen()  # the search ran out of time: what the run saw still stands
    verdict = {Verdict.PROVED: "equivalent", Verdict.REFUTED: "different"}.get(
        outcome.verdict, "unknown")
    result = Equivalence(verdict, outcome.depth + 1 if outcome.trace else outcome.depth,
                         time.monotonic() - start, outcome.trace, slaves=bus,
                         cycle_ms=cycle_us / 1000, host_masks=both.host_masks,
                         note=outcome.note, phase_us=outcome.phase_us)
    if outcome.verdict is Verdict.BOUNDED:
        result.note = f"no difference within {depth + 1} cycles, and no proof"
    for a, b in pairs:
        x, y = outcome.values.get(cell_name(a)), outcome.values.get(cell_name(b))
        if x is not None and y is not None and x != y:
            _tell(result, a[1:], x, y)
    return result


def _tell(result: Equivalence, cell: Key, first: int, second: int) -> None:
    """A compared cell's two values after the last cycle, as a scenario names them."""
    scale = 10 if cell[0] == "T" else 1  # a timer's ticks as TV reads them: ms
    result.differences[_operand_text(cell)] = (first * scale, second * scale)


def _correspondence(first: Program, second: Program, cycles: list[Cycle],
                    observed: list[Key], masks: dict[int, int], phase: int | None,
                    budget_s: float) -> Correspondence:
    """A random run of both programs: the elements that may always be equal (a
    refactoring's renamed flags, timers and counters among them), or the compared cells
    seen to differ (``prove/correspond.py``). When the run could not be made, every cell
    both programs keep at the same place is a candidate."""
    own = (sorted(cycles[0].post, key=cell_name), sorted(cycles[1].post, key=cell_name))
    run = corresponding(first, second, own, compared=[(cell, cell) for cell in observed],
                        slaves=cycles[0].slaves, cycle_us=cycles[0].cycle_us,
                        host_masks=masks, phase_us=phase, budget_s=budget_s)
    if not run.pairs and not run.differences:
        run.pairs = [Pair((cell, -1), (cell, -1)) for cell in own[0]
                     if cell in cycles[1].post]
    run.pairs = [pair for pair in run.pairs if TICK not in (pair.first[0], pair.second[0])]
    return run


def _operand_text(cell: Key) -> str:
    """A compared cell as a scenario names it (a timer by the time it has left)."""
    kind = cell[0]
    if kind == "Q":
        return f"QB {2 * int(cell[1])}"
    if kind == "T":
        return f"TV {cell[1]}"
    if kind == "C":
        return f"CV {cell[1]}"
    if kind == "V":
        return f"{cell[1]} {cell[2]}"
    return f"FY {cell[1]}"
