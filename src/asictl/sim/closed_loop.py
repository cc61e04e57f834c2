"""The plant models in a simulation (closed loop), as an observer (sim/observer.py).

The models (sim/plant.py) are evaluated at time 0 before any cycle, after every AS-i
cycle that ran and at each model's own next change, which the core applies as a ``set``
at its time; a model that will change an input sooner than the current advance was
planned to end asks the core to pause the board there (``Simulation.wake_at``).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from asictl.codes import ScenarioCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Severity, Span
from asictl.il import ast
from asictl.observe.operands import Operand
from asictl.sim.observer import Observer
from asictl.sim.plant import Model, Plant

if TYPE_CHECKING:  # the engine imports this module
    from asictl.sim.engine import Simulation


class ClosedLoop(Observer):
    """The plant models of one run; ``sample_ms``: how often a trace samples a moving
    model between its changes (None: no trace)."""

    def __init__(self, simulation: Simulation, plant: Plant, sample_ms: float | None) -> None:
        self._simulation = simulation
        self._io = _PlantIO(simulation)
        self.plant = plant
        self._sample_ms = sample_ms

    def add(self, model: Model) -> None:
        """Add a model; ``ValueError`` if another model drives one of its inputs or a slave
        of them is not on the bus."""
        self.plant.add(model)
        try:
            self._check([model])
        except ValueError:
            self.plant.models.remove(model)
            raise

    def active(self) -> bool:
        return bool(self.plant.models)

    def sampled(self) -> Iterable[Operand]:
        return (o for m in self.plant.models for o in m.sensed())

    def begin(self) -> None:
        """The models' inputs at time 0, before any cycle."""
        self._check(self.plant.models)
        self.plant.update(0.0, self._io)

    def after_cycle(self, now: float) -> None:
        plant = self.plant
        plant.update(now, self._io)
        change = plant.next_change_ms(self._sample_ms)
        if change is not None:
            self._simulation.wake_at(change)

    def next_change_ms(self) -> float | None:
        return self.plant.next_change_ms(self._sample_ms)

    def changed(self, at: float) -> None:
        self.plant.update(at, self._io)

    def _check(self, models: list[Model]) -> None:
        """Every input these plant models drive belongs to a slave on the bus."""
        simulation = self._simulation
        for model in models:
            for operand in model.driven():
                node = operand.node
                if node.kind in (ast.OperandKind.I, ast.OperandKind.IB) \
                        and not simulation.board.bus.at(node.address):
                    message = (f"{model.name} drives '{operand}' of slave {node.address}, "
                               "which is not on the bus")
                    if not model.line:
                        raise ValueError(message)
                    raise DiagnosticError([Diagnostic(
                        Severity.ERROR, ScenarioCode.NO_SUCH_SLAVE, message,
                        Span(simulation.scenario.file, model.line, 1),
                    )])


class _PlantIO:
    """The plant models' view of a simulation: operands as ``Simulation.read`` gives
    them, inputs written as a scenario's ``set`` writes them."""

    def __init__(self, simulation: Simulation) -> None:
        self._simulation = simulation

    def read(self, operand: Operand) -> int:
        return self._simulation.read(operand)

    def write(self, operand: Operand, value: int) -> None:
        self._simulation.set(operand, value)
