"""The one scenario writer: what it writes, the scenario reader reads back unchanged."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from asictl.sim.scenario import SlaveSpec, read_scenario
from asictl.sim.scenario_writer import ScenarioWriter
from asictl.source import from_string

_TIMES = st.integers(0, 24 * 3_600_000_000 - 5000).map(lambda us: us / 1000)
_BITS = st.dictionaries(st.sampled_from([f"I {a}.{b}" for a in (1, 2, 31) for b in range(4)]),
                        st.integers(0, 1), min_size=1, max_size=4)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(_TIMES, _BITS, _BITS), min_size=1, max_size=5),
       st.text(max_size=40), st.floats(0.1, 10_000))
def test_written_steps_read_back_as_written(steps, comment, cycle_ms) -> None:
    out = ScenarioWriter()
    out.comment(comment)
    out.program('odd "name"\\.asi')
    out.master(cycle_ms, [SlaveSpec(1, 0x7, 0xF, 0xA)])
    for at, sets, expects in steps:
        out.step(at, set=sets, expect={k.replace("I", "Q"): v for k, v in expects.items()},
                 within_ms=5)
    scenario = read_scenario(from_string("dir/s.toml", out.text()))
    assert str(scenario.program) == 'dir/odd "name"\\.asi'
    assert scenario.cycle_ms == float(f"{cycle_ms:g}")
    assert scenario.slaves == [SlaveSpec(1, 0x7, 0xF, 0xA)]
    assert [s.at_ms for s in scenario.steps] == [at for at, _, _ in steps]
    assert [{str(o): v for o, v, _ in s.set} for s in scenario.steps] == [
        sets for _, sets, _ in steps]
    assert all(s.within_ms == 5 for s in scenario.steps)


def test_numbers_may_be_written_as_toml_spells_them() -> None:
    out = ScenarioWriter()
    out.step(2000.001, set={"IB 4": "0x0F", "I 1": "0b0101"})
    assert out.text() == '\n[[step]]\nat_ms = 2000.001\nset = { "IB 4" = 0x0F, "I 1" = 0b0101 }\n'
