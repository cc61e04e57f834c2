"""The collector pause of the front end: off inside, back on after, whatever happens."""

from __future__ import annotations

import gc

import pytest

from asictl.il import checks
from asictl.il.checks import check_source
from asictl.il.collector import collector_paused
from asictl.source import from_string


def test_paused_inside_and_running_after() -> None:
    assert gc.isenabled()
    with collector_paused():
        assert not gc.isenabled()
        with collector_paused():
            assert not gc.isenabled()
        assert not gc.isenabled()  # the inner block did not pause it
    assert gc.isenabled()


def test_running_again_after_an_exception() -> None:
    with pytest.raises(ZeroDivisionError), collector_paused():
        1 / 0  # noqa: B018
    assert gc.isenabled()


def test_left_off_where_it_was_off() -> None:
    gc.disable()
    try:
        with collector_paused():
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_checking_pauses_the_collector(monkeypatch: pytest.MonkeyPatch) -> None:
    seen = []

    def check_program(*args: object, **kwargs: object) -> list[object]:
        seen.append(gc.isenabled())
        return []

    monkeypatch.setattr(checks, "check_program", check_program)
    result = check_source(from_string("p.asi", "[PROGRAM]\n    A I 1.0\n    = Q 1.0\n"))
    assert result.diagnostics == []
    assert seen == [False]
    assert gc.isenabled()
