"""Each example program of the manual, compiled and run on the emulator, does what the
manual says it does."""

from __future__ import annotations

import pytest
from manual_examples import EXAMPLES

from asictl.codegen8051.compiler import compile_program
from asictl.diagnostics import DiagnosticError
from asictl.il.checks import check_source
from asictl.runtime.program_map import LoadedProgram
from asictl.runtime.runner import ProgramRunner
from asictl.source import from_string


class RecordingFirmware:
    """Remembers every firmware call; SendPrm answers with the parameter it was sent."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, bytes]] = []

    def call(self, name: str, pseg: bytearray) -> None:
        self.calls.append((name, bytes(pseg[:2])))
        if name == "SendPrm":
            pseg[0], pseg[1] = 0, pseg[1]
        else:
            pseg[0] = 0


def runner_for(text: str, firmware=None) -> ProgramRunner:
    result = check_source(from_string("example.asi", text))
    assert not result.has_errors, result.diagnostics
    compiled = compile_program(result.program)
    return ProgramRunner(
        LoadedProgram(compiled.code, compiled.pmap, compiled.entry_points), firmware=firmware
    )


def inputs(**bits: int) -> bytes:
    """Input image from keyword pairs like s4_0=1 (slave 4, bit 0)."""
    image = bytearray(16)
    for name, value in bits.items():
        slave, bit = (int(x) for x in name[1:].split("_"))
        if value:
            image[slave >> 1] |= 1 << ((slave & 1) * 4 + bit)
    return bytes(image)


def q(runner: ProgramRunner, slave: int, bit: int) -> int:
    return runner.outputs[slave >> 1] >> ((slave & 1) * 4 + bit) & 1


@pytest.mark.parametrize(
    ("i4", "i5", "f42_7", "expected"),
    [(a, b, f, int((a or b) and not f)) for a in (0, 1) for b in (0, 1) for f in (0, 1)],
)
def test_or_and_not_network(i4: int, i5: int, f42_7: int, expected: int):
    runner = runner_for(EXAMPLES["or_and_not"])
    runner.cpu.xdata.write(0x200 + 42, f42_7 << 7)
    runner.cycle(inputs(s4_0=i4, s5_0=i5))
    assert q(runner, 17, 3) == expected


@pytest.mark.parametrize(("fy1", "fy2"), [(10, 3), (3, 10), (0, 0), (255, 1), (0, 255)])
def test_subtraction(fy1: int, fy2: int):
    runner = runner_for(EXAMPLES["subtraction"])
    runner.cpu.xdata.write(0x201, fy1)
    runner.cpu.xdata.write(0x202, fy2)
    runner.cycle()
    assert runner.flag(3) == (fy1 - fy2) % 256


def test_blink_1hz():
    """Q 31.0 on at 250 ms, off at 750 ms, on at 1250 ms (5 ms cycles, 10 ms ticks)."""
    runner = runner_for(EXAMPLES["blink"])
    seen = {}
    for ms in range(0, 1300, 5):
        if ms and ms % 10 == 0:
            runner.tick()
        runner.cycle()
        seen[ms] = q(runner, 31, 0)
    assert (seen[250], seen[750], seen[1250]) == (1, 0, 1)
    edges = [ms for ms in range(5, 1300, 5) if seen[ms] != seen[ms - 5]]
    assert edges == [500, 1000]


def test_param_on_edges():
    firmware = RecordingFirmware()
    runner = runner_for(EXAMPLES["param_edges"], firmware)
    runner.cycle(inputs(s12_0=0))
    assert firmware.calls == []
    runner.cycle(inputs(s12_0=1))  # rising edge: 3 to slave 13
    runner.cycle(inputs(s12_0=1))
    assert firmware.calls == [("SendPrm", bytes([13, 3]))]
    assert runner.flag(127) == 0x80 | 3
    runner.cycle(inputs(s12_0=0))  # falling edge: 12
    assert firmware.calls[1:] == [("SendPrm", bytes([13, 12]))]
    assert runner.flag(127) == 0x80 | 12


@pytest.mark.parametrize("i5", [0, 1])
@pytest.mark.parametrize("i4", [0, 1])
def test_gating(i4: int, i5: int):
    runner = runner_for(EXAMPLES["gating"])
    runner.cycle(inputs(s4_0=i4, s5_0=i5))
    assert q(runner, 17, 3) == int(i4 or i5)
    assert q(runner, 17, 2) == i5


def test_set_power_up_parameter():
    firmware = RecordingFirmware()
    runner = runner_for(EXAMPLES["set_pp"], firmware)
    runner.cycle()
    assert firmware.calls == [("SetPP", bytes([17, 0x0A]))]


def test_assembler_findings_are_reported_at_the_il_line():
    result = check_source(from_string("w.asi", "[PROGRAM]\n    A I 1.0\n    ASM mov a,TR0\n"))
    compiled = compile_program(result.program)
    [warning] = compiled.diagnostics
    assert (warning.code, warning.span.file, warning.span.line) == ("W501", "w.asi", 3)
    bad = check_source(from_string("e.asi", "[PROGRAM]\n    A I 1.0\n    ASM mov q,#1\n"))
    with pytest.raises(DiagnosticError) as info:
        compile_program(bad.program)
    assert [(d.span.file, d.span.line) for d in info.value.diagnostics] == [("e.asi", 3)]
