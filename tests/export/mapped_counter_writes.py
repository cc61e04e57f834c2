"""A program under map_counters that writes the upper four bits of mapped counters'
high bytes (FY 97, 99 .. 125) by =, S, R, T FY and T FW at both alignments, reads them
back in the same cycle and copies them to outputs and flags. On the master those bits
stay 0 whatever is written (platform.master.flag_keeps); the exports' tests run it
beside the reference interpreter, so an export that writes them where the master does
not is seen in the cycle it happens."""

from __future__ import annotations

from asictl.export.check import Cycle
from asictl.il.loader import Program, load_program
from asictl.source import from_string

SOURCE = """\
[OPTIONS]
map_counters: yes

[SETUP]
1: iiii, 0
2: oooo, 0

[PROGRAM]
        AN  C 11            ; 1 while counter 11 (FY 118, FY 119) is 0
        =   F 119.5         ; its high byte's bit 5: stays 0
        =   F 119.1         ; bit 1 holds count bit 9
***
        A   I 1.0
        =   F 119.6
        =   F 20.0          ; a store after one that changes nothing
        S   F 97.7
        S   F 97.2
        R   F 99.4
        CU  C 11
***
        L   KB 1
        L   KB 1
        !=  F
        =   F 123.4         ; the register from a comparison
        =   F 20.1
***
        A   F 119.5
        O   F 119.6
        =   Q 2.0           ; never on: both bits stay 0
***
        A   F 119.1
        =   Q 2.1
***
        A   F 97.7
        =   Q 2.2           ; never on
***
        A   F 97.2
        =   Q 2.3
***
        L   KB 255
        T   FY 125          ; counter 14's high byte: 0Fh
        L   FY 125
        T   FY 14
        L   KW 0FFFFh
        T   FW 98           ; FY 99, a high byte, is the word's low byte
        T   FW 101          ; FY 101, a high byte, is the word's high byte
        L   FW 98
        T   FW 10           ; FF0Fh
        L   FW 101
        T   FW 12           ; 0FFFh
"""

#: I 1.0 (input byte 0, bit 4) off, on, on, off, on: the bit stores run with the
#: register 0 and 1, and counter 11 counts.
RUN = [Cycle(bytes([bits]) + bytes(15), 1) for bits in (0x00, 0x10, 0x10, 0x00, 0x10, 0x10)]


def mapped_counter_writes() -> Program:
    program, diagnostics = load_program(from_string("mapped_counter_writes.asi", SOURCE))
    assert program is not None
    assert not [d for d in diagnostics if d.is_error], diagnostics
    return program
