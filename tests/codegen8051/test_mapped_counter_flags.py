"""With map_counters, flag bytes 97, 99 .. 125 are the mapped counters' high bytes: only
bits 0-3 hold the count, the upper four are always 0 (programming manual, the option
map_counters; il-semantics.md). A program that writes such a byte and reads it back in
the same cycle must read what the counter holds, in the compiled 8051 code and in the
reference interpreter alike; the board's mask after the cycle comes too late for that."""

from __future__ import annotations

import pytest
from il_strategies import ModelFirmware

from asictl.codegen8051.compiler import compile_program
from asictl.il.loader import load_program
from asictl.il.oracle import Interpreter
from asictl.platform.master import flag_keeps
from asictl.runtime.program_map import LoadedProgram
from asictl.runtime.runner import ProgramRunner
from asictl.source import from_string

HEADER = "[OPTIONS]\nmap_counters: yes\n[SETUP]\n1: iiii, 0\n[PROGRAM]\n"

#: (the program's body, the flag byte it copies the read-back into, what it must hold)
CASES = [
    ("L KB 255\nT FY 97\nL FY 97\nT FY 10\n", 10, 0x0F),
    ("L KW 0FFFFh\nT FW 96\nL FW 96\nT FW 10\n", 11, 0x0F),   # FY 96 high, FY 97 low
    ("L KW 0FFFFh\nT FW 97\nL FY 97\nT FY 10\n", 10, 0x0F),   # FY 97 is the high byte
    ("L KW 0FFFFh\nT FW 95\nL FY 96\nT FY 10\n", 10, 0xFF),   # a low byte keeps all
    ("ON F 0.0\nS F 97.7\nA F 97.7\n= F 10.0\nON F 0.0\nS F 97.3\nA F 97.3\n= F 10.1\n"
     "ON F 0.0\n= F 99.6\nA F 99.6\n= F 10.2\n", 10, 0x02),
    ("L KB 255\nT FY 125\nL FY 125\nT FY 10\n", 10, 0x0F),    # counter 14, the last
    ("L KB 255\nT FY 127\nL FY 127\nT FY 10\n", 10, 0xFF),    # no counter's
]


def _program(body: str):
    program, diags = load_program(from_string("<test>", HEADER + body + "BE\n"))
    assert not [d for d in diags if d.is_error], diags
    return program


@pytest.mark.parametrize("body,flag,expected", CASES)
def test_a_read_back_of_a_mapped_counter_byte_is_the_same_compiled_and_interpreted(
    body: str, flag: int, expected: int
) -> None:
    program = _program(body)
    interp = Interpreter(program, firmware=ModelFirmware())
    compiled = compile_program(program)
    runner = ProgramRunner(
        LoadedProgram(compiled.code, compiled.pmap, compiled.entry_points),
        firmware=ModelFirmware(),
    )
    interp.cycle(bytes(16))
    runner.cycle(bytes(16))
    assert interp.state.flags[flag] == expected
    assert bytes(runner.flag(n) for n in range(128)) == bytes(interp.state.flags)
    for n in range(97, 127, 2):
        assert interp.state.flags[n] & 0xF0 == 0, f"FY {n} holds upper bits"


def test_a_bit_write_keeps_the_count_the_host_wrote_into_the_high_byte() -> None:
    """The differential test's shortest disagreement: the host writes 99h to FY 119
    (counter 11's high byte), the program clears F 119.0. The board stores only 09h
    (Pc2Board.io_write; scenario mapped_counter_bytes), so both sides start from it and
    end with 08h: the bit write keeps the host's other count bits and adds no upper ones."""
    program = _program("A I 0.0\n= F 119.0\n")
    interp = Interpreter(program, firmware=ModelFirmware())
    compiled = compile_program(program)
    runner = ProgramRunner(
        LoadedProgram(compiled.code, compiled.pmap, compiled.entry_points),
        firmware=ModelFirmware(),
    )
    stored = 0x99 & flag_keeps(119, map_counters=True)
    interp.state.flags[119] = stored
    runner.write(compiled.pmap.flag(119), stored)
    interp.cycle(bytes(16))
    runner.cycle(bytes(16))
    assert interp.state.flags[119] == runner.flag(119) == 0x08
    assert interp.state.flags == bytearray(runner.flag(n) for n in range(128))
