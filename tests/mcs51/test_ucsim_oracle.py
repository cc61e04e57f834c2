"""Differential tests: the emulator against ucsim's s51 on the same programs and states.

Each case sets up internal RAM, SFRs, port pins, XDATA and code in both simulators,
executes a number of instructions, and compares PC, all 256 bytes of internal RAM, the
SFRs, the XDATA bytes the program could have touched, and the machine cycles elapsed.
Many cases share one s51 process (its start-up dominates otherwise): the commands go in
a command file, and each case's output ends with a marker printed by ``expression``.

States are random but keep clear of peripherals neither simulator is compared on:
IE, TCON, SCON and PCON stay 0 and no operand addresses them, so no timer runs and no
interrupt is taken.
"""

from __future__ import annotations

import os
import random
import re
import subprocess
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from asictl.mcs51.emulator import Emulator
from asictl.mcs51.isa import OPCODES, Operand

# Direct addresses a random operand may name: RAM and SFRs that are plain storage in both
# simulators. TMOD/THx/TLx are included because the timers stay stopped.
SFRS = (0x80, 0x81, 0x82, 0x83, 0x89, 0x8A, 0x8B, 0x8C, 0x8D, 0x90, 0xA0, 0xB0, 0xD0, 0xE0, 0xF0)
SAFE_DIRECT = tuple(range(0x80)) + SFRS
# Bit addresses: the bit-addressable RAM and the bits of ports, PSW, ACC and B.
SAFE_BITS = tuple(range(0x80)) + tuple(
    base + n for base in (0x80, 0x90, 0xA0, 0xB0, 0xD0, 0xE0, 0xF0) for n in range(8)
)
# s51 0.6.4 switches register banks on byte writes to PSW but not on bit writes to RS0/RS1
# (SETB RS0 leaves R0-R7 in the old bank); sequences keep clear of that s51 bug, which
# test_edge_cases pins down.
SEQUENCE_BITS = tuple(b for b in SAFE_BITS if b not in (0xD3, 0xD4))
# SFRs compared after each case: the randomised ones plus those that must stay put.
COMPARED_SFRS = (*SFRS, 0x87, 0x88, 0x98, 0xA8, 0xB8)
PORT_SFRS = (0x80, 0x90, 0xA0, 0xB0)
# Bits left out of the comparison, each for a documented reason (docs/emulator.md):
# - TCON.IE0/IE1: s51 sets them when random data pulls INT0/INT1 (P3.2, P3.3) low; the
#   emulator has no interrupt logic, and with IE = 0 the flags change nothing else.
# - PSW.P: s51 keeps a value written to PSW bit 0 until ACC next changes; the chip
#   recomputes parity every cycle, and so does the emulator. ACC itself is compared.
SFR_COMPARED_BITS = {0x88: 0xFF ^ 0x0A, 0xD0: 0xFE}
CONTROL_TRANSFER = {"AJMP", "LJMP", "SJMP", "JMP", "ACALL", "LCALL", "RET", "RETI"}
MARKER = 740_000_000
SJMP_SELF = b"\x80\xfe"


def parity(value: int) -> int:
    return bin(value).count("1") & 1


@dataclass
class Case:
    """One program and starting state, run for ``steps`` instructions."""

    label: str
    pc: int
    program: bytes
    iram: bytes
    sfr: dict[int, int]
    pins: bytes = b"\xff\xff\xff\xff"
    xram: dict[int, int] = field(default_factory=dict)
    code: dict[int, int] = field(default_factory=dict)  # extra code bytes (MOVC data)
    # Two steps by default: the instruction under test, then the SJMP $ after it (or
    # whatever it jumped to), so the block translator runs it: the emulator interprets
    # a one-instruction run, and a run whose budget is smaller than the block.
    steps: int = 2


@dataclass
class Outcome:
    pc: int
    cycles: int
    iram: bytes
    sfr: dict[int, int]
    xram: dict[int, int]

    def differences(self, other: Outcome) -> list[str]:
        out = []
        if self.pc != other.pc:
            out.append(f"PC {self.pc:04X} != {other.pc:04X}")
        if self.cycles != other.cycles:
            out.append(f"cycles {self.cycles} != {other.cycles}")
        out += [
            f"iram[{i:02X}] {x:02X} != {y:02X}"
            for i, (x, y) in enumerate(zip(self.iram, other.iram, strict=True))
            if x != y
        ]
        out += [
            f"sfr[{k:02X}] {self.sfr[k]:02X} != {other.sfr[k]:02X}"
            for k in COMPARED_SFRS
            if (self.sfr[k] ^ other.sfr[k]) & SFR_COMPARED_BITS.get(k, 0xFF)
        ]
        out += [
            f"xram[{k:04X}] {self.xram[k]:02X} != {other.xram[k]:02X}"
            for k in sorted(self.xram)
            if self.xram[k] != other.xram[k]
        ]
        return out


def changed_addresses(before: bytes, after: bytearray) -> set[int]:
    """Addresses whose bytes differ, found a page at a time (64 KB per case adds up)."""
    out: set[int] = set()
    for page in range(0, 0x10000, 0x100):
        if before[page : page + 0x100] != after[page : page + 0x100]:
            out.update(i for i in range(page, page + 0x100) if before[i] != after[i])
    return out


def run_ours(emu: Emulator, case: Case) -> tuple[Outcome, list[int]]:
    """Run a case on a reused emulator; also returns the XDATA addresses to compare."""
    emu.reset()
    emu.code[:] = bytes(0x10000)
    emu.code.load(case.pc, case.program)
    for address, value in case.code.items():
        emu.code[address] = value
    ram = emu.xdata.ram
    ram[:] = bytes(0x10000)
    for address, value in case.xram.items():
        ram[address] = value
    before = bytes(ram)
    emu.iram[:] = case.iram
    for address, value in case.sfr.items():
        emu.sfr[address] = value
    emu.pins[:] = case.pins
    emu.pc = case.pc
    emu.run(max_instructions=case.steps)
    watch = sorted(changed_addresses(before, ram) | case.xram.keys())
    outcome = Outcome(
        pc=emu.pc,
        cycles=emu.cycles,
        iram=bytes(emu.iram),
        sfr={k: emu.psw if k == 0xD0 else emu.sfr[k] for k in COMPARED_SFRS},
        xram={k: ram[k] for k in watch},
    )
    return outcome, watch


def _hexlist(values) -> str:
    return " ".join(f"0x{v:02x}" for v in values)


def s51_script(case: Case, watch: list[int], index: int) -> list[str]:
    cmds = [
        "reset",
        "fill rom 0 0xffff 0",
        "fill xram 0 0xffff 0",
        f"set memory rom 0x{case.pc:04x} {_hexlist(case.program)}",
        *(f"set memory rom 0x{a:04x} 0x{v:02x}" for a, v in case.code.items()),
        *(f"set memory xram 0x{a:04x} 0x{v:02x}" for a, v in case.xram.items()),
        f"set memory iram 0 {_hexlist(case.iram)}",
        *(f"set memory sfr 0x{a:02x} 0x{v:02x}" for a, v in case.sfr.items()),
        *(f"set hardware port[{n}] 0x{v:02x}" for n, v in enumerate(case.pins)),
        f"pc 0x{case.pc:04x}",
        f"step {case.steps}",
        # Pins back to high, so the SFR dump shows the port latches.
        *(f"set hardware port[{n}] 0xff" for n in range(4)),
        "state",
        "dump /h iram 0 0xff 16",
        "dump /h sfr 0x80 0xff 16",
        *(f"dump /h xram 0x{a:04x} 0x{a:04x}" for a in watch),
        f"expression {MARKER + index}",
    ]
    return cmds


# A dump row: address, the bytes, then an ASCII column (which may itself look like hex).
_ROW = re.compile(r"^0x[0-9a-f]+ [0-9a-f]{2} .*$", re.M)


def parse_outcome(text: str, watch: list[int]) -> Outcome:
    pc = int(re.search(r"CPU state= \S+ PC= 0x([0-9a-f]+)", text).group(1), 16)
    clocks = int(re.search(r"since last reset= [\d.]+ sec \((\d+) clks\)", text).group(1))
    rows = [m.group().split()[1:] for m in _ROW.finditer(text)]
    iram = bytes.fromhex("".join("".join(row[:16]) for row in rows[:16]))
    sfr_bytes = bytes.fromhex("".join("".join(row[:16]) for row in rows[16:24]))
    xram = {address: int(row[0], 16) for address, row in zip(watch, rows[24:], strict=True)}
    assert len(iram) == 256 and len(sfr_bytes) == 128, text
    assert clocks % 12 == 0, text
    return Outcome(pc, clocks // 12, iram, {k: sfr_bytes[k - 0x80] for k in COMPARED_SFRS}, xram)


def run_s51_batch(s51: str, cases: list[Case], watches: list[list[int]]) -> list[Outcome]:
    """Run cases in one s51 process.

    The commands go in a file run with ``-C``: s51 echoes commands read from a pipe
    asynchronously, interleaved with their output, but those from a file in order.
    """
    # s51 would otherwise stop when SP wraps from FFh; the chip just wraps.
    script = ["set error stack off"]
    for index, (case, watch) in enumerate(zip(cases, watches, strict=True)):
        script += s51_script(case, watch, index)
    script.append("quit")
    with tempfile.TemporaryDirectory() as directory:
        commands = Path(directory, "cases.cmd")
        commands.write_text("\n".join(script) + "\n")
        done = subprocess.run(
            [s51, "-q", "-t", "8052", "-C", str(commands)],
            stdin=subprocess.DEVNULL,
            capture_output=True,
            text=True,
            timeout=300,
            check=False,
        )
    chunks = re.split(rf"^{MARKER // 10**6}\d{{6}}$", done.stdout, flags=re.M)
    assert len(chunks) == len(cases) + 1, done.stdout[-2000:] + done.stderr
    return [parse_outcome(chunk, watch) for chunk, watch in zip(chunks, watches, strict=False)]


def run_s51(s51: str, cases: list[Case], watches: list[list[int]]) -> list[Outcome]:
    """Spread the cases over one s51 process per CPU."""
    jobs = max(1, min(os.cpu_count() or 1, len(cases) // 100))
    size = -(-len(cases) // jobs)
    parts = [(cases[i : i + size], watches[i : i + size]) for i in range(0, len(cases), size)]
    with ThreadPoolExecutor(jobs) as pool:
        results = pool.map(lambda part: run_s51_batch(s51, *part), parts)
    return [outcome for batch in results for outcome in batch]


def compare(s51: str, cases: list[Case]) -> None:
    """Each case on s51, on the emulator's interpreter and on its block translator."""
    translated, interpreted = Emulator(), Emulator(translate=False)
    ours, watches = zip(*(run_ours(translated, case) for case in cases), strict=True)
    theirs = run_s51(s51, cases, list(watches))
    failures = []
    for case, mine, reference in zip(cases, ours, theirs, strict=True):
        diff = mine.differences(reference)
        if diff:
            where = f"{case.label} @{case.pc:04X} {case.program.hex()}"
            failures.append(f"{where}: ours != s51: {diff}")
        diff = mine.differences(run_ours(interpreted, case)[0])
        if diff:
            failures.append(f"{case.label} @{case.pc:04X}: blocks != interpreter: {diff}")
    assert not failures, f"{len(failures)} of {len(cases)} cases differ:\n" + "\n".join(
        failures[:40]
    )


# -- random states --------------------------------------------------------------------

INTERESTING = (0x00, 0x01, 0x0F, 0x10, 0x7F, 0x80, 0x99, 0xF0, 0xFF)


def random_byte(rng: random.Random) -> int:
    return rng.choice(INTERESTING) if rng.random() < 0.25 else rng.randrange(256)


def random_state(rng: random.Random) -> tuple[bytes, dict[int, int], bytes]:
    iram = bytes(random_byte(rng) for _ in range(256))
    sfr = {address: random_byte(rng) for address in SFRS}
    sfr[0xD0] = sfr[0xD0] & 0xFE | parity(sfr[0xE0])
    # P2's pins stay high: s51 takes the high address byte of MOVX @Ri from P2's pins,
    # the chip (and the emulator) from the P2 latch.
    pins = bytes(0xFF if port == 2 else rng.choice((0xFF, rng.randrange(256))) for port in range(4))
    return iram, sfr, pins


def operand_bytes(rng: random.Random, opcode: int, bits: tuple[int, ...] = SAFE_BITS) -> bytes:
    info = OPCODES[opcode]
    out = []
    for index in info.encoding:
        kind = info.operands[index]
        if kind is Operand.DIRECT:
            out.append(rng.choice(SAFE_DIRECT))
        elif kind in (Operand.BIT, Operand.NBIT):
            out.append(rng.choice(bits))
        else:
            out += [random_byte(rng) for _ in range(kind.size)]
    return bytes([opcode, *out])


def single_instruction_case(rng: random.Random, opcode: int) -> Case:
    iram, sfr, pins = random_state(rng)
    pc = rng.randrange(0x0100, 0xF000)
    program = operand_bytes(rng, opcode) + SJMP_SELF
    bank = sfr[0xD0] & 0x18
    # XDATA a MOVX could read, and code a MOVC could read, get random contents.
    dptr = sfr[0x83] << 8 | sfr[0x82]
    xram = {dptr: rng.randrange(256)}
    for r in (0, 1):
        xram[sfr[0xA0] << 8 | iram[bank + r]] = rng.randrange(256)
    code = {}
    a = sfr[0xE0]
    for target in ((a + dptr) & 0xFFFF, (a + pc + 1) & 0xFFFF):
        if not pc <= target < pc + len(program):
            code[target] = rng.choice([v for v in range(256) if v != 0xA5])
    label = f"{OPCODES[opcode].mnemonic} ({opcode:02X}h)"
    return Case(label, pc, program, iram, sfr, pins, xram, code)


@pytest.mark.parametrize("states", [4, pytest.param(24, marks=pytest.mark.slow)])
def test_every_opcode_from_random_states(s51_path: str, states: int) -> None:
    rng = random.Random(8051)
    cases = [
        single_instruction_case(rng, opcode)
        for opcode, info in enumerate(OPCODES)
        if info is not None
        for _ in range(states)
    ]
    compare(s51_path, cases)


def test_da_for_every_accumulator_and_flag_combination(s51_path: str) -> None:
    """DA A is the instruction emulators most often get wrong; check all 1024 inputs."""
    rng = random.Random(1)
    cases = []
    for a in range(256):
        for flags in (0x00, 0x40, 0x80, 0xC0):
            iram, sfr, _ = random_state(rng)
            sfr[0xE0] = a
            sfr[0xD0] = flags | parity(a)
            program = b"\xd4" + SJMP_SELF
            cases.append(Case(f"DA A={a:02X} flags={flags:02X}", 0x0200, program, iram, sfr))
    compare(s51_path, cases)


# -- instruction sequences --------------------------------------------------------------

SEQUENCE_OPCODES = [
    info.opcode for info in OPCODES if info is not None and info.mnemonic not in CONTROL_TRANSFER
]


@st.composite
def programs(draw) -> Case:
    """A straight-line program whose branches only ever skip forward, ending in SJMP $.

    Forward-only branches guarantee termination; they may land on any later instruction
    or on the final SJMP.
    """
    rng = random.Random(draw(st.integers(0, 2**32 - 1)))
    opcodes = draw(st.lists(st.sampled_from(SEQUENCE_OPCODES), min_size=1, max_size=24))
    instructions = [bytearray(operand_bytes(rng, opcode, SEQUENCE_BITS)) for opcode in opcodes]
    base = draw(st.sampled_from((0x0100, 0x1234, 0x7F80)))
    starts = []
    address = base
    for ins in instructions:
        starts.append(address)
        address += len(ins)
    end = address
    for i, ins in enumerate(instructions):
        info = OPCODES[ins[0]]
        if Operand.REL in info.operands:
            target = draw(st.sampled_from([*starts[i + 1 :], end]))
            ins[-1] = (target - (starts[i] + len(ins))) & 0xFF
    program = b"".join(bytes(ins) for ins in instructions) + b"\x80\xfe"
    iram, sfr, pins = random_state(rng)
    sfr[0x81] = draw(st.sampled_from((0x07, 0x2F, 0x7E, 0xFE, sfr[0x81])))
    bank = sfr[0xD0] & 0x18
    dptr = sfr[0x83] << 8 | sfr[0x82]
    xram = {dptr: rng.randrange(256), sfr[0xA0] << 8 | iram[bank]: rng.randrange(256)}
    # More steps than instructions: both simulators end up looping on the final SJMP $.
    return Case("sequence", base, program, iram, sfr, pins, xram, steps=len(instructions) + 3)


@settings(
    max_examples=60,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(st.lists(programs(), min_size=8, max_size=8))
def test_random_sequences_match_s51(s51_path: str, cases: list[Case]) -> None:
    compare(s51_path, cases)


@pytest.mark.parametrize("pins", [0x0F, 0xA5])
def test_port_reads_see_pins_and_read_modify_write_sees_latch(s51_path: str, pins: int) -> None:
    """MOV reads the pins; ANL/ORL/XRL/INC/DEC/CPL/JBC/SETB/CLR/MOV bit,C read the latch."""
    rng = random.Random(pins)
    opcodes = [0xE5, 0x85, 0xC5, 0x42, 0x52, 0x62, 0x43, 0x53, 0x63, 0x05, 0x15, 0xD5,
               0xA2, 0x20, 0x30, 0x10, 0xB2, 0xC2, 0xD2, 0x92, 0x72, 0x82, 0xA0, 0xB0,
               0xC0, 0xB5]  # fmt: skip
    cases = []
    for opcode in opcodes:
        for port in PORT_SFRS:
            case = single_instruction_case(rng, opcode)
            program = bytearray(case.program)
            info = OPCODES[opcode]
            for position, index in enumerate(info.encoding, start=1):
                if info.operands[index] is Operand.DIRECT:
                    program[position] = port
                elif info.operands[index] in (Operand.BIT, Operand.NBIT):
                    program[position] = port + rng.randrange(8)
            case.program = bytes(program)
            case.pins = bytes(pins if p == port else 0xFF for p in PORT_SFRS)
            cases.append(case)
    compare(s51_path, cases)


def edge(label: str, address: int, program: bytes, overrides: dict[int, int], marks=()):
    """A corner case random states rarely reach: a program at an address, some SFRs set."""
    return pytest.param(label, address, program, overrides, id=label, marks=marks)


EDGE_CASES = [
    edge("PUSH SP", 0x0100, b"\xc0\x81", {}),
    edge("POP SP", 0x0100, b"\xd0\x81", {}),
    edge("PUSH ACC", 0x0100, b"\xc0\xe0", {}),
    edge("POP ACC", 0x0100, b"\xd0\xe0", {}),
    edge("POP PSW", 0x0100, b"\xd0\xd0", {}),
    edge("XCH A,ACC", 0x0100, b"\xc5\xe0", {}),
    edge("MOV PSW,#18h then R0", 0x0100, b"\x75\xd0\x18\xe8", {}),
    edge(
        "SETB RS0 then R1",
        0x0100,
        b"\xd2\xd3\xe9",
        {0xD0: 0x00},
        # The chip switches banks however RS0 is written (datasheet: PSW.3/4 select
        # the bank); the emulator does, as test_emulator checks. s51 does not.
        marks=pytest.mark.xfail(
            strict=True, reason="s51 0.6.4 ignores bank switches by bit writes to RS0/RS1"
        ),
    ),
    edge("DIV by zero", 0x0100, b"\x84", {0xF0: 0x00}),
    edge("MUL FFh*FFh", 0x0100, b"\xa4", {0xE0: 0xFF, 0xF0: 0xFF}),
    edge("INC DPTR wraps", 0x0100, b"\xa3", {0x82: 0xFF, 0x83: 0xFF}),
    edge("RET with SP=00h", 0x0100, b"\x22", {0x81: 0x00}),
    edge("RET with SP=01h", 0x0100, b"\x22", {0x81: 0x01}),
    edge("LCALL with SP=FEh", 0x0100, b"\x12\x20\x00", {0x81: 0xFE}),
    edge("ACALL from the end of a 2K page", 0x07FE, b"\x11\x23", {}),
    edge("AJMP from the end of a 2K page", 0x0FFE, b"\xe1\x55", {}),
    edge("SJMP back across 0000h", 0x0002, b"\x80\xf0", {}),
    edge("MOVC A,@A+DPTR wraps", 0x0100, b"\x93", {0xE0: 0x20, 0x82: 0xF0, 0x83: 0xFF}),
    edge("MOVC A,@A+PC", 0x0100, b"\x83", {0xE0: 0x05}),
    edge("JMP @A+DPTR wraps", 0x0100, b"\x73", {0xE0: 0x10, 0x82: 0xF8, 0x83: 0xFF}),
    edge("DJNZ ACC", 0x0100, b"\xd5\xe0\x10", {0xE0: 0x01}),
    edge("CJNE A,ACC", 0x0100, b"\xb5\xe0\x10", {}),
    edge("JBC CY", 0x0100, b"\x10\xd7\x10", {0xD0: 0x80}),
    edge("MOV C,P", 0x0100, b"\xa2\xd0", {0xE0: 0x01}),
    edge("ANL PSW,#0", 0x0100, b"\x53\xd0\x00", {0xD0: 0xFF}),
    edge("INC PSW", 0x0100, b"\x05\xd0", {0xD0: 0x17}),
    edge("MOVX @R1,A with P2 paging", 0x0100, b"\xf3", {0xA0: 0x5A}),
    edge("DA after ADD 99h+99h", 0x0100, b"\x24\x99\xd4", {0xE0: 0x99, 0xD0: 0x00}),
]


@pytest.mark.parametrize("label, address, program, overrides", EDGE_CASES)
def test_edge_cases(s51_path: str, label: str, address: int, program: bytes, overrides) -> None:
    rng = random.Random(label)
    cases = []
    for _ in range(16):
        case = single_instruction_case(rng, 0x00)
        case.label, case.pc, case.program = label, address, program + SJMP_SELF
        case.sfr.update(overrides)
        case.sfr[0xD0] = case.sfr[0xD0] & 0xFE | parity(case.sfr[0xE0])
        case.steps = len(program)  # at least one step per instruction
        cases.append(case)
    compare(s51_path, cases)
