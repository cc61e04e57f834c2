"""Scenario files: the schema, and every mistake reported at its line."""

from __future__ import annotations

import pytest

from asictl.diagnostics import DiagnosticError
from asictl.sim.scenario import SlaveSpec, read_scenario
from asictl.source import from_string

GOOD = """\
program = "blink.asi"          # relative to this file
[master]
cycle_ms = 5
slaves = { 16 = "iiio,1", 3 = "Bh,0" }
[[step]]
at_ms = 0
set = { "I 4.0" = 1, "IB 4" = 0x21, "FY 10" = 7 }
[[step]]
at_ms = 250
expect = { "Q 17.3" = 1, "QB 16" = 0x08, "FY 3" = 145, "F 127.7" = 1, "PSeg 0" = 0 }
[[step]]
at_ms = 300
remove_slaves = [16]
add_slaves = { 5 = "oooo,0,Eh" }
power_fail = false
"""


def errors(text: str, variables: dict[str, int] | None = None) -> list[tuple[int, int, str]]:
    with pytest.raises(DiagnosticError) as info:
        read_scenario(from_string("s.toml", text), variables)
    return [(d.span.line, d.span.column, d.message) for d in info.value.diagnostics]


def test_the_documented_example_reads():
    scenario = read_scenario(from_string("dir/s.toml", GOOD))
    assert str(scenario.program) == "dir/blink.asi"
    assert scenario.cycle_ms == 5
    assert scenario.slaves == [SlaveSpec(16, 1, 1, 0xF), SlaveSpec(3, 0xB, 0, 0xF)]
    first, second, third = scenario.steps
    assert [(str(op), value, line) for op, value, line in first.set] == [
        ("I 4.0", 1, 7), ("IB 4", 0x21, 7), ("FY 10", 7, 7)
    ]
    assert [str(op) for op, _, _ in second.expect] == ["Q 17.3", "QB 16", "FY 3", "F 127.7",
                                                        "PSeg 0"]
    assert (third.remove_slaves, third.add_slaves, third.power_fail) == (
        [16], [SlaveSpec(5, 8, 0, 0xE)], False
    )
    assert scenario.end_ms == 300 and [s.line for s in scenario.steps] == [5, 8, 11]


def test_steps_in_any_order_are_run_by_time():
    text = "[[step]]\nat_ms = 20\n[[step]]\nat_ms = 10\n"
    assert [s.at_ms for s in read_scenario(from_string("s.toml", text)).ordered()] == [10, 20]


def _times(step: str) -> list[float]:
    return [s.at_ms for s in read_scenario(from_string("s.toml", f"[[step]]\n{step}\n")).steps]


def test_at_is_a_number_of_milliseconds_or_a_text_with_its_unit():
    assert _times("at = 16") == [16]
    assert _times('at = "16ms"') == [16]
    assert _times('at = "16s"') == [16_000]
    assert _times('at = "1.5min"') == [90_000]
    assert _times("at_ms = 250") == [250]


def test_at_without_a_unit_in_a_text_shows_both_readings():
    assert errors('[[step]]\nat = "16"\n') == [
        (2, 6, "at: '16' has no unit: give a unit: 16ms or 16s")]


def test_at_ms_is_always_milliseconds_and_refuses_a_text():
    ((line, column, message),) = errors('[[step]]\nat_ms = "16s"\n')
    assert (line, column) == (2, 9)
    assert message.startswith("at_ms is a time in milliseconds") and 'at = "16s"' in message
    ((_, _, message),) = errors('[[step]]\nat_ms = "16"\n')
    assert "at_ms is a time in milliseconds" in message


def test_within_takes_a_unit_as_at_does():
    text = '[[step]]\nat = "1s"\nwithin = "50ms"\nexpect = { "Q 1.0" = 1 }\n'
    assert read_scenario(from_string("s.toml", text)).steps[0].within_ms == 50
    ((_, _, message),) = errors('[[step]]\nat = 5\nwithin = "5"\nexpect = { "Q 1.0" = 1 }\n')
    assert message == "within: '5' has no unit: give a unit: 5ms or 5s"


def test_unknown_operand_and_out_of_range_values_point_at_the_key():
    text = '[[step]]\nat_ms = 1\nexpect = { "Q 17.3" = 1, "X 1" = 1, "QB 16" = 256 }\n'
    found = errors(text)
    assert [(line, col) for line, col, _ in found] == [(3, 26), (3, 37)]
    assert "'X' is not a variable declared by the program" in found[0][2]
    assert "value 256 out of range 0..255" in found[1][2]


def test_only_inputs_and_flags_can_be_set():
    found = errors('[[step]]\nat_ms = 0\nset = { "Q 1.0" = 1 }\n')
    assert found == [(3, 9, "'Q 1.0' cannot be set: a scenario sets inputs (I, IB) and flags "
                             "(F, FY)")]


def test_odd_byte_address_and_unknown_variable():
    text = '[[step]]\nat_ms = 0\nexpect = { "IB 5" = 1, "Reading 2" = 0, "Other 0" = 1 }\n'
    messages = [m for _, _, m in errors(text, {"reading": 2})]
    assert messages == [
        "'IB 5': an even slave address 0..30",
        "'Reading 2': 'Reading' has 2 bytes",
        "'Other 0': 'Other' is not a variable declared by the program",
    ]


def test_missing_time_unknown_keys_and_bad_slaves():
    text = (
        "[master]\ncycle_ms = 0\nslaves = { 40 = \"iiii,0\", 3 = \"zz\" }\n"
        "[[step]]\nset = {}\n[[step]]\nat_ms = 5\nwhen = 3\n"
    )
    found = errors(text)
    assert (2, 12, "cycle_ms is a time in milliseconds from 0.1 to 10000, not 0") in found
    assert any(line == 3 and "slave 40" in m for line, _, m in found)
    assert any(line == 3 and "slave 3" in m for line, _, m in found)
    assert (4, 1, 'each step needs a time: at = "2s" (or at_ms = 2000)') in found
    assert any(line == 8 and "unknown key 'when'" in m for line, _, m in found)


def test_an_unknown_key_names_the_closest_known_one():
    text = "progam = \"p.asi\"\n[master]\ncycle_m = 5\n[[step]]\nat_ms = 1\nexpct = {}\n"
    found = {line: m for line, _, m in errors(text)}
    assert "unknown key 'progam'; did you mean 'program'?" in found[1]
    assert "unknown key 'cycle_m' in [master]; did you mean 'cycle_ms'?" in found[3]
    assert "unknown key 'expct' in a step; did you mean 'expect'?" in found[6]
    assert "did you mean" not in errors("[[step]]\nat_ms = 1\nzzz = 1\n")[0][2]


def test_a_time_given_twice_and_a_slave_given_twice_are_errors():
    text = ('[master]\nslaves = { 31 = "oooo,0", "031" = "iiii,0" }\n'
            '[[step]]\nat_ms = 10\nat = "20ms"\n')
    found = errors(text)
    assert (2, 27, "slave 31 is given twice ('031')") in found
    assert (5, 1, "a step's time is at_ms or at, not both") in found


def test_invalid_toml_gives_its_line():
    assert errors("[[step]]\nat_ms = = 3\n")[0][:1] == (2,)
