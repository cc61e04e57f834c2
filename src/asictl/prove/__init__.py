"""Proving properties of IL programs and comparing two versions of one.

``props`` reads properties files; ``symbolic`` is the program cycle as z3 terms, built
from the reference interpreter's rules; ``engine`` decides properties (bounded model
checking for counterexamples and witnesses, k-induction strengthened with invariants it
finds for proofs); ``counterexample`` writes what it finds as scenarios; ``diff``
compares two programs network by network and decides whether they behave the same, on the
pairs of state elements ``correspond`` finds alike.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from asictl.prove.diff import Equivalence, equivalent

__all__ = ["Equivalence", "equivalent"]

#: The most cycles a search or an induction goes to (``--depth``), and how far they go
#: when it is not given.
MAX_DEPTH = 10_000
DEPTH = 20


def __getattr__(name: str) -> object:
    """``equivalent`` and ``Equivalence`` (the API mutation testing calls), imported on
    first use so that reading a properties file needs no z3."""
    if name in __all__:
        from asictl.prove import diff

        return getattr(diff, name)
    raise AttributeError(name)
