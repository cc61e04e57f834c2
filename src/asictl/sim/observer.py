"""What a feature of a simulation hooks into: the ``Observer`` protocol.

The stepping core (sim/engine.py) downloads the program, applies the scenario's steps at
their times and lets master time pass; everything else a run does is an observer: the
expectations and their tolerance windows, the plant models, the trace, the per-line
trace, the coverage, the stops and refusals. A new feature is one more observer, in a
module of its own, and one line where ``Simulation`` lists its observers.

The core calls the hooks in the order of that list, and the order is part of the
behaviour: a plant model sets its inputs before a window samples them, a window adds its
failures before the trace marks them. After each cycle and at each change the core calls
only the hooks an observer defines (one it leaves as they are here costs nothing), and an
observer with nothing to do in a run (``active``) is left out when the program starts, so
a run without a feature pays nothing for it after each cycle.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:  # the observers' modules import this one
    from asictl.observe.operands import Operand
    from asictl.sim.plant import Model
    from asictl.sim.result import SimResult
    from asictl.sim.scenario import Step


#: "Just before" a time: sets happen this long before it, so that no cycle at exactly
#: that time has run yet.
BEFORE_MS = 0.001


class Observer(Protocol):
    """One feature of a simulation. Each hook does nothing unless the feature defines it."""

    def active(self) -> bool:
        """Whether it has anything to do in this run, asked when the program starts (before
        ``begin``): one that has not hears no more hooks."""
        return True

    def times(self) -> Iterable[tuple[float, bool]]:
        """The times (ms since time 0) at which ``at_time`` must see the state, and for
        each whether it must see it just before the time (as a step's sets do: no cycle
        at that time has run yet) or at it."""
        return ()

    def sampled(self) -> Iterable[Operand]:
        """The operands it reads after every cycle that runs: timers among them tick one
        by one on the board, so that no value between two reads is skipped."""
        return ()

    def model_added(self, model: Model) -> None:
        """A plant model joined the run (before the program runs)."""
        return None

    def loaded(self) -> None:
        """The program is downloaded, stopped: its runner can be watched."""
        return None

    def begin(self) -> None:
        """Time 0, before its steps are applied and before any program cycle."""
        return None

    def started(self) -> None:
        """The program was started: time 0 is known (the first cycle has run)."""
        return None

    def at_time(self, at: float) -> None:
        """One of the ``times``, a step's time or both, before the steps at that time."""
        return None

    def after_steps(self, steps: list[Step]) -> None:
        """The steps at one time were applied (all of their sets): check them."""
        return None

    def after_any_cycle(self) -> None:
        """After each AS-i cycle the board ran, also before time 0 is known."""
        return None

    def after_cycle(self, now: float) -> None:
        """After each AS-i cycle that ran from time 0 on; ``now`` is its master time."""
        return None

    def next_change_ms(self) -> float | None:
        """When it next changes an input on its own (a plant model), else None: the core
        lets time pass up to just before then and calls ``changed``."""
        return None

    def changed(self, at: float) -> None:
        """The state is wanted as of ``at`` between two cycles (a ``next_change_ms`` came,
        or a reader asked): a plant model sets its inputs, a trace samples them."""
        return None

    def stopped(self, now: float) -> None:
        """The program stopped at ``now``."""
        return None

    def finish(self, result: SimResult) -> None:
        """The run ended: add what it found to ``result``."""
        return None
