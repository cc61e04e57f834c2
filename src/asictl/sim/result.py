"""What a simulation found: the expectations that failed, the stops and refusals, the
trace, the state the program left and the coverage (``SimResult``). The stepping core
and its observers (sim/observer.py) fill it in."""

from __future__ import annotations

from dataclasses import dataclass, field

from asictl.observe.coverage import Coverage
from asictl.observe.iltrace import LineRow
from asictl.observe.operands import Operand
from asictl.readers.units import format_duration, format_instant
from asictl.sim.observation import Refusal, Stop
from asictl.sim.scenario import Scenario, Step
from asictl.sim.trace import Trace


@dataclass
class Failure:
    step: Step
    line: int
    operand: Operand
    expected: int
    got: int
    #: the operand as the scenario wrote it (a symbol, say)
    written: str = ""
    #: the IL line that last wrote the operand before the step's time (``prog.asi:12``),
    #: where it is known: for the expectations of a step with a tolerance window
    writer: str = ""

    @property
    def at_ms(self) -> float:
        return self.step.at_ms

    def __str__(self) -> str:
        name = self.written or str(self.operand)
        window = f" (within {format_duration(self.step.within_ms)})" if self.step.within_ms else ""
        text = (f"at {format_instant(self.step.at_ms)}{window}: {name} expected "
                f"{self.expected}, got {self.got}")
        return f"{text}; last written by {self.writer}" if self.writer else text


@dataclass(frozen=True)
class FinalState:
    """What a program left when the simulation ended: what ``sim`` without expectations
    shows, so that a quick run answers "what does it do?" without a scenario."""

    at_ms: float
    #: each slave with output bits on the bus: the four bits it receives (D0 = bit 0)
    outputs: dict[int, int]
    #: each counter of the program: its value
    counters: dict[int, int]
    #: each timer of the program: its remaining time in milliseconds
    timers_ms: dict[int, int]

    def as_json(self) -> dict[str, object]:
        return {
            "at_ms": self.at_ms,
            "outputs": {str(a): v for a, v in self.outputs.items()},
            "counters": {str(n): v for n, v in self.counters.items()},
            "timers_ms": {str(n): v for n, v in self.timers_ms.items()},
        }


@dataclass
class SimResult:
    scenario: Scenario
    checked: int = 0
    failures: list[Failure] = field(default_factory=list)
    stops: list[Stop] = field(default_factory=list)
    refusals: list[Refusal] = field(default_factory=list)
    trace: Trace | None = None
    il_rows: list[LineRow] = field(default_factory=list)
    end_ms: float = 0.0
    final: FinalState | None = None
    #: what the run reached of the program (with ``coverage=True``)
    coverage: Coverage | None = None

    @property
    def passed(self) -> bool:
        return not self.failures
