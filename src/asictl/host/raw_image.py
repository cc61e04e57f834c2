"""Raw images: a master's EEPROM byte for byte, whatever program it holds (docs/host.md
"Raw images").

asictl's program image format (docs/image-format.md) is its own design; the programs on
real masters were loaded with the vendor's tools. Commands 52/53 (and the gateway's
functions 66/67) move EEPROM blocks whatever they hold, so a backup, a restore and a
comparison need no knowledge of the format: this module is that, and nothing more.

A raw image is the EEPROM from address 0 up to its last non-blank 16-byte line (the rest
is blank, FFh): the same bytes whichever way the master is reached and however large its
transport's blocks, so two backups of one program are the same file. On disk it is an
Intel HEX file with every address from 0 to its end (a blank run inside is written out),
read back strictly: a record outside the EEPROM, a gap or an overlap is refused with its
line, since any of them would leave bytes of the master undefined.
"""

from __future__ import annotations

import hashlib
import io
from collections.abc import Callable
from dataclasses import dataclass

from intelhex import IntelHex

from asictl.codes import ImageCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Severity, Span
from asictl.host.transfer import Transport, head_size
from asictl.host.transports.jobs import JobError, JobStatus
from asictl.image.eeprom import MAGIC
from asictl.platform.master import EEPROM_SIZE
from asictl.source import SourceText

#: An erased EEPROM byte.
BLANK = 0xFF
#: Bytes per HEX record, and the steps in which the used part of the EEPROM is measured.
LINE = 16

Progress = Callable[[int], None]


def is_asictl_image(head: bytes) -> bool:
    """Whether the EEPROM starts with asictl's magic (its own format, docs/image-format.md)."""
    return head[: len(MAGIC)] == MAGIC


def is_blank(data: bytes) -> bool:
    return not data.strip(bytes([BLANK]))


def _unmade(head: bytes) -> bool:
    """The magic zeroed: where asictl's own download starts, and what it leaves when it
    is interrupted (docs/host.md)."""
    return head[: len(MAGIC)] == bytes(len(MAGIC))


def holds_raw_program(head: bytes) -> bool:
    """Whether an EEPROM starting with ``head`` holds a program that is not asictl's:
    neither asictl's image, nor blank, nor an interrupted asictl download."""
    return not (is_asictl_image(head) or is_blank(head) or _unmade(head))


def foreign_eeprom(transport: Transport, head: bytes) -> str:
    """What the EEPROM holds when it does not start with asictl's image (``head``: its
    first bytes), for ``status``: nothing, an interrupted raw download, or a program in
    another format, which asictl backs up and compares but does not read."""
    if is_blank(head):
        if is_blank(transport.read_eeprom(len(head), transport.block_size)):
            return "no program image"
        return ("no program: the EEPROM starts blank but holds bytes further on (an "
                "interrupted raw download: 'asictl download FILE.hex --raw' again repairs it)")
    if _unmade(head):
        return "no program image"
    return (f"a program not in asictl's format (it starts with {head[:4].hex(' ')}): a raw "
            "image, which asictl's emulated board does not run; 'asictl upload -o FILE.hex' "
            "backs it up byte for byte")


def used(eeprom: bytes) -> bytes:
    """The EEPROM up to its last non-blank line: what a backup keeps."""
    end = len(eeprom.rstrip(bytes([BLANK])))
    return eeprom[: min(len(eeprom), -(-end // LINE) * LINE)]


def identity(image: bytes) -> str:
    """A raw image's identity, as asictl's images have theirs: ``raw-`` and its SHA-256."""
    return "raw-" + hashlib.sha256(image).hexdigest()


def padded(image: bytes) -> bytes:
    """The whole EEPROM a raw image stands for: the image, then blank."""
    return image + bytes([BLANK]) * (EEPROM_SIZE - len(image))


def read_eeprom(transport: Transport, progress: Progress | None = None) -> bytes:
    """The whole EEPROM, block by block (53, or function 67 through a gateway)."""
    advance = progress or (lambda n: None)
    step = transport.block_size
    out = bytearray()
    for address in range(0, EEPROM_SIZE, step):
        out += transport.read_eeprom(address, min(step, EEPROM_SIZE - address))
        advance(1)
    return bytes(out)


def steps(transport: Transport) -> int:
    """Blocks of the whole EEPROM: the progress steps of a raw upload (and, twice, of a
    raw download: written, then read back)."""
    return -(-EEPROM_SIZE // transport.block_size)


def download_raw(transport: Transport, image: bytes, progress: Progress | None = None) -> None:
    """Write ``image`` (padded blank to the whole EEPROM) and compare it read back.

    The EEPROM's head (what ``status`` reads first: one PC2 block, a gateway's first
    blocks) is blanked first and written last, as asictl's own download keeps its header
    for last: until the end, the EEPROM starts blank, which ``status`` reports
    as an interrupted download, and a master does not find half a program there. A
    second download of the same image repairs any interruption.
    """
    data = padded(image)
    step = transport.block_size
    advance = progress or (lambda n: None)
    first = -(-head_size(transport) // step) * step  # what status reads first
    transport.write_eeprom(0, bytes([BLANK]) * first)
    for address in range(first, EEPROM_SIZE, step):
        transport.write_eeprom(address, data[address : address + step])
        advance(1)
    transport.write_eeprom(0, data[:first])
    advance(first // step)
    stored = read_eeprom(transport, progress)
    wrong = first_difference(stored, data)
    if wrong is not None:
        raise JobError(
            JobStatus.EEPROM_ERROR,
            f"the EEPROM does not hold what was written (first difference at {wrong:04X}h); "
            "download the image again",
        )


def first_difference(a: bytes, b: bytes) -> int | None:
    """The first address where two images differ (a shorter one reads blank beyond)."""
    a, b = padded(a), padded(b)
    return next((i for i, (x, y) in enumerate(zip(a, b, strict=True)) if x != y), None)


@dataclass(frozen=True)
class Comparison:
    """Two raw images byte for byte (each padded blank to the whole EEPROM)."""

    #: the first differing addresses (at most ``SHOWN``)
    addresses: list[int]
    #: how many bytes differ in all
    count: int

    SHOWN = 8

    @classmethod
    def of(cls, a: bytes, b: bytes) -> Comparison:
        differing = [i for i, (x, y) in enumerate(zip(padded(a), padded(b), strict=True))
                     if x != y]
        return cls(differing[: cls.SHOWN], len(differing))

    @property
    def identical(self) -> bool:
        return self.count == 0

    def describe(self) -> str:
        where = ", ".join(f"{a:04X}h" for a in self.addresses)
        more = ", ..." if self.count > len(self.addresses) else ""
        return f"{self.count} byte(s) differ, first at {where}{more}"


def to_hex(image: bytes) -> str:
    """The Intel HEX text of a raw image: 16-byte records from 0, every address."""
    hex_image = IntelHex()
    hex_image.frombytes(image, offset=0)
    out = io.StringIO()
    hex_image.write_hex_file(out, byte_count=LINE)
    return out.getvalue()


def from_hex(source: SourceText) -> bytes:
    """The raw image an Intel HEX file holds, read strictly: data records (and a zero
    extended address) from 0 upwards without gaps or overlaps, inside the EEPROM, with
    correct checksums, up to one end-of-file record. ``DiagnosticError`` (E603) names the
    line of the first problem."""
    data = bytearray()
    ended = False
    for number, text in enumerate(source.text.splitlines(), 1):
        record = text.strip()
        if not record:
            continue
        span = Span(source.name, number, len(text) - len(text.lstrip()) + 1, len(record))

        def fail(message: str, span: Span = span) -> DiagnosticError:
            return DiagnosticError([Diagnostic(Severity.ERROR, ImageCode.RAW_HEX, message, span)])

        if ended:
            raise fail("a record after the end-of-file record")
        fields = _record(record)
        if fields is None:
            raise fail("not an Intel HEX record (':' then pairs of hex digits, checksum right)")
        address, kind, payload = fields
        if kind == 1:
            ended = True
        elif kind in (2, 4):
            if any(payload):
                raise fail(f"an extended address ({payload.hex().upper()}h) beyond the "
                           f"{EEPROM_SIZE // 1024} KB EEPROM")
        elif kind != 0:
            raise fail(f"record type {kind:02X}: a raw image has only data records")
        elif address + len(payload) > EEPROM_SIZE:
            raise fail(f"bytes at {address:04X}h-{address + len(payload) - 1:04X}h, outside "
                       f"the {EEPROM_SIZE // 1024} KB EEPROM (0000h-{EEPROM_SIZE - 1:04X}h)")
        elif address > len(data):
            raise fail(f"a gap: no bytes for {len(data):04X}h-{address - 1:04X}h (a raw image "
                       "gives every address from 0, blank ones as FF)")
        elif address < len(data):
            raise fail(f"bytes at {address:04X}h given twice (or out of order)")
        else:
            data += payload
    if not ended:
        raise DiagnosticError([Diagnostic(
            Severity.ERROR, ImageCode.RAW_HEX,
            "no end-of-file record (:00000001FF): the file may be cut short",
            Span(source.name, max(1, source.text.count("\n")), 1),
        )])
    return bytes(data)


def _record(record: str) -> tuple[int, int, bytes] | None:
    """(address, type, data) of one record; None if it is malformed or its checksum wrong."""
    if not record.startswith(":") or len(record) < 11 or len(record) % 2 == 0:
        return None
    try:
        raw = bytes.fromhex(record[1:])
    except ValueError:
        return None
    if len(raw) != raw[0] + 5 or sum(raw) & 0xFF:
        return None
    return raw[1] << 8 | raw[2], raw[3], raw[4:-1]
