"""The program image: exact layout, round trips, and refusal of anything damaged."""

from __future__ import annotations

import contextlib
import random
import re
import struct
import zlib
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from manual_examples import EXAMPLES

from asictl.build import Origin, build, build_image, image_from_raw
from asictl.codegen8051.compiler import Compiled, compile_program
from asictl.diagnostics import Span
from asictl.host.program_files import uploaded_source
from asictl.il import ast
from asictl.il.checks import check_source
from asictl.image.eeprom import (
    HEADER_SIZE,
    MAGIC,
    TIMER_UNREAD,
    Configuration,
    ImageError,
    ProgramImage,
    SlaveConfig,
    program_identity,
)
from asictl.platform.master import EEPROM_SIZE, Options
from asictl.runtime import layout
from asictl.runtime.line_map import LineMap, LineMapError
from asictl.runtime.program_map import LoadedProgram
from asictl.runtime.runner import ProgramRunner
from asictl.source import from_string, read_source

BLINK = Path(__file__).resolve().parents[2] / "demos" / "blink.asi"


def compile_text(text: str, name: str = "prog.asi") -> Compiled:
    result = check_source(from_string(name, text))
    assert not [d for d in result.diagnostics if d.is_error], result.diagnostics
    return compile_program(result.program)


def compile_file(path: Path | str) -> Compiled:
    result = check_source(read_source(path))
    assert not [d for d in result.diagnostics if d.is_error], result.diagnostics
    return compile_program(result.program)


@pytest.fixture(scope="module")
def blink() -> Compiled:
    return compile_file(BLINK)


@pytest.fixture(scope="module")
def blink_bytes(blink: Compiled) -> bytes:
    return build_image(blink).to_bytes()


def with_fixed_crc(data: bytes | bytearray) -> bytes:
    """The image with a length and CRC that match its (possibly damaged) contents."""
    fixed = bytearray(data)
    struct.pack_into("<HI", fixed, 6, len(fixed), 0)
    struct.pack_into("<I", fixed, 8, zlib.crc32(fixed))
    return bytes(fixed)


# ----------------------------------------------------------------------- layout


def test_header_fields_at_their_documented_offsets(blink: Compiled, blink_bytes: bytes):
    data = blink_bytes
    image = ProgramImage.from_bytes(data)
    assert data[0:4] == MAGIC == b"ASI2"
    assert data[4] == 3  # format version
    assert data[5] == 0x01  # source included
    assert struct.unpack_from("<H", data, 6)[0] == len(data)
    crc = struct.unpack_from("<I", data, 8)[0]
    assert crc == zlib.crc32(data[:8] + bytes(4) + data[12:])
    assert data[12] == 0x00  # auto_start: yes, nothing else set
    assert data[13:29] == image.identity
    assert data[29:33] == bytes([0, 0, 0, 0x80])  # slave 31
    assert data[33 + 31] == 0x08  # IO 8, ID 0
    assert data[65:81] == b"\xff" * 16
    code_base, code, pmap, source = struct.unpack_from("<HHHH", data, 81)
    assert HEADER_SIZE == 89
    assert (code_base, code) == (layout.CODE_BASE, len(blink.code))
    assert data[HEADER_SIZE : HEADER_SIZE + code] == blink.code
    assert HEADER_SIZE + code + pmap + source == len(data)
    assert data[-source:] == image.source


def test_bytes_round_trip_and_loaded_program(blink: Compiled, blink_bytes: bytes):
    image = ProgramImage.from_bytes(blink_bytes)
    assert image.to_bytes() == blink_bytes
    assert image == build_image(blink)
    assert image.pmap == blink.pmap
    loaded = image.loaded_program()
    assert (loaded.code, loaded.pmap, loaded.code_base) == (
        blink.code, blink.pmap, layout.CODE_BASE
    )
    assert image.sources() == {"blink.asi": BLINK.read_bytes()}


def test_hex_round_trip_and_records(blink_bytes: bytes):
    image = ProgramImage.from_bytes(blink_bytes)
    text = image.to_hex()
    records = text.splitlines()
    assert records[0].startswith(":10000000" + MAGIC.hex().upper())
    assert all(r.startswith(":10") for r in records[:-2])
    assert records[-1] == ":00000001FF"
    assert ProgramImage.from_hex(text).to_bytes() == blink_bytes


def test_every_map_part_survives_the_round_trip(tmp_path: Path):
    (tmp_path / "mean.fb").write_text(
        "[DECL]\nAcc BYTE 2\n[PROGRAM]\n    L FY 3\n    T Acc 0\n    JU FB GetPP\n"
    )
    main = tmp_path / "main.asi"
    main.write_text(
        "[OPTIONS]\nmap_counters: yes\n[DECL]\nT20 TIMER\nC30 COUNTER\nBuffer BYTE 7\n"
        "MEAN FB mean.fb\n[PROGRAM]\n    A I 3.1\n    AN I2 3.1\n    O F 9.2\n    = Q 4.0\n"
        "    L KT 100\n    S T 20\n    A T 1\n    CU C 2\n    CU C 30\n    L KB 1\n"
        "    T Buffer 6\n    L KP 13.3\n    PARAM\n    JU FB MEAN\n"
    )
    compiled = compile_file(main)
    image = ProgramImage.from_bytes(build_image(compiled).to_bytes())
    assert image.pmap == compiled.pmap
    assert image.pmap.map_counters and image.pmap.variables and image.pmap.counters
    assert image.entry_points == {"getpp": 0x104, "sendprm": 0x108}
    assert list(image.sources()) == ["main.asi", "mean.fb"]


def test_image_runs_like_the_compiled_program(blink: Compiled, blink_bytes: bytes):
    from_image = ProgramRunner(ProgramImage.from_bytes(blink_bytes).loaded_program())
    compiled = ProgramRunner(LoadedProgram(blink.code, blink.pmap, dict(blink.entry_points)))
    seen = []
    for _ in range(120):
        for runner in (from_image, compiled):
            runner.cycle(bytes(16))
            runner.tick()
        assert from_image.outputs == compiled.outputs
        seen.append(from_image.outputs[15])
    assert len(set(seen)) == 2  # Q 31.0 blinks


# ----------------------------------------------------------------------- flags and setup


@pytest.mark.parametrize(
    ("options", "byte"),
    [
        (Options(), 0x00),
        (Options(auto_start=False), 0x08),
        (Options(ignore_config_errors=True), 0x04),
        (Options(map_counters=True), 0x10),
        (Options(auto_start=False, ignore_config_errors=True, map_counters=True), 0x1C),
    ],
)
def test_control_flags(options: Options, byte: int):
    assert options.control_flags() == byte
    assert Options.from_flags(byte) == options


def test_manual_options_example_sets_ignore_and_wait_for_set_button():
    image = build_image(compile_text(EXAMPLES["options"] + "[PROGRAM]\n    BE\n"))
    assert image.flags == 0x0C
    assert image.to_bytes()[12] == 0x0C


def test_manual_setup_example_gives_exact_lps_pcd_pp():
    image = build_image(compile_text(EXAMPLES["setup"] + "[PROGRAM]\n    BE\n"))
    config = image.configuration
    assert config.lps == bytes([0x08, 0x00, 0x01, 0x00])  # slaves 3 and 16
    pcd = bytearray(b"\xff" * 32)
    pcd[3] = 0x0B  # IO B, ID 0
    pcd[16] = 0x11  # IO 1 (iiio), ID 1
    assert config.pcd == bytes(pcd)
    pp = bytearray(b"\xff" * 16)
    pp[8] = 0xFE  # slave 16: Eh in the low nibble; slave 17 (not set up): F
    assert config.pp == bytes(pp)  # slave 3 without parameter: F
    data = image.to_bytes()
    assert data[29:33] == config.lps and data[33:65] == config.pcd and data[65:81] == config.pp
    assert config.slaves() == [SlaveConfig(3, 0xB, 0, 0xF), SlaveConfig(16, 1, 1, 0xE)]


def test_odd_slave_parameter_is_the_high_nibble():
    config = Configuration.of([ast.SlaveSetup(5, 0, 0, 0x3)])
    assert config.pp[2] == 0x3F


# ----------------------------------------------------------------------- identity


FILES = [("main.asi", b"[PROGRAM]\n    A I 1.0\n    = Q 1.0\n"), ("x.fb", b"[PROGRAM]\n")]


@given(st.data())
def test_identity_changes_with_any_source_byte(data):
    index = data.draw(st.integers(0, len(FILES) - 1))
    name, raw = FILES[index]
    position = data.draw(st.integers(0, len(raw) - 1))
    flip = data.draw(st.integers(1, 255))
    changed = bytearray(raw)
    changed[position] ^= flip
    files = list(FILES)
    files[index] = (name, bytes(changed))
    assert program_identity(files) != program_identity(FILES)


def test_identity_depends_on_names_order_and_version_only():
    base = program_identity(FILES)
    assert program_identity(list(FILES)) == base
    assert program_identity([("main.asi", FILES[0][1]), ("y.fb", FILES[1][1])]) != base
    assert program_identity(FILES, version="0.1.1") != base
    assert program_identity(FILES[:1]) != base
    assert program_identity([FILES[0], ("x.fb", b"[PROGRAM]\n" + b"")]) == base


def test_identity_does_not_depend_on_the_directory(tmp_path: Path, blink_bytes: bytes):
    copy = tmp_path / "blink.asi"
    copy.write_bytes(BLINK.read_bytes())
    assert build_image(compile_file(copy)).to_bytes() == blink_bytes
    copy.write_bytes(BLINK.read_bytes() + b"\n")
    assert build_image(compile_file(copy)).identity != ProgramImage.from_bytes(
        blink_bytes
    ).identity


# ----------------------------------------------------------------------- damage


@settings(max_examples=300, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.data())
def test_crc_detects_every_single_corrupted_byte(blink_bytes: bytes, data):
    position = data.draw(st.integers(0, len(blink_bytes) - 1))
    damaged = bytearray(blink_bytes)
    damaged[position] ^= data.draw(st.integers(1, 255))
    with pytest.raises(ImageError):
        ProgramImage.from_bytes(bytes(damaged))


def test_crc_error_message(blink_bytes: bytes):
    damaged = bytearray(blink_bytes)
    damaged[200] ^= 1
    with pytest.raises(ImageError, match=r"image corrupted: CRC-32 is [0-9A-F]{8}, the header"):
        ProgramImage.from_bytes(bytes(damaged))


@settings(suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.integers(0, 443))
def test_truncated_image_is_refused_clearly(blink_bytes: bytes, length: int):
    with pytest.raises(ImageError, match=r"cut short|not a program image written by asictl"):
        ProgramImage.from_bytes(blink_bytes[:length])


@given(st.binary(max_size=600))
def test_garbage_is_an_image_error(data: bytes):
    with pytest.raises(ImageError):
        ProgramImage.from_bytes(data)


@settings(max_examples=400, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.data())
def test_damage_behind_a_valid_crc_is_an_image_error_or_a_faithful_image(blink_bytes, data):
    """What a checksum cannot catch (a buggy writer) still never crashes the reader."""
    damaged = bytearray(blink_bytes)
    for _ in range(data.draw(st.integers(1, 4))):
        position = data.draw(st.integers(12, len(damaged) - 1))
        damaged[position] = data.draw(st.integers(0, 255))
    cut = data.draw(st.one_of(st.just(len(damaged)), st.integers(HEADER_SIZE, len(damaged))))
    candidate = with_fixed_crc(damaged[:cut])
    try:
        image = ProgramImage.from_bytes(candidate)
    except ImageError:
        return
    assert image.to_bytes() == candidate
    with contextlib.suppress(ImageError):
        image.sources()


@given(st.text(max_size=300))
def test_hex_garbage_is_an_image_error(text: str):
    with pytest.raises(ImageError):
        ProgramImage.from_hex(text)


def test_other_version_and_foreign_data_messages(blink_bytes: bytes):
    newer = bytearray(blink_bytes)
    newer[4] = 4
    with pytest.raises(ImageError, match="format version 4; this asictl reads versions 1, 2, 3"):
        ProgramImage.from_bytes(with_fixed_crc(newer))
    with pytest.raises(ImageError, match=r"starts with 3a 31 30 30; asictl's images start with"):
        ProgramImage.from_bytes(b":10000000")
    with pytest.raises(ImageError, match="extra bytes at the end"):
        ProgramImage.from_bytes(blink_bytes + b"\0")


def test_header_consistency_is_checked(blink_bytes: bytes):
    both = bytearray(blink_bytes)
    both[5] = 0x03  # source included and left out
    with pytest.raises(ImageError, match="image flags 03h do not match its contents"):
        ProgramImage.from_bytes(with_fixed_crc(both))
    moved = bytearray(blink_bytes)
    struct.pack_into("<H", moved, 81, 0x0100)
    with pytest.raises(ImageError, match="code linked at 0100h; the firmware enters programs at"):
        ProgramImage.from_bytes(with_fixed_crc(moved))
    with pytest.raises(ImageError, match="image is 16385 bytes; the EEPROM holds 16384"):
        ProgramImage.from_bytes(MAGIC + bytes(EEPROM_SIZE + 1 - len(MAGIC)))


def test_hex_with_a_gap_is_refused(blink_bytes: bytes):
    records = ProgramImage.from_bytes(blink_bytes).to_hex().splitlines()
    with pytest.raises(ImageError, match="one block from address 0"):
        ProgramImage.from_hex("\n".join(records[:2] + records[3:]))


# ----------------------------------------------------------------------- [RAW]


def uploaded_module(image: ProgramImage) -> ast.Module:
    source = from_string("uploaded.asi", uploaded_source(image))
    result = check_source(source)
    assert result.diagnostics == []  # a download will accept it
    return result.program.main


def image_from_uploaded(text: str) -> ProgramImage:
    """What the build makes of an uploaded file; its diagnostics raised as ``ImageError``."""
    built = build(from_string("uploaded.asi", text))
    assert built.origin is Origin.RAW
    if built.diagnostics:
        raise ImageError("; ".join(d.message for d in built.diagnostics))
    assert built.image is not None
    return built.image


def test_raw_round_trip_gives_the_identical_image(blink: Compiled):
    image = build_image(blink, with_source=False)
    module = uploaded_module(image)
    (raw,) = module.sections_of(ast.RawSection)
    assert image_from_raw(raw.records).to_bytes() == image.to_bytes()
    assert image_from_uploaded(uploaded_source(image)).to_bytes() == image.to_bytes()


def test_uploaded_source_shows_options_and_setup():
    text = EXAMPLES["options"] + EXAMPLES["setup"] + "[PROGRAM]\n    BE\n"
    image = build_image(compile_text(text), with_source=False)
    source = uploaded_source(image)
    assert "ignore_config_errors: yes\nauto_start: no\nmap_counters: no\n" in source
    assert "[SETUP]\n3: Bh, 0h, Fh\n16: 1h, 1h, Eh\n" in source
    assert image_from_uploaded(uploaded_module(image).to_source()) == image


def test_edited_uploaded_sections_are_refused(blink: Compiled):
    text = uploaded_source(build_image(blink, with_source=False))
    edited = text.replace("auto_start: yes", "auto_start: no").replace("31: 8h", "30: 8h")
    with pytest.raises(ImageError) as caught:
        image_from_uploaded(edited)
    message = str(caught.value)
    assert "[OPTIONS] auto_start: no, the image has yes" in message
    assert "[SETUP] slave 30: 8h, 0h, Fh, the image has not set up" in message
    assert "[SETUP] slave 31: not set up, the image has 8h, 0h, Fh" in message


def test_broken_raw_records_name_the_section():
    with pytest.raises(ImageError, match=r"^\[RAW\] section: not a program image written by"):
        image_from_uploaded("[RAW]\n:0300000002003BC0\n:00000001FF\n")


# ----------------------------------------------------------------------- size limits


def noise(size: int) -> str:
    """Comment text that zlib cannot shrink much."""
    rng = random.Random(7)
    alphabet = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789"
    return "".join(
        "; " + "".join(rng.choice(alphabet) for _ in range(70)) + "\n" for _ in range(size // 73)
    )


def test_source_left_out_when_it_does_not_fit_but_the_program_does():
    compiled = compile_text(noise(30_000) + EXAMPLES["blink"])
    image = build_image(compiled)
    assert image.source == b"" and image.source_left_out
    assert len(image.to_bytes()) < EEPROM_SIZE
    assert image.to_bytes()[5] == 0x02
    assert image.sources() == {}
    assert ProgramImage.from_bytes(image.to_bytes()) == image
    assert "it did not fit in the EEPROM" in uploaded_source(image)
    unwanted = build_image(compiled, with_source=False)
    assert not unwanted.source_left_out and unwanted.to_bytes()[5] == 0


def test_program_too_big_for_the_eeprom_names_the_sizes():
    compiled = compile_text("[PROGRAM]\n    A I 1.0\n    = Q 1.0\n[ASSEMBLY]\n    DS 16300\n")
    with pytest.raises(ImageError) as caught:
        build_image(compiled)
    message = str(caught.value)
    match = re.match(
        rf"image needs (\d+) bytes, the EEPROM holds 16384 \(code {len(compiled.code)}, "
        rf"program map \d+, header {HEADER_SIZE}\)$",
        message,
    )
    assert match and int(match[1]) > EEPROM_SIZE, message
    assert caught.value.exit_code == 1


# ----------------------------------------------------------------------- line map


def test_the_line_map_names_every_il_line_with_code(blink: Compiled, blink_bytes: bytes):
    image = ProgramImage.from_bytes(blink_bytes)
    assert image.line_map == blink.line_map
    assert image.line_map.files == ("blink.asi",)
    listing = {entry.address: entry for entry in blink.assembly.listing if entry.data}
    for address in sorted(listing):
        span = blink.lines[listing[address].span.line - 1].span
        found = image.line_map.line_at(address)
        assert (found.line if found else None) == (span.line if span else None)


def _without_timer_flags(image: ProgramImage) -> ProgramImage:
    return replace(image, pmap=replace(image.pmap, unread_timers=set()))


def test_a_version_1_image_still_reads_and_keeps_its_bytes(blink_bytes: bytes):
    image = ProgramImage.from_bytes(blink_bytes)
    old = replace(_without_timer_flags(image), line_map=LineMap(), format_version=1)
    data = old.to_bytes()
    assert data[4] == 1 and len(data) < len(blink_bytes)
    again = ProgramImage.from_bytes(data)
    assert again.to_bytes() == data and not again.line_map
    assert again.loaded_program().code == image.code
    with pytest.raises(ImageError, match="version 1 cannot carry a line map"):
        replace(_without_timer_flags(image), format_version=1).to_bytes()


def test_a_version_2_image_reads_with_every_timer_ticking_one_by_one(blink_bytes: bytes):
    """Version 2 has no timer flags: read back, no timer is one the master may step over."""
    image = ProgramImage.from_bytes(blink_bytes)
    assert image.pmap.timers and image.pmap.unread_timers == set(image.pmap.timers)
    with pytest.raises(ImageError, match="version 2 cannot say which timers"):
        replace(image, format_version=2).to_bytes()
    data = replace(_without_timer_flags(image), format_version=2).to_bytes()
    assert data[4] == 2 and len(data) == len(blink_bytes) - len(image.pmap.timers)
    again = ProgramImage.from_bytes(data)
    assert again.to_bytes() == data and again.pmap.unread_timers == set()
    assert again.pmap.timers == image.pmap.timers and again.line_map == image.line_map


def test_timer_flags_name_the_timers_whose_remaining_time_the_program_reads():
    """``L T n`` reads a timer's remaining time, ``A T n`` only its status; any ASM line
    may read anything. The image says so, and refuses flags it does not know."""
    status_only = build(from_string("p.asi", "[PROGRAM]\n A I 1.0\n L KT 500\n S T 1\n"
                                    " A T 1\n = Q 2.0\n L T 2\n T FW 10\n R T 2\n"))
    assert status_only.image is not None and not status_only.has_errors
    pmap = ProgramImage.from_bytes(status_only.image.to_bytes()).pmap
    assert pmap.timers.keys() == {1, 2} and pmap.unread_timers == {1}
    asm = build(from_string("p.asi", "[PROGRAM]\n A I 1.0\n L KT 500\n S T 1\n"
                            "[ASSEMBLY]\n NOP\n"))
    assert asm.image is not None and not asm.has_errors, asm.render()
    assert asm.image.pmap.timers.keys() == {1} and asm.image.pmap.unread_timers == set()
    inline = build(from_string("p.asi", "[PROGRAM]\n A I 1.0\n L KT 500\n S T 1\n ASM NOP\n"))
    assert inline.image is not None and not inline.has_errors, inline.render()
    assert inline.image.pmap.unread_timers == set()
    data = bytearray(status_only.image.to_bytes())
    at = data.find(struct.pack("<HH", 1, pmap.timers[1]) + bytes([TIMER_UNREAD]))
    assert at > 0
    data[at + 4] = 0x81
    with pytest.raises(ImageError, match="timer 1 has unknown flags 81h"):
        ProgramImage.from_bytes(with_fixed_crc(data))


@given(st.lists(st.tuples(st.integers(1, 40), st.none() | st.tuples(
    st.sampled_from(["a.asi", "b.fb"]), st.integers(1, 5000))), max_size=60))  # [] included
def test_line_maps_round_trip(pieces):
    address, spans = layout.CODE_BASE, []
    for length, where in pieces:
        spans.append((address, length, Span(where[0], where[1], 1) if where else None))
        address += length
    line_map = LineMap.build(spans)
    assert bool(line_map) == any(length for length, _ in pieces)
    data = line_map.to_bytes(layout.CODE_BASE)
    assert LineMap.from_bytes(data, layout.CODE_BASE) == line_map
    for start, length, span in spans:
        found = line_map.line_at(start + length - 1)
        assert (str(found) if found else None) == (f"{span.file}:{span.line}" if span else None)


def test_line_map_file_names_must_be_plain_and_printable():
    good = LineMap.build([(0x4000, 2, Span("main.asi", 3, 1))])
    data = good.to_bytes(0x4000)
    assert LineMap.from_bytes(data, 0x4000).files == ("main.asi",)
    for bad in ("m\x1b[2Jx.asi", "../etc.asi"):
        crafted = data.replace(b"\x08main.asi", bytes([len(bad.encode())]) + bad.encode())
        with pytest.raises(LineMapError, match="not a plain printable name"):
            LineMap.from_bytes(crafted, 0x4000)
