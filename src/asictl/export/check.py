"""``asictl export --check``: the exported AWL in awlsim beside the reference interpreter.

awlsim (an independent S7 runtime, from PyPI) runs in its own Python, found through
``ASICTL_AWLSIM_PYTHON`` or the ``awlsim-test`` script on PATH (docs/migrate.md);
``awlsim_driver.py`` is what it runs. A run is a list of cycles, each with the inputs,
the 10 ms ticks since the last cycle, and what the host wrote to the flags before it.
Both machines run it from a cold start; after every cycle the outputs, the flags, the
timers and the counters must be equal, and the first difference is named by operand.

The runs: the program's scenario, as ``asictl sim`` runs it on the emulated master (its
inputs, ticks and host writes recorded cycle by cycle, the plant models included), and
generated input sequences at cycle times that are multiples of 10 ms.
The expected side is the reference interpreter (il/oracle.py), which the compiler's
differential tests hold equal to the emulated master.
"""

from __future__ import annotations

import json
import os
import random
import shutil
import subprocess
import tempfile
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from asictl.errors import UserError
from asictl.export.awl import AwlProgram
from asictl.export.layout import COUNTER_DB, IMAGE_BYTES, TIMER_DB
from asictl.il import ast
from asictl.il.loader import Program
from asictl.il.oracle import Interpreter
from asictl.platform.master import TICK_US
from asictl.sim.engine import Simulation
from asictl.sim.session import Prepared

#: Where the check finds awlsim's Python, and blark.
PYTHON_VARIABLE = "ASICTL_AWLSIM_PYTHON"
BLARK_VARIABLE = "ASICTL_BLARK"
_DRIVER = Path(__file__).with_name("awlsim_driver.py")
_FLAGS = 128


@dataclass(frozen=True)
class Cycle:
    """One program cycle of a run."""

    inputs: bytes
    #: 10 ms ticks of master time since the last cycle
    ticks: int = 0
    #: the flags as the master had them before the cycle (a host may have written some),
    #: or None where nobody writes them
    flags: bytes | None = None


@dataclass(frozen=True)
class Difference:
    run: str
    cycle: int
    operand: str
    il: int
    awl: int

    def __str__(self) -> str:
        return (f"{self.run}: cycle {self.cycle}: {self.operand} is {self.il} on the master, "
                f"{self.awl} in awlsim")


def awlsim_python(explicit: str | None = None) -> str:
    """The Python with awlsim: the option, the variable, or the one beside awlsim-test."""
    chosen = explicit or os.environ.get(PYTHON_VARIABLE)
    if chosen:
        return chosen
    script = shutil.which("awlsim-test")
    if script is not None:
        beside = Path(script).with_name("python3")
        if beside.exists():
            return str(beside)
    raise UserError(f"awlsim not found: install awlsim 0.77.1 (e.g. in a venv) and set "
                    f"{PYTHON_VARIABLE} to its python, or put its awlsim-test on PATH")


def blark_parse(text: str, blark: str | None = None) -> str | None:
    """Parse Structured Text with blark (an independent IEC 61131-3 parser, found through
    ``ASICTL_BLARK`` or on PATH): None when it parses, else blark's complaint."""
    program = blark or os.environ.get(BLARK_VARIABLE) or shutil.which("blark")
    if program is None:
        raise UserError(f"blark not found: install blark 0.8.3 (e.g. in a venv) and set "
                        f"{BLARK_VARIABLE} to its blark script, or put it on PATH")
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "export.st"
        path.write_text(text, encoding="utf-8")
        try:
            done = subprocess.run([program, "parse", str(path)], capture_output=True,
                                  text=True, check=False)
        except OSError as exc:
            raise UserError(f"{program}: cannot run: {exc.strerror or exc}") from None
    return None if done.returncode == 0 else (done.stdout + done.stderr).strip()


class Awlsim:
    """awlsim in a subprocess, holding one program."""

    def __init__(self, awl: str, python: str, symbols: str = "") -> None:
        """``symbols``: a symbol table (awlsim's CSV) to load with the program."""
        try:
            self.process = subprocess.Popen(
                [python, str(_DRIVER)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                text=True,
            )
        except OSError as exc:
            raise UserError(f"{python}: cannot run: {exc.strerror or exc}") from None
        try:
            self.load(awl, symbols)
        except UserError:
            self.close()
            raise

    def load(self, awl: str, symbols: str = "") -> None:
        """Hold this program from now on (the process stays: a load is much quicker)."""
        answer = self._ask({"load": awl, "symbols": symbols})
        if "error" in answer:
            raise UserError(f"awlsim refuses the exported AWL:\n{answer['error']}")

    def _ask(self, request: dict[str, object]) -> dict[str, object]:
        stdin, stdout = self.process.stdin, self.process.stdout
        assert stdin is not None and stdout is not None
        stdin.write(json.dumps(request) + "\n")
        stdin.flush()
        line = stdout.readline()
        if not line:
            raise UserError("awlsim stopped (see its messages above)")
        answer: dict[str, object] = json.loads(line)
        return answer

    def run(self, cycles: Sequence[tuple[int, bytes, dict[int, int]]],
            read: Sequence[tuple[str, int, int]]) -> list[list[bytes]]:
        answer = self._ask({
            "run": [[clock, inputs.hex(), {str(k): v for k, v in writes.items()}]
                    for clock, inputs, writes in cycles],
            "read": [list(r) for r in read],
        })
        if "error" in answer:
            raise UserError(f"awlsim stopped the program:\n{answer['error']}")
        rows = answer["cycles"]
        assert isinstance(rows, list)
        return [[bytes.fromhex(h) for h in row] for row in rows]

    def close(self) -> None:
        if self.process.stdin is not None:
            self.process.stdin.close()
        self.process.wait()

    def __enter__(self) -> Awlsim:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class Checker:
    """One program, its export, and awlsim: runs compared cycle by cycle."""

    def __init__(self, program: Program, export: AwlProgram, awlsim: Awlsim) -> None:
        self.program = program
        self.export = export
        self.awlsim = awlsim
        self.counters = sorted(n for n in _used(program, ast.OperandKind.C)
                               if not export.layout.counter_mapped(n))
        self.timers = sorted(_used(program, ast.OperandKind.T))

    def compare(self, name: str, run: Sequence[Cycle]) -> Difference | None:
        """Run both machines; the first difference, or None."""
        oracle = Interpreter(self.program)
        clock = 0
        requests = []
        states = []
        for cycle in run:
            clock += 10 * cycle.ticks
            oracle.tick(cycle.ticks)
            writes = {}
            if cycle.flags is not None:  # what the host wrote, as the oracle did not
                writes = {n: v for n, (v, was) in enumerate(zip(cycle.flags,
                                                                oracle.state.flags,
                                                                strict=True))
                          if v != was}
                oracle.state.flags[:] = cycle.flags
            oracle.cycle(cycle.inputs)
            requests.append((clock, cycle.inputs, writes))
            states.append(self._state(oracle))
        read = [("Q", 0, IMAGE_BYTES), ("M", 0, _FLAGS)]
        read += [(str(TIMER_DB), 2 * n, 2) for n in self.timers]
        read += [(str(COUNTER_DB), 2 * n, 2) for n in self.counters]
        rows = self.awlsim.run(requests, read)
        for index, (state, row) in enumerate(zip(states, rows, strict=True)):
            difference = self._first(name, index, state, row)
            if difference is not None:
                return difference
        return None

    def _state(self, oracle: Interpreter) -> list[bytes]:
        """The oracle's state after a cycle, as awlsim's is read."""
        state = oracle.state
        words = [state.timers.get(n, 0) for n in self.timers]
        words += [state.counters.get(n, 0) for n in self.counters]  # unmapped ones
        return [bytes(state.outputs), bytes(state.flags),
                *(w.to_bytes(2, "big") for w in words)]

    def _first(self, name: str, index: int, il: list[bytes], awl: list[bytes]
               ) -> Difference | None:
        (il_q, il_f, *il_words), (awl_q, awl_f, *awl_words) = il, awl
        for byte in range(IMAGE_BYTES):
            if awl_q[byte] != il_q[byte]:
                bit = (awl_q[byte] ^ il_q[byte]).bit_length() - 1
                return Difference(name, index, f"Q {2 * byte + bit // 4}.{bit % 4}",
                                  il_q[byte] >> bit & 1, awl_q[byte] >> bit & 1)
        for byte in range(_FLAGS):
            if awl_f[byte] != il_f[byte]:
                bit = (awl_f[byte] ^ il_f[byte]).bit_length() - 1
                return Difference(name, index, f"F {byte}.{bit}", il_f[byte] >> bit & 1,
                                  awl_f[byte] >> bit & 1)
        names = [f"T {n}" for n in self.timers] + [f"C {n}" for n in self.counters]
        for operand, mine, theirs in zip(names, il_words, awl_words, strict=True):
            if mine != theirs:
                return Difference(name, index, operand, int.from_bytes(mine, "big"),
                                  int.from_bytes(theirs, "big"))
        return None


def scenario_run(prepared: Prepared) -> list[Cycle]:
    """The cycles of the scenario as ``asictl sim`` runs it on the emulated master: each
    cycle's inputs, the ticks before it and the flags (host writes included)."""
    simulation = Simulation(prepared.build, prepared.scenario, duration_ms=prepared.end_ms,
                            symbols=prepared.symbols)
    simulation.load()
    runner, board = simulation.runner, simulation.board
    assert runner is not None
    seen: list[tuple[bytes, int, bytes]] = []

    def watch(inputs: bytes | bytearray | None) -> None:
        flags = bytes(runner.flag(n) for n in range(_FLAGS))
        seen.append((bytes(runner.inputs if inputs is None else inputs),
                     board.next_tick_us, flags))

    runner.watch = watch
    simulation.begin()
    simulation.run_to(simulation.end_ms)
    run = []
    last = seen[0][1] if seen else 0
    for inputs, tick_us, flags in seen:
        run.append(Cycle(inputs, (tick_us - last) // TICK_US, flags))
        last = tick_us
    return run


def generated_runs(count: int, seed: int, length: int = 60) -> Iterator[tuple[str, list[Cycle]]]:
    """Random input sequences: few bits change from one cycle to the next (so edges and
    delays happen), cycle times of 10 ms mostly, sometimes a long one (a timer runs out)."""
    rng = random.Random(seed)
    for n in range(count):
        inputs = bytearray(rng.randbytes(IMAGE_BYTES))
        run = []
        for _ in range(length):
            for _ in range(rng.choice((0, 0, 1, 1, 2, 4))):
                bit = rng.randrange(IMAGE_BYTES * 8)
                inputs[bit // 8] ^= 1 << bit % 8
            ticks = rng.choice((1, 1, 1, 1, 2, 5, 50, 200))
            run.append(Cycle(bytes(inputs), ticks))
        yield f"sequence {n + 1} (seed {seed})", run


def _used(program: Program, kind: ast.OperandKind) -> set[int]:
    """The numbers of the timers or counters the program names."""
    return {operand.address for module in program.modules() for statement in module.code()
            for operand, _ in ast.operands(statement) if operand.kind is kind}
