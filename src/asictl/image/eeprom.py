"""The program image: what the master keeps in its 16 KB EEPROM (docs/image-format.md).

One byte string carries everything a master needs to run a program and everything a
tool needs to recognise it later: the flags and slave configuration a download sets, the
code, the program map the firmware copies process data by, the firmware entry points the
code was linked against, and (when there is room) the exact source files, so an upload
gives the engineer back what was compiled. Download and upload move these bytes
unchanged; an uploaded file without source keeps them as Intel HEX records in a [RAW]
section, so downloading that file restores the identical image.

This module is the format only: it knows nothing of IL or of the compiler (``build``
makes images from programs), so the emulated board reads images without them.

Every image asictl accepts has exactly one encoding: ``from_bytes`` refuses anything
``to_bytes`` would not write, so decoding and encoding again never changes a byte.
"""

from __future__ import annotations

import hashlib
import io
import struct
import zlib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import PurePath
from typing import Any, Protocol

from intelhex import IntelHex, IntelHexError

from asictl import __version__
from asictl.errors import ExitCode, UserError
from asictl.platform.master import (
    DEFAULT_PARAMETER,
    EEPROM_SIZE,
    NO_PROFILE,
    OPTION_FLAGS,
    SLAVES,
    ControlFlag,
    Options,
)
from asictl.runtime import contract, layout
from asictl.runtime.firmware import FIRMWARE_BLOCKS
from asictl.runtime.line_map import LineMap, LineMapError
from asictl.runtime.program_map import (
    CellKind,
    LoadedProgram,
    Location,
    ProgramMap,
    Space,
    Variable,
)
from asictl.source import SYMBOLS_SUFFIX

MAGIC = b"ASI2"
#: Version 2 added the line map, version 3 a flags byte per timer (whether the program
#: reads its remaining time); older images still read and keep their version when
#: written again.
FORMAT_VERSION = 3
READABLE_VERSIONS = (1, 2, 3)
#: Timer flags (version 3): the program never reads the timer's remaining time.
TIMER_UNREAD = 0x01

# Header layout (all little-endian); docs/image-format.md has the table.
_HEADER = struct.Struct("<4sBBHIB16s4s32s16sHHHH")
HEADER_SIZE = _HEADER.size
_CRC_OFFSET = 8


def image_length(header: bytes) -> int:
    """The total length an image's header announces, or 0 where no image starts: how much
    of the EEPROM an upload reads and a reset loads."""
    if len(header) < HEADER_SIZE or header[: len(MAGIC)] != MAGIC:
        return 0
    length: int = _HEADER.unpack_from(header)[3]
    return length

# Image flags (header byte 5).
SOURCE_INCLUDED = 0x01
SOURCE_LEFT_OUT = 0x02  # left out because it did not fit, not because it was not wanted

_CELL_KINDS = tuple(CellKind)
_SPACE_BIT = 0x80
#: Sources larger than this are refused on decoding rather than inflated (zip bombs).
_MAX_SOURCE_SIZE = 16 * 1024 * 1024


class ImageError(UserError):
    """An image that cannot be built (too big) or read (corrupt, foreign, truncated)."""


# --------------------------------------------------------------------------- pieces


class ProjectedSlave(Protocol):
    """A slave as [SETUP] projects it (``ast.SlaveSetup`` is one); parameter None: F."""

    @property
    def address(self) -> int: ...
    @property
    def io_code(self) -> int: ...
    @property
    def id_code(self) -> int: ...
    @property
    def parameter(self) -> int | None: ...


@dataclass(frozen=True)
class SlaveConfig:
    """A projected slave of an image's configuration."""

    address: int
    io_code: int
    id_code: int
    parameter: int


@dataclass(frozen=True)
class Configuration:
    """The projected configuration a download writes: LPS, PCD and PP in PC2 layout."""

    #: list of projected slaves: slave n is bit n % 8 of byte n // 8
    lps: bytes = bytes(4)
    #: permanent configuration data: byte n = ID code << 4 | I/O code of slave n
    pcd: bytes = bytes([NO_PROFILE]) * SLAVES
    #: permanent parameters: slave 2k in the low nibble of byte k, 2k+1 in the high nibble
    pp: bytes = bytes([DEFAULT_PARAMETER * 0x11]) * (SLAVES // 2)

    @classmethod
    def of(cls, slaves: Iterable[ProjectedSlave]) -> Configuration:
        lps, pcd, pp = bytearray(4), bytearray(cls().pcd), bytearray(cls().pp)
        for slave in slaves:
            n = slave.address
            lps[n // 8] |= 1 << n % 8
            pcd[n] = slave.id_code << 4 | slave.io_code
            parameter = DEFAULT_PARAMETER if slave.parameter is None else slave.parameter
            shift = 4 * (n % 2)
            pp[n // 2] = pp[n // 2] & ~(0xF << shift) | parameter << shift
        return cls(bytes(lps), bytes(pcd), bytes(pp))

    def projected(self) -> list[int]:
        return [n for n in range(SLAVES) if self.lps[n // 8] >> n % 8 & 1]

    def parameter(self, n: int) -> int:
        return self.pp[n // 2] >> 4 * (n % 2) & 0xF

    def slaves(self) -> list[SlaveConfig]:
        """The projected slaves, in address order."""
        return [
            SlaveConfig(n, self.pcd[n] & 0xF, self.pcd[n] >> 4, self.parameter(n))
            for n in self.projected()
        ]


def _source_name(name: str) -> str:
    """Files are stored by base name: the image must not depend on where it was compiled."""
    return PurePath(name).name or name


def source_files(sources: Mapping[str, bytes]) -> list[tuple[str, bytes]]:
    """The (name, raw bytes) pairs an image stores, main first; names must be unique."""
    files: list[tuple[str, bytes]] = []
    seen: set[str] = set()
    for name, raw in sources.items():
        stored = _source_name(name)
        if stored in seen:
            raise ImageError(f"two source files are both named '{stored}'; rename one")
        seen.add(stored)
        files.append((stored, raw))
    return files


def _pack_files(files: list[tuple[str, bytes]]) -> bytes:
    out = bytearray([len(files)])
    for name, raw in files:
        out += _name_bytes(name)
        out += struct.pack("<I", len(raw))
        out += raw
    return bytes(out)


def pack_sources(files: list[tuple[str, bytes]]) -> bytes:
    """The compressed source container."""
    return zlib.compress(_pack_files(files), 9)


def program_identity(files: list[tuple[str, bytes]], version: str = __version__) -> bytes:
    """16 bytes that change whenever a source byte, a file name or the compiler changes."""
    return hashlib.sha256(_name_bytes(version) + _pack_files(files)).digest()[:16]


def _name_bytes(name: str) -> bytes:
    try:
        encoded = name.encode("utf-8")
    except UnicodeEncodeError:  # a file name the system gave as bytes that are not UTF-8
        shown = name.encode("utf-8", "surrogateescape").decode("ascii", "backslashreplace")
        raise ImageError(
            f"{shown}: the file name is not UTF-8, and the image keeps file names as "
            "UTF-8 (an upload gives them back): rename the file"
        ) from None
    if len(encoded) > 255:
        raise ImageError(f"name too long for the image (at most 255 bytes): {name[:40]}...")
    return bytes([len(encoded)]) + encoded


# --------------------------------------------------------------------------- the image


@dataclass(frozen=True)
class ProgramImage:
    """A decoded image; ``to_bytes`` gives the EEPROM contents."""

    #: the AS-i Control flags byte as [OPTIONS] sets it
    flags: int
    configuration: Configuration
    identity: bytes
    code: bytes
    pmap: ProgramMap
    #: firmware block (key name) -> entry address, for the blocks the code calls
    entry_points: Mapping[str, int] = field(default_factory=dict)
    #: the compressed source container; empty when the image carries no source
    source: bytes = b""
    #: why there is no source, when there is none: it did not fit
    source_left_out: bool = False
    code_base: int = layout.CODE_BASE
    #: which IL line each code byte implements (empty: not known, as in version 1)
    line_map: LineMap = field(default_factory=LineMap)
    format_version: int = FORMAT_VERSION

    @property
    def options(self) -> Options:
        return Options.from_flags(self.flags)

    @property
    def identity_hex(self) -> str:
        return self.identity.hex()

    def to_bytes(self) -> bytes:
        if self.format_version < 3 and self.pmap.unread_timers:
            raise ImageError(f"an image of format version {self.format_version} cannot say "
                             "which timers the program reads")
        program_map = _encode_map(self.pmap, self.entry_points, self.format_version)
        if self.format_version >= 2:
            program_map += self.line_map.to_bytes(self.code_base)
        elif self.line_map:
            raise ImageError("an image of format version 1 cannot carry a line map")
        image_flags = (SOURCE_INCLUDED if self.source else 0) | (
            SOURCE_LEFT_OUT if self.source_left_out else 0
        )
        length = HEADER_SIZE + len(self.code) + len(program_map) + len(self.source)
        if length > 0xFFFF:
            raise ImageError(
                f"image needs {length} bytes, the EEPROM holds {EEPROM_SIZE}", ExitCode.FAILED
            )
        header = _HEADER.pack(
            MAGIC, self.format_version, image_flags, length, 0, self.flags, self.identity,
            self.configuration.lps, self.configuration.pcd, self.configuration.pp,
            self.code_base, len(self.code), len(program_map), len(self.source),
        )
        data = bytearray(header + self.code + program_map + self.source)
        struct.pack_into("<I", data, _CRC_OFFSET, zlib.crc32(data))
        return bytes(data)

    @classmethod
    def from_bytes(cls, data: bytes) -> ProgramImage:
        """Decode and validate an image; anything else is an ``ImageError`` saying what."""
        data = bytes(data)
        if data[:4] != MAGIC[: len(data)]:
            raise ImageError(
                f"not a program image written by asictl (it starts with {data[:4].hex(' ')}; "
                f"asictl's images start with {MAGIC.hex(' ')}, '{MAGIC.decode()}'): asictl "
                "reads only the images it wrote itself, not those of other tools such as "
                "the vendor's"
            )
        if len(data) > EEPROM_SIZE:
            raise ImageError(f"image is {len(data)} bytes; the EEPROM holds {EEPROM_SIZE}")
        if len(data) < HEADER_SIZE:
            raise ImageError(
                f"image cut short: {len(data)} bytes, less than its {HEADER_SIZE}-byte header"
            )
        (
            _, version, image_flags, length, crc, flags, identity, lps, pcd, pp,
            code_base, code_size, map_size, source_size,
        ) = _HEADER.unpack_from(data)
        if version not in READABLE_VERSIONS:
            raise ImageError(
                f"image format version {version}; this asictl reads versions "
                + ", ".join(map(str, READABLE_VERSIONS))
            )
        if length != len(data):
            raise ImageError(
                f"image length {len(data)} bytes, but its header says {length}"
                + (" (cut short)" if len(data) < length else " (extra bytes at the end)")
            )
        zeroed = bytearray(data)
        zeroed[_CRC_OFFSET : _CRC_OFFSET + 4] = bytes(4)
        actual = zlib.crc32(zeroed)
        if actual != crc:
            raise ImageError(
                f"image corrupted: CRC-32 is {actual:08X}, the header says {crc:08X}"
            )
        if HEADER_SIZE + code_size + map_size + source_size != length:
            raise ImageError(
                f"image sections ({code_size} + {map_size} + {source_size} bytes after the "
                f"header) do not add up to its length {length}"
            )
        if flags & ~OPTION_FLAGS & 0xFF:
            raise ImageError(f"image sets AS-i Control flags an image cannot set: {flags:02X}h")
        if image_flags not in (
            (SOURCE_INCLUDED,) if source_size else (0, SOURCE_LEFT_OUT)
        ):
            raise ImageError(f"image flags {image_flags:02X}h do not match its contents")
        if lps[0] & 1:
            raise ImageError("image projects slave 0, which is reserved for new slaves")
        code_end = HEADER_SIZE + code_size
        pmap, entry_points, line_map = _decode_map(
            data[code_end : code_end + map_size], bool(flags & ControlFlag.MAP_COUNTERS),
            code_base=code_base, version=version,
        )
        image = cls(
            flags=flags,
            configuration=Configuration(lps, pcd, pp),
            identity=identity,
            code=data[HEADER_SIZE:code_end],
            pmap=pmap,
            entry_points=entry_points,
            source=data[code_end + map_size :],
            source_left_out=bool(image_flags & SOURCE_LEFT_OUT),
            code_base=code_base,
            line_map=line_map,
            format_version=version,
        )
        if image.to_bytes() != data:
            raise ImageError("image is not in the form asictl writes (entries out of order?)")
        try:
            contract.check(image.loaded_program())
        except contract.ContractError as exc:
            raise ImageError(f"image breaks the runtime contract: {exc}") from None
        return image

    def to_hex(self) -> str:
        """Intel HEX text of the EEPROM contents from address 0, 16 bytes a record."""
        hex_image = IntelHex()
        hex_image.frombytes(self.to_bytes(), offset=0)
        out = io.StringIO()
        hex_image.write_hex_file(out, byte_count=16)
        return out.getvalue()

    @classmethod
    def from_hex(cls, text: str) -> ProgramImage:
        return cls.from_bytes(_hex_bytes(text))

    def loaded_program(self) -> LoadedProgram:
        return LoadedProgram(self.code, self.pmap, dict(self.entry_points), self.code_base)

    def sources(self) -> dict[str, bytes]:
        """File name -> raw bytes as compiled, main file first; empty without source."""
        if not self.source:
            return {}
        inflater = zlib.decompressobj()
        try:
            plain = inflater.decompress(self.source, _MAX_SOURCE_SIZE)
        except zlib.error as exc:
            raise ImageError(f"image source text is damaged: {exc}") from None
        if inflater.unconsumed_tail or not inflater.eof or inflater.unused_data:
            raise ImageError("image source text is damaged or implausibly large")
        reader = _Reader(plain, "source container")
        files = {}
        for _ in range(reader.u8()):
            name = reader.name()
            files[name] = reader.take(reader.u32())
        reader.end()
        return files

    def symbols(self) -> tuple[str, bytes] | None:
        """The program's symbol table stored with its source (``NAME.symbols.toml``, the
        container's last file when there is one): its name and raw bytes."""
        sources = self.sources()
        name = _symbols_name(sources)
        return None if name is None else (name, sources[name])

    def program_sources(self) -> dict[str, bytes]:
        """``sources`` without the symbol table: the IL files, main file first."""
        sources = self.sources()
        name = _symbols_name(sources)
        if name is not None:
            del sources[name]
        return sources


def _symbols_name(sources: dict[str, bytes]) -> str | None:
    """The symbol table's name in a source container, or None: a lone file is the program
    itself, whatever its name."""
    last = next(reversed(sources), None)
    if last is None or len(sources) < 2 or not last.endswith(SYMBOLS_SUFFIX):
        return None
    return last


# --------------------------------------------------------------------------- program map


def _encode_map(pmap: ProgramMap, entry_points: Mapping[str, int], version: int) -> bytes:
    out = bytearray(struct.pack("<HH", pmap.pseg, pmap.data_end))
    cells = sorted(pmap.cells.items(), key=lambda item: (_CELL_KINDS.index(item[0][0]), item[0][1]))
    out += struct.pack("<H", len(cells))
    for (kind, index), location in cells:
        space = _SPACE_BIT if location.space is Space.XDATA else 0
        out += struct.pack("<BBH", _CELL_KINDS.index(kind) | space, index, location.address)
    out += struct.pack("<H", len(pmap.timers))
    for number, address in sorted(pmap.timers.items()):
        out += struct.pack("<HH", number, address)
        if version >= 3:
            out.append(TIMER_UNREAD if number in pmap.unread_timers else 0)
    out += struct.pack("<H", len(pmap.counters))
    for number, address in sorted(pmap.counters.items()):
        out += struct.pack("<HH", number, address)
    variables = sorted(pmap.variables.values(), key=lambda v: v.address)
    out += struct.pack("<H", len(variables))
    for variable in variables:
        out += struct.pack("<HB", variable.address, variable.size) + _name_bytes(variable.name)
    out += bytes([len(entry_points)])
    for name, address in sorted(entry_points.items()):
        out += struct.pack("<H", address) + _name_bytes(name)
    return bytes(out)


def _decode_map(
    data: bytes, map_counters: bool, *, code_base: int, version: int
) -> tuple[ProgramMap, dict[str, int], LineMap]:
    reader = _Reader(data, "program map")
    pmap = ProgramMap(pseg=reader.u16(), data_end=reader.u16(), map_counters=map_counters)
    for _ in range(reader.u16()):
        code, index, address = reader.unpack("<BBH")
        if code & ~_SPACE_BIT >= len(_CELL_KINDS):
            raise ImageError(f"image program map: unknown cell kind {code & ~_SPACE_BIT}")
        space = Space.XDATA if code & _SPACE_BIT else Space.IRAM
        pmap.cells[_CELL_KINDS[code & ~_SPACE_BIT], index] = Location(space, address)
    for _ in range(reader.u16()):
        number, address = reader.unpack("<HH")
        pmap.timers[number] = address
        flags = reader.u8() if version >= 3 else 0
        if flags & ~TIMER_UNREAD:
            raise ImageError(f"image program map: timer {number} has unknown flags {flags:02X}h")
        if flags & TIMER_UNREAD:
            pmap.unread_timers.add(number)
    for _ in range(reader.u16()):
        number, address = reader.unpack("<HH")
        pmap.counters[number] = address
    for _ in range(reader.u16()):
        address, size = reader.unpack("<HB")
        name = reader.name()
        pmap.variables[name.casefold()] = Variable(name, address, size)
    entry_points = {}
    for _ in range(reader.u8()):
        (address,) = reader.unpack("<H")
        name = reader.name()
        if name not in FIRMWARE_BLOCKS:
            raise ImageError(f"image calls firmware block '{name}', which this asictl lacks")
        entry_points[name] = address
    line_map = LineMap()
    if version >= 2:
        try:
            line_map = LineMap.from_bytes(reader.rest(), code_base)
        except LineMapError as exc:
            raise ImageError(f"image line map: {exc}") from None
    reader.end()
    return pmap, entry_points, line_map


class _Reader:
    """Reads a length-prefixed structure; running off its end is an ``ImageError``."""

    def __init__(self, data: bytes, what: str) -> None:
        self.data, self.what, self.offset = data, what, 0

    def take(self, n: int) -> bytes:
        if self.offset + n > len(self.data):
            raise ImageError(
                f"image {self.what} cut short: needs {self.offset + n} bytes, has {len(self.data)}"
            )
        chunk = self.data[self.offset : self.offset + n]
        self.offset += n
        return chunk

    def unpack(self, fmt: str) -> tuple[Any, ...]:
        return struct.unpack(fmt, self.take(struct.calcsize(fmt)))

    def u8(self) -> int:
        return self.take(1)[0]

    def rest(self) -> bytes:
        return self.take(len(self.data) - self.offset)

    def u16(self) -> int:
        value: int = self.unpack("<H")[0]
        return value

    def u32(self) -> int:
        value: int = self.unpack("<I")[0]
        return value

    def name(self) -> str:
        raw = self.take(self.u8())
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            raise ImageError(f"image {self.what}: a name is not UTF-8 text") from None

    def end(self) -> None:
        if self.offset != len(self.data):
            raise ImageError(
                f"image {self.what}: {len(self.data) - self.offset} unexpected bytes at the end"
            )


# --------------------------------------------------------------------------- Intel HEX


def _hex_bytes(text: str) -> bytes:
    """The bytes of Intel HEX text that must cover addresses 0..n-1 without gaps."""
    try:
        hex_image = IntelHex(io.StringIO(text))
    except (IntelHexError, ValueError) as exc:
        raise ImageError(f"not valid Intel HEX: {exc}") from None
    addresses = hex_image.addresses()
    if not addresses:
        raise ImageError("the Intel HEX holds no data")
    if addresses[0] != 0 or addresses[-1] != len(addresses) - 1:
        raise ImageError(
            "the Intel HEX does not hold one block from address 0 "
            f"(it covers {len(addresses)} bytes between {addresses[0]:04X}h and "
            f"{addresses[-1]:04X}h)"
        )
    if len(addresses) > EEPROM_SIZE:
        raise ImageError(f"the Intel HEX holds {len(addresses)} bytes; the EEPROM {EEPROM_SIZE}")
    data: bytes = hex_image.tobinstr()
    return data


def differences(mine: ProgramImage, theirs: ProgramImage) -> list[str]:
    """What differs between two images, in the words of the program's sections (``verify``
    and ``fleet verify`` say it so)."""
    found = []
    if mine.code != theirs.code or mine.entry_points != theirs.entry_points:
        found.append("code ([PROGRAM])")
    if mine.configuration != theirs.configuration:
        mine_slaves, their_slaves = mine.configuration.slaves(), theirs.configuration.slaves()
        changed = sorted(
            {s.address for s in mine_slaves} ^ {s.address for s in their_slaves}
            | {a.address for a, b in zip(mine_slaves, their_slaves, strict=False) if a != b}
        )
        found.append(
            "configuration ([SETUP]"
            + (f": slaves {', '.join(map(str, changed))}" if changed else "")
            + ")"
        )
    if mine.flags != theirs.flags:
        found.append("options ([OPTIONS])")
    if mine.pmap != theirs.pmap and "code ([PROGRAM])" not in found:
        found.append("memory layout")
    # The identity is the hash of the source files: equal identities with other bytes are
    # one program stored with and without its source (compile --no-source), not two.
    if not found and mine.identity != theirs.identity:
        found.append("source text or file names only (the program's identity differs)")
    return found
