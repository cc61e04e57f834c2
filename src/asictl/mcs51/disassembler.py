"""The 8051 disassembler: an image back into source that reassembles to the same bytes.

The output is meant to be edited and assembled again, so exactness comes first:
every byte is decoded linearly as code (there is no flow analysis to tell code from
data), the undefined opcode A5h and an instruction cut off by the end of a memory
range become ``DB``, gaps become ``ORG``, and every relative or page-relative target
is written so that the assembler encodes the same byte. Jump and call targets that
start a decoded instruction get ``Lxxxx`` labels.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass

from intelhex import IntelHex

from asictl.mcs51.asm_expr import format_hex
from asictl.mcs51.isa import OPCODES, SFR_BITS, SFRS, OpcodeInfo, Operand

_SFR_NAMES = {address: name for name, address in SFRS.items()}
_BIT_NAMES = {address: name for name, address in SFR_BITS.items()}
_TARGETS = (Operand.REL, Operand.ADDR11, Operand.ADDR16)
_MNEMONIC_WIDTH = 8
_LABEL_WIDTH = 8


@dataclass(frozen=True, slots=True)
class Decoded:
    """One instruction, or one byte of data (``info`` is None) if no instruction fits."""

    address: int
    data: bytes
    info: OpcodeInfo | None
    #: Operand values in source order; a jump target is the absolute address.
    values: tuple[int | None, ...] = ()

    @property
    def target(self) -> int | None:
        """The code address a jump or call goes to."""
        if self.info is None:
            return None
        for kind, value in zip(self.info.operands, self.values, strict=True):
            if kind in _TARGETS:
                return value
        return None


def decode(data: bytes, address: int = 0) -> Iterator[Decoded]:
    """Decode a contiguous run of code starting at ``address``."""
    pos = 0
    while pos < len(data):
        here = address + pos
        info = OPCODES[data[pos]]
        if info is None or pos + info.length > len(data):
            yield Decoded(here, data[pos : pos + 1], None)
            pos += 1
            continue
        raw = data[pos : pos + info.length]
        yield Decoded(here, raw, info, _operand_values(info, raw, here))
        pos += info.length


def _operand_values(info: OpcodeInfo, raw: bytes, address: int) -> tuple[int | None, ...]:
    values: list[int | None] = [None] * len(info.operands)
    pos = 1
    next_pc = (address + info.length) & 0xFFFF
    for index in info.encoding:
        kind = info.operands[index]
        value = int.from_bytes(raw[pos : pos + kind.size], "big")
        pos += kind.size
        if kind is Operand.REL:
            value = (next_pc + value - (0x100 if value & 0x80 else 0)) & 0xFFFF
        elif kind is Operand.ADDR11:
            value = (next_pc & 0xF800) | (info.opcode & 0xE0) << 3 | value
        values[index] = value
    return tuple(values)


def segments_of(image: IntelHex | Mapping[int, int]) -> list[tuple[int, bytes]]:
    """Contiguous runs of an image's bytes, sorted by address."""
    if isinstance(image, IntelHex):
        return [(start, image.tobinstr(start, end - 1)) for start, end in image.segments()]
    runs: list[tuple[int, bytes]] = []
    addresses = sorted(image)
    start = 0
    for i, address in enumerate(addresses):
        if i == len(addresses) - 1 or addresses[i + 1] != address + 1:
            first = addresses[start]
            runs.append((first, bytes(image[a] for a in addresses[start : i + 1])))
            start = i + 1
    return runs


def disassemble(image: IntelHex | Mapping[int, int] | bytes, *, origin: int = 0) -> str:
    """Source text for an image: an IntelHex, an address -> byte map, or bytes at ``origin``."""
    runs = [(origin, bytes(image))] if isinstance(image, bytes | bytearray) else segments_of(image)
    if runs and runs[-1][0] + len(runs[-1][1]) > 0x10000:
        raise ValueError("the image has bytes above FFFFh, outside the 8051 code space")
    decoded = [list(decode(data, start)) for start, data in runs]
    starts = {d.address for run in decoded for d in run if d.info is not None}
    labels = {t for run in decoded for d in run if (t := d.target) is not None and t in starts}
    return "".join(_render(run, labels) for run in decoded if run)


def _render(run: Iterable[Decoded], labels: set[int]) -> str:
    lines: list[str] = []
    for i, item in enumerate(run):
        if i == 0:
            lines.append(
                f"{'':<{_LABEL_WIDTH}}{'ORG':<{_MNEMONIC_WIDTH}}{format_hex(item.address, 4)}"
            )
        label = f"L{item.address:04X}:" if item.address in labels else ""
        lines.append(f"{label:<{_LABEL_WIDTH}}{format_instruction(item, labels)}".rstrip())
    return "\n".join(lines) + "\n"


def format_instruction(item: Decoded, labels: set[int] | frozenset[int] = frozenset()) -> str:
    """One decoded item as assembler source, e.g. ``MOV     A,#05h``."""
    if item.info is None:
        return f"{'DB':<{_MNEMONIC_WIDTH}}{format_hex(item.data[0], 2)}"
    operands = ",".join(
        _format_operand(kind, value, labels)
        for kind, value in zip(item.info.operands, item.values, strict=True)
    )
    return f"{item.info.mnemonic:<{_MNEMONIC_WIDTH}}{operands}"


def _format_operand(kind: Operand, value: int | None, labels: set[int] | frozenset[int]) -> str:
    if value is None:
        return kind.value
    match kind:
        case Operand.IMM:
            return "#" + format_hex(value, 2)
        case Operand.IMM16:
            return "#" + format_hex(value, 4)
        case Operand.DIRECT:
            return _SFR_NAMES.get(value) or format_hex(value, 2)
        case Operand.BIT:
            return _format_bit(value)
        case Operand.NBIT:
            return "/" + _format_bit(value)
        case _:  # a code address
            return f"L{value:04X}" if value in labels else format_hex(value, 4)


def _format_bit(bit: int) -> str:
    """A bit address by name (CY), as SFR.n (P1.0) or as byte.n (24h.1)."""
    if bit in _BIT_NAMES:
        return _BIT_NAMES[bit]
    byte = bit & 0xF8 if bit >= 0x80 else 0x20 + bit // 8
    return f"{_SFR_NAMES.get(byte) or format_hex(byte, 2)}.{bit % 8}"
