"""Mutation testing: would the scenarios notice if the program were slightly wrong?

A mutant is the program with one change made on its syntax tree (the operators are in
``mutations``): ``A`` for ``AN``, ``S`` for ``R``, an assignment or a ``BEC`` removed, a
``JC`` made unconditional or removed, a timer or counter constant one step off, a
comparison negated, a bit operand moved to its neighbour, a byte constant one off.
The mutant is compiled from the changed tree (no text is parsed) and run against the
scenarios that test its program, each until its first failed expectation: the first
scenario that fails kills it. A mutant whose 8051 code is the original's is
``equivalent`` without running; one that runs past its time limit (a loop the master
does not end, a simulation that no longer skips idle cycles) is ``timeout``, which
counts as killed. A mutant that survives is either a gap in the scenarios or a change
that makes no difference; when the ``prove`` extra is installed, ``prove_equivalent``
asks the prover, and a proved one is ``equivalent`` too (after a quick search for
inputs on which the two differ, quality/refute.py, which spares the prover the
survivors it could never prove). The score is killed / (mutants - equivalent - invalid).

Each mutant runs in a process of its own, forked from this one (it inherits the
parsed programs and scenarios; nothing but its verdict is sent back), at most ``jobs``
at once; a process past its time limit is killed. A process that dies without an
answer (the OOM killer, a signal) runs its mutant once more; dying again, the mutant is
``died`` and counts as not killed, so a dead worker can never raise the score. The
limit is on the scenarios; the proof of a mutant that passed them all has ``prove_s``
of its own, and one out of time leaves the mutant a survivor.

With a cache (quality/cache.py), a mutant whose program, scenarios, limits and asictl
are those of a kept verdict is not run: its verdict is the kept one.
"""

from __future__ import annotations

import dataclasses
import importlib
import multiprocessing
import multiprocessing.connection
import os
import signal
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, assert_never

from asictl.build import Build, Origin, build_image
from asictl.diagnostics import DiagnosticError
from asictl.il import ast
from asictl.il.loader import Program
from asictl.observe.coverage import LineKey
from asictl.observe.names import named
from asictl.observe.symbols import SymbolTable
from asictl.quality.cache import INTERNAL, Cache, Kept, target_key
from asictl.quality.refute import find_difference
from asictl.readers.units import format_duration
from asictl.sim.session import Prepared, simulate

#: how long the prover may look for a survivor's proof of equivalence, by default: the
#: proofs the demos' equivalent mutants need take under 2 s
PROVE_SECONDS = 5.0
#: how much longer than that its worker may take (z3 does not stop to the millisecond)
PROOF_MARGIN = 5.0
#: the message of a worker whose mutant passed every scenario: its proof begins
_PROVING = "proving"
#: the install hint when equivalence cannot be checked (asictl is not on PyPI: the hint
#: names the package, and the extra for a checkout, as ``errors.missing_extra`` does)
PROVE_HINT = ("equivalence not checked (install the prove extra: pip install 'z3-solver', "
              "or in an asictl checkout pip install '.[prove]')")

_K = ast.OperandKind
#: the highest bit of each bit operand kind a mutant may move to
_TOP_BIT = {_K.I: 3, _K.I2: 3, _K.Q: 3, _K.F: 7, _K.VAR: 7}
_NEGATED = {
    ast.CompareOp.EQ: ast.CompareOp.NE, ast.CompareOp.NE: ast.CompareOp.EQ,
    ast.CompareOp.GT: ast.CompareOp.LE, ast.CompareOp.LE: ast.CompareOp.GT,
    ast.CompareOp.GE: ast.CompareOp.LT, ast.CompareOp.LT: ast.CompareOp.GE,
}
_SWAPPED_LOGIC = {ast.LogicOp.A: ast.LogicOp.AN, ast.LogicOp.AN: ast.LogicOp.A,
                  ast.LogicOp.O: ast.LogicOp.ON, ast.LogicOp.ON: ast.LogicOp.O}
#: constants, their range and one step (a timer constant is kept in 10 ms ticks)
_CONSTANTS = {_K.KT: (40950, 10), _K.KC: (4095, 1), _K.KB: (255, 1)}

Node = ast.Statement | ast.GatingLine


@dataclass(frozen=True)
class Mutant:
    """One change: where (the module, its section, the node's index there), what the
    node becomes (None: removed) and how the report shows it."""

    file: str
    line: int
    column: int
    #: ``A I 1.0 -> AN I 1.0``
    change: str
    module: int
    section: int
    index: int
    replacement: Node | None

    @property
    def name(self) -> str:
        """The mutant among its program's: where, which node, what change (the key of
        its kept result, quality/cache.py)."""
        return (f"{self.file}:{self.line}:{self.column} "
                f"[{self.module}.{self.section}.{self.index}] {self.change}")


@dataclass
class Result:
    mutant: Mutant
    #: killed, timeout, survived, died, equivalent or invalid; killed and timeout count as
    #: killed, died (its worker process died twice) as not killed
    verdict: str
    #: the scenario that killed it, the reason it is invalid or equivalent
    detail: str = ""
    seconds: float = 0.0
    #: read from the cache (quality/cache.py), not judged in this run
    cached: bool = False


def _moved(operand: ast.Operand) -> ast.Operand | None:
    """The neighbouring bit (the next one, the one before at the top)."""
    top = _TOP_BIT.get(operand.kind)
    if top is None or operand.width is not ast.Width.BIT or operand.bit < 0:
        return None
    bit = operand.bit + 1 if operand.bit < top else operand.bit - 1
    return dataclasses.replace(operand, bit=bit)


def _stepped(operand: ast.Operand) -> list[ast.Operand]:
    limit = _CONSTANTS.get(operand.kind)
    if limit is None:
        return []
    top, step = limit
    return [dataclasses.replace(operand, address=value)
            for value in (operand.address - step, operand.address + step) if 0 <= value <= top]


def mutations(node: Node) -> Iterator[Node | None]:
    """Every one-change mutant of a node (None: the node removed)."""
    match node:
        case ast.Logic():
            yield dataclasses.replace(node, op=_SWAPPED_LOGIC[node.op])
            moved = _moved(node.operand)
            if moved is not None:
                yield dataclasses.replace(node, operand=moved)
        case ast.Store():
            if node.op is ast.StoreOp.ASSIGN:
                yield None
            else:
                other = ast.StoreOp.RESET if node.op is ast.StoreOp.SET else ast.StoreOp.SET
                yield dataclasses.replace(node, op=other)
            moved = _moved(node.operand)
            if moved is not None:
                yield dataclasses.replace(node, operand=moved)
        case ast.Jump() | ast.CallFB():
            if node.conditional:
                yield dataclasses.replace(node, conditional=False)
                yield None
        case ast.BlockEnd():
            if node.kind is ast.EndKind.BEC:
                yield None
        case ast.Load():
            for operand in _stepped(node.operand):
                yield dataclasses.replace(node, operand=operand)
        case ast.Compare():
            yield dataclasses.replace(node, op=_NEGATED[node.op])
        case ast.GatingLine():
            yield None
            for i, term in enumerate(node.terms):
                terms = list(node.terms)
                terms[i] = dataclasses.replace(term, negated=not term.negated)
                yield dataclasses.replace(node, terms=tuple(terms))
                moved = _moved(term.operand)
                if moved is not None:
                    terms[i] = dataclasses.replace(term, operand=moved)
                    yield dataclasses.replace(node, terms=tuple(terms))
        case (ast.Not() | ast.Transfer() | ast.Arith() | ast.Count() | ast.SegmentEnd()
              | ast.Param() | ast.Asm() | ast.Label()):
            pass
        case _:
            assert_never(node)


def _body(section: ast.Section) -> tuple[Node, ...]:
    if isinstance(section, ast.ProgramSection):
        return section.statements
    if isinstance(section, ast.GatingSection):
        return section.lines
    return ()


def mutants_of(program: Program) -> list[Mutant]:
    """Every mutant of every module of a program, in file and line order."""
    found: list[Mutant] = []
    for m, module in enumerate(program.modules()):
        for s, section in enumerate(module.sections):
            for i, node in enumerate(_body(section)):
                if node.span is None:
                    continue
                for replacement in mutations(node):
                    after = "removed" if replacement is None else replacement.to_source()
                    found.append(Mutant(
                        node.span.file, node.span.line, node.span.column,
                        f"{node.to_source()} -> {after}", m, s, i, replacement,
                    ))
    return found


def apply(program: Program, mutant: Mutant) -> Program:
    """The program with the mutant's change (the original is left as it is)."""
    module = program.modules()[mutant.module]
    sections = list(module.sections)
    section = sections[mutant.section]
    body = list(_body(section))
    if mutant.replacement is None:
        del body[mutant.index]
    else:
        body[mutant.index] = mutant.replacement
    if isinstance(section, ast.ProgramSection):
        statements = tuple(n for n in body if not isinstance(n, ast.GatingLine))
        sections[mutant.section] = dataclasses.replace(section, statements=statements)
    elif isinstance(section, ast.GatingSection):
        lines = tuple(n for n in body if isinstance(n, ast.GatingLine))
        sections[mutant.section] = dataclasses.replace(section, lines=lines)
    changed = dataclasses.replace(module, sections=tuple(sections))
    if mutant.module == 0:
        return dataclasses.replace(program, main=changed)
    blocks = dict(program.blocks)
    name = list(blocks)[mutant.module - 1]
    blocks[name] = changed
    return dataclasses.replace(program, blocks=blocks)


def build_mutant(original: Build, mutant: Mutant) -> Build:
    """The mutant compiled; raises ``DiagnosticError`` when the compiler refuses it."""
    from asictl.codegen8051.compiler import compile_program

    assert original.program is not None
    program = apply(original.program, mutant)
    compiled = compile_program(program)
    built = Build(original.name, Origin.SOURCE, texts=original.texts, program=program,
                  compiled=compiled)
    built.image = build_image(compiled, with_source=False)
    return built


# ---------------------------------------------------------------------- running


@dataclass
class Target:
    """A program and the scenarios that test it, prepared once in this process."""

    program: Path
    scenarios: list[Prepared]
    #: how long the scenarios take the original, in seconds
    seconds: float = 0.0
    mutants: list[Mutant] = field(default_factory=list)
    #: the statement lines the scenarios run (observe/coverage.py): a mutant elsewhere
    #: changes nothing they run, so it survives without being run
    reached: set[LineKey] = field(default_factory=set)

    #: the results a cache holds for this program's mutants under its key, by name
    kept: dict[str, Kept] = field(default_factory=dict)

    def runs(self, mutant: Mutant) -> bool:
        return (os.path.abspath(mutant.file), mutant.line) in self.reached


def _keeping(cache: Cache, targets: list[Target], settings: object,
             done: Callable[[Result], None] | None) -> Callable[[Result], None]:
    """Read each target's kept results into ``kept``; the ``done`` that keeps a
    target's results in the cache once all its mutants have one (then calls ``done``)."""
    owner: dict[int, int] = {}
    keys: list[str] = []
    pending: list[int] = []
    finished: list[list[Result]] = []
    for number, target in enumerate(targets):
        texts = target.scenarios[0].build.texts
        key = target_key(target.program, texts, [Path(p.scenario.file) for p in
                                                 target.scenarios], settings,
                         target.scenarios[0].symbols)
        keys.append(key)
        target.kept = cache.load(target.program, key)
        pending.append(len(target.mutants))
        finished.append([])
        owner.update((id(mutant), number) for mutant in target.mutants)

    def keep(result: Result) -> None:
        number = owner[id(result.mutant)]
        finished[number].append(result)
        pending[number] -= 1
        if not pending[number]:
            cache.store(targets[number].program, keys[number],
                        [(r.mutant.name, r.verdict, r.detail) for r in finished[number]
                         if r.verdict != "died"])
        if done is not None:
            done(result)

    return keep


def verdict(target: Target, mutant: Mutant, proving: Callable[[], None] | None = None,
            prove_s: float = PROVE_SECONDS) -> tuple[str, str]:
    """Run one mutant against its scenarios (in the worker process); ``proving`` hears
    that they all passed and the question of equivalence begins, which has a time
    limit of its own."""
    original = target.scenarios[0].build
    try:
        built = build_mutant(original, mutant)
    except DiagnosticError as exc:
        return "invalid", exc.diagnostics[0].message if exc.diagnostics else "not compiled"
    assert original.compiled is not None and built.compiled is not None
    if built.compiled.code == original.compiled.code and \
            built.compiled.pmap == original.compiled.pmap:
        return "equivalent", "the same 8051 code"
    for prepared in target.scenarios:
        run = simulate(dataclasses.replace(prepared, build=built), fail_fast=True)
        if run.result.failures:  # its operand named as every note names one
            failure = dataclasses.replace(run.result.failures[0], written=named(
                str(run.result.failures[0].operand), prepared.symbols))
            return "killed", f"{prepared.scenario.file}:{failure.line}: {failure}"
    if proving is not None:
        proving()
    proved = prove_equivalent(original, built, prove_s, target.scenarios[0].symbols)
    if proved is not None:
        return proved
    return "survived", ""


def prove_available() -> bool:
    """Is the prover there (the ``prove`` extra: asictl.prove and z3)?"""
    try:
        importlib.import_module("z3")
        importlib.import_module("asictl.prove")
    except ImportError:
        return False
    return True


def prove_equivalent(original: Build, mutant: Build, prove_s: float = PROVE_SECONDS,
                     symbols: SymbolTable | None = None) -> tuple[str, str] | None:
    """Ask the prover whether a surviving mutant behaves as the original; None when it
    is not installed or cannot tell. A survivor seen to differ from the original on
    random inputs first (quality/refute.py) is one no proof can make equivalent: it is
    ``survived`` at once, the difference its detail (its bits named by ``symbols``, the
    program's table)."""
    if not prove_available():
        return None
    difference = find_difference(original, mutant)
    if difference is not None:
        return "survived", difference.describe(symbols or SymbolTable())
    diff: Any = importlib.import_module("asictl.prove.diff")
    # equivalent for what a scenario can expect: outputs, flags, timers, counters
    programs = [build.source_program() for build in (original, mutant)]
    observe = diff.readable(*(p for p in programs if p is not None))
    answer = diff.equivalent(original, mutant, timeout_s=prove_s, observe=observe)
    if answer.verdict == "equivalent":
        return "equivalent", "proved equivalent (outputs, flags, timers and counters)"
    return None


@dataclass
class _Worker:
    """A worker process and its mutant: when it started, its time limit in seconds, and
    whether its mutant passed every scenario and the proof runs (on a limit of its own:
    a proof out of time leaves a survivor, not a timeout)."""

    process: Any
    pipe: Any
    start: float
    limit: float
    proving: bool = False


def run_all(
    targets: list[Target], *, jobs: int, timeout_s: float | None = None,
    prove_s: float = PROVE_SECONDS, done: Callable[[Result], None] | None = None,
    cache: Cache | None = None,
) -> list[Result]:
    """Every mutant of every target, ``jobs`` processes at once; results in the order of
    the mutants, ``done`` called as each finishes. ``timeout_s`` limits a mutant's
    scenarios, ``prove_s`` the proof of one that passes them all. With a ``cache``, a
    result kept under the same key is taken from it, and each program's results are
    kept there as soon as the last of its mutants is judged."""
    context = multiprocessing.get_context("fork")
    queue = [(target, mutant) for target in targets for mutant in target.mutants]
    results: dict[int, Result] = {}
    if cache is not None:
        done = _keeping(cache, targets, (timeout_s, prove_s, prove_available()), done)
    for index, (target, mutant) in enumerate(queue):
        if not target.runs(mutant):
            results[index] = Result(mutant, "survived", "no scenario runs this line")
        elif mutant.name in target.kept:
            kept = target.kept[mutant.name]
            results[index] = Result(mutant, kept.verdict, kept.detail, cached=True)
        else:
            continue
        if done is not None:
            done(results[index])
    pending = [index for index in range(len(queue)) if index not in results]
    # the mutants of the slowest programs first: the others fill the workers meanwhile
    pending.sort(key=lambda index: -queue[index][0].seconds)
    running: dict[int, _Worker] = {}
    try:
        _run_pending(context, queue, pending, jobs, (timeout_s, prove_s), results, done,
                     running)
    finally:  # interrupted: no worker outlives the run
        for worker in running.values():
            worker.process.kill()
    return [results[i] for i in range(len(queue))]


def _run_pending(
    context: Any, queue: list[tuple[Target, Mutant]], pending: list[int], jobs: int,
    limits: tuple[float | None, float], results: dict[int, Result],
    done: Callable[[Result], None] | None, running: dict[int, _Worker],
) -> None:
    timeout_s, prove_s = limits
    position = 0
    died: set[int] = set()
    while position < len(pending) or running:
        while position < len(pending) and len(running) < max(1, jobs):
            index = pending[position]
            position += 1
            target, mutant = queue[index]
            receive, send = context.Pipe(duplex=False)
            process = context.Process(target=_child, args=(target, mutant, send, prove_s),
                                      daemon=True)
            process.start()
            send.close()
            limit = timeout_s if timeout_s is not None else 10.0 + 5 * target.seconds
            running[index] = _Worker(process, receive, time.monotonic(), limit)
        now = time.monotonic()
        wait = min(w.start + w.limit for w in running.values()) - now
        multiprocessing.connection.wait([w.pipe for w in running.values()],
                                        timeout=max(0.0, wait))
        for index, worker in list(running.items()):
            mutant = queue[index][1]
            elapsed = time.monotonic() - worker.start
            answer = _answer(worker)
            if answer is not None and answer[0] == _PROVING:
                # the scenarios passed: the proof has a time limit of its own
                worker.proving, worker.limit = True, elapsed + prove_s + PROOF_MARGIN
                continue
            if answer is not None:
                kind, detail = answer
            elif not worker.process.is_alive():  # died without a word: killed, OOM
                worker.process.join()
                last = _answer(worker)  # unless it answered just before it ended
                if last is not None and last[0] != _PROVING:
                    kind, detail = last
                elif index not in died:  # once more: the death may have been passing
                    died.add(index)
                    pending.insert(position, index)
                    worker.pipe.close()
                    del running[index]
                    continue
                else:
                    kind, detail = "died", (f"its worker process {_death(worker.process)}, "
                                            "twice: counted as not killed")
            elif elapsed > worker.limit:
                worker.process.kill()
                kind, detail = ("survived", "the proof of equivalence ran out of time") \
                    if worker.proving else ("timeout", "still running after "
                                            f"{format_duration(worker.limit * 1000)}")
            else:
                continue
            worker.process.join()
            worker.pipe.close()
            del running[index]
            results[index] = Result(mutant, kind, detail, elapsed)
            if done is not None:
                done(results[index])


def _answer(worker: _Worker) -> tuple[str, str] | None:
    """What the worker sent, if anything; None when it has said nothing (yet, or ever:
    a process that has ended and left nothing in the pipe died)."""
    if not worker.pipe.poll():
        return None
    try:
        kind, detail = worker.pipe.recv()
    except EOFError:  # the pipe closed without a word: the process is gone
        worker.process.join()
        return None
    return str(kind), str(detail)


def _death(process: Any) -> str:
    """How a worker ended, for a mutant's detail: 'was killed by SIGKILL', 'exited 1'."""
    code = process.exitcode
    if code is not None and code < 0:
        try:
            return f"was killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"was killed by signal {-code}"
    return f"exited {code} without an answer"


def _child(target: Target, mutant: Mutant, send: Any, prove_s: float) -> None:
    try:
        answer = verdict(target, mutant, lambda: send.send((_PROVING, "")), prove_s)
    except Exception as exc:  # a bug: reported as the mutant's detail, never a hang
        answer = ("invalid", f"{INTERNAL}{type(exc).__name__}: {exc}")
    send.send(answer)
    send.close()


def score(verdicts: Iterable[str]) -> tuple[int, int]:
    """(killed, counted): timeouts are killed; a mutant whose worker died twice counts as
    not killed (a dead worker can only lower the score); equivalent and invalid mutants
    are not counted."""
    seen = list(verdicts)
    killed = sum(1 for v in seen if v in ("killed", "timeout"))
    counted = sum(1 for v in seen if v in ("killed", "timeout", "survived", "died"))
    return killed, counted
