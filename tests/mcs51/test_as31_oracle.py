"""Differential test: our assembler and as31 must produce byte-identical images.

A corpus is generated covering every opcode with boundary operands (0, 7Fh, 80h, FFh,
relative jumps at -128 and +127, AJMP/ACALL at both ends of a 2 KB page, 16-bit 0
and FFFFh), every predefined SFR and bit name, every bit-addressable byte.bit form
and the as31 directives, number forms and expressions. It is written in the syntax
both assemblers share (as31's), assembled by each, and the images compared.
"""

from __future__ import annotations

import itertools
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from intelhex import IntelHex

from asictl.diagnostics import DiagnosticError
from asictl.mcs51.assembler import assemble_text
from asictl.mcs51.isa import OPCODES, SFR_BITS, SFRS, OpcodeInfo, Operand

BYTE_VALUES = ("0", "7Fh", "80h", "0FFh")
IMMEDIATES = ("#0", "#7Fh", "#80h", "#0FFh", "#-1", "#-127")
IMMEDIATES16 = ("#0", "#0FFFFh", "#1234h", "#-1")
ADDRESSES16 = ("0", "0FFFFh", "1234h")
REL_OFFSETS = (-128, 0, 127)
CORPUS_START = 0x1000  # far enough from 0 that backward jumps stay in the address space


class Corpus:
    """Lines of as31 source with the location counter tracked as they are added."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.pc = 0

    def org(self, address: int) -> None:
        assert address >= self.pc, "corpus sections must not overlap"
        self.lines.append(f"\t.org {address:#x}")
        self.pc = address

    def add(self, text: str, length: int) -> None:
        self.lines.append(f"\t{text}")
        self.pc += length

    def text(self) -> str:
        return "\n".join(self.lines) + "\n"


def operand_choices(info: OpcodeInfo, kind: Operand) -> tuple[str, ...]:
    match kind:
        case Operand.DIRECT | Operand.BIT:
            return BYTE_VALUES
        case Operand.NBIT:
            return tuple(f"/{v}" for v in BYTE_VALUES)
        case Operand.IMM:
            return IMMEDIATES
        case Operand.IMM16:
            return IMMEDIATES16
        case Operand.ADDR16:
            return ADDRESSES16
        case Operand.REL:
            return tuple(f"*+{info.length}{offset:+d}" for offset in REL_OFFSETS)
        case Operand.AT_A_DPTR:
            return ("@a+dptr", "@A + DPTR", "@dptr+a")
        case Operand.AT_A_PC:
            return ("@a+pc", "@pc + a")
        case _:
            return (kind.value.lower(),)


def instruction_lines(info: OpcodeInfo) -> Iterator[str]:
    choices = [operand_choices(info, kind) for kind in info.operands]
    for combo in itertools.product(*choices):
        yield f"{info.mnemonic.lower()} {', '.join(combo)}".rstrip()


def build_corpus() -> str:
    corpus = Corpus()
    corpus.org(CORPUS_START)
    for info in OPCODES:
        if info is None or info.mnemonic in ("AJMP", "ACALL"):
            continue
        for line in instruction_lines(info):
            corpus.add(line, info.length)
    # AJMP/ACALL: each opcode (page bits 0..7), targets at both ends of the page
    for base in (0x3000, 0x3800):
        corpus.org(base + 0x400)
        for bits in range(8):
            for mnemonic in ("ajmp", "acall"):
                for low in (0x00, 0xFF):
                    corpus.add(f"{mnemonic} {base | bits << 8 | low:#06x}", 2)
    # the successor's address decides the page: at 47FEh it is 4800h, at 4FFEh it is 5000h
    corpus.org(0x47FE)
    corpus.add("ajmp 4800h", 2)
    corpus.add("acall 4FFFh", 2)
    corpus.org(0x4FFC)
    corpus.add("ajmp 4800h", 2)
    corpus.add("acall 57FFh", 2)
    corpus.org(0x5000)
    for name in SFRS:
        corpus.add(f"mov a, {name}", 2)
        corpus.add(f"mov {name.lower()}, #1", 3)
    for name in SFR_BITS:
        corpus.add(f"setb {name}", 2)
        corpus.add(f"jb {name.lower()}, *", 3)
    for byte in [*range(0x20, 0x30), *(v for v in SFRS.values() if v % 8 == 0)]:
        for bit in range(8):
            corpus.add(f"clr {byte:#04x}.{bit}", 2)
    for name, value in SFRS.items():
        if value % 8 == 0:
            corpus.add(f"cpl {name}.7", 2)
            corpus.add(f"anl c, /{name.lower()}.0", 2)
    # from here on nothing is placed by .org, so the location counter is not tracked
    corpus.lines += [
        "\t.equ sym, 21h",
        "\t.flag flg, sym.5",
        "\t.flag acc7, ACC.7",
        "\tsetb flg",
        "\tmov c, acc7",
        "\tanl c, !flg",
        "\tmov a, #sym",
        "\tmov sym, a",
    ]
    numbers = (
        "0x1F",
        "0X1f",
        "0b1010",
        "1010b",
        "17o",
        "19d",
        "010",
        "0ffh",
        "0FFH",
        "'a'",
        "'\\n'",
        "'\\0'",
        "'\\t'",
        "255",
    )
    for number in numbers:
        corpus.add(f"mov a, #{number}", 2)
    expressions = (
        "2+3*4",
        "(2+3)*4",
        "100/7",
        "100%7",
        "-3",
        "--3",
        "7-2-1",
        "0f0h&3ch",
        "0f0h|0fh",
        "1<<3",
        "80h>>3",
        "1<<2&3",
        "6&3<<1",
        "(2+3)&1",
        "-(1+2)",
        "12/2/3",
        "-2*-3",
        "2&3|4",
        "(2|4)&1",
    )
    for expression in expressions:
        corpus.add(f"mov a, #{expression}", 2)
    corpus.lines += [
        "label1:\tmov dptr, #label2",
        "label2:\t.byte 1, 2, \"str\\n\\t\", 'c', label2 & 0ffh",
        "\t.word label1, 0xBEEF, -1",
        "\t.db 7fh",
        "\t.dw 1",
        "\t.skip 3",
        "\t.BYTE 3",
        "\t.end",
    ]
    return corpus.text()


def as31_image(as31: str, source: str, directory: Path) -> dict[int, int]:
    path = directory / "corpus.asm"
    path.write_text(source)
    result = subprocess.run([as31, "-Fhex", str(path)], capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stdout + result.stderr
    image = IntelHex(str(directory / "corpus.hex"))
    return {address: image[address] for address in image.addresses()}


def describe_difference(ours: dict[int, int], theirs: dict[int, int], source: str) -> str:
    assembly = assemble_text(source)
    for address in sorted(set(ours) | set(theirs)):
        if ours.get(address) != theirs.get(address):
            entry = assembly.origin(address)
            where = f"{entry.span.line}: {entry.text.strip()}" if entry else "?"
            return (
                f"first difference at {address:04X}h: ours {ours.get(address)}, "
                f"as31 {theirs.get(address)} (line {where})"
            )
    return "identical"


@pytest.fixture(scope="module")
def corpus() -> str:
    return build_corpus()


def test_corpus_covers_every_opcode(corpus):
    opcodes = {entry.data[0] for entry in assemble_text(corpus).listing if entry.cycles is not None}
    assert opcodes == {info.opcode for info in OPCODES if info is not None}


def test_as31_and_asictl_agree_on_the_corpus(as31_path, corpus, tmp_path):
    ours = assemble_text(corpus).byte_map()
    theirs = as31_image(as31_path, corpus, tmp_path)
    assert len(ours) > 3000
    assert ours == theirs, describe_difference(ours, theirs, corpus)


@pytest.mark.parametrize(
    ("line", "code"),
    [
        ("\tsjmp *+2+128", "E505"),  # relative jump one byte too far
        ("\tsjmp *+2-129", "E505"),
        ("\tajmp 800h", "E506"),  # other 2 KB page
        ("\tmov a, #256", "E504"),
        ("\tsetb 30h.0", "E509"),  # byte not bit-addressable
        ("\tljmp undefined_symbol", "E507"),
        ("x:\nx:", "E508"),
    ],
)
def test_both_reject(as31_path, tmp_path, line, code):
    source = f"\t.org 100h\n{line}\n"
    path = tmp_path / "bad.asm"
    path.write_text(source)
    result = subprocess.run([as31_path, str(path)], capture_output=True, text=True, check=False)
    assert result.returncode != 0
    with pytest.raises(DiagnosticError) as info:
        assemble_text(source)
    assert [d.code for d in info.value.diagnostics] == [code]
