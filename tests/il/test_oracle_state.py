"""``PlcState.copy``: a state of its own, for the searches that branch (the falsifier,
the exhaustive runs of the prover's tests)."""

from __future__ import annotations

import dataclasses

from asictl.il.oracle import PlcState
from asictl.prove.falsify import _Written


def sample() -> PlcState:
    return PlcState(inputs=bytearray(b"\x01" * 16), timers={1: 5}, counters={2: 3},
                    variables={"v": bytearray(b"\x01\x02")}, accu1=7, rlo=True, constant=9)


def test_a_copy_is_equal_and_changing_it_leaves_the_original_as_it_was() -> None:
    state = sample()
    twin = state.copy()
    assert twin == state
    twin.inputs[0] = twin.old_inputs[0] = twin.outputs[0] = twin.flags[0] = 2
    twin.pseg[0] = 2
    twin.timers[1] = 0
    twin.timers[4] = 1
    twin.counters[2] = 0
    twin.variables["v"][0] = 9
    twin.variables["w"] = bytearray(1)
    twin.accu1 = twin.accu2 = 0
    twin.rlo = False
    assert state == sample()


def test_every_field_is_copied_or_immutable() -> None:
    """A field of a new kind fails here until ``copy`` copies it."""
    state = sample()
    twin = state.copy()
    for field in dataclasses.fields(PlcState):
        value = getattr(state, field.name)
        if isinstance(value, bytearray | dict):
            assert getattr(twin, field.name) is not value, field.name
            if field.name == "variables":
                assert all(twin.variables[k] is not v for k, v in value.items())
        else:
            assert type(value) in (int, bool), field.name


def test_the_falsifiers_timer_table_stays_one_with_what_it_saw_written() -> None:
    table = _Written({1: 5})
    table[2] = 0
    state = PlcState(timers=table)
    twin = state.copy()
    assert isinstance(twin.timers, _Written) and twin.timers == {1: 5, 2: 0}
    assert twin.timers.written == {2} and twin.timers.written is not table.written
    twin.timers[3] = 1
    assert table.written == {2} and 3 not in table
