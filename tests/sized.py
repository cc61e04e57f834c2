"""One property test at two sizes: the default run's sample and, behind the ``slow``
marker, the long run's (docs/performance.md, "The test suite")."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis.strategies import SearchStrategy


def sizes(default: int, long: int) -> pytest.MarkDecorator:
    """The test's ``examples``: ``default``, and ``long`` in the long run."""
    return pytest.mark.parametrize(
        "examples", [default, pytest.param(long, marks=pytest.mark.slow)])


def check(examples: int, body: Callable[..., None], *strategies: SearchStrategy[Any]) -> None:
    """``body`` on ``examples`` draws of ``strategies``, as ``@given`` runs it."""
    settings(max_examples=examples, deadline=None,
             suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])(
        given(*strategies)(body))()
