"""W718: a slave's answer (F 127 after PARAM, PSeg after SendPrm, Command, Address) read
in the cycle that asked for it. asictl's master answers at once, a real master only in
its management phase (manual 3.4.6), so such a program behaves differently on each."""

from __future__ import annotations

from pathlib import Path

import pytest

from asictl.il.checks import check_source
from asictl.source import from_string, read_source

SETUP = "[SETUP]\n1: iiii, 0\n2: oooo, 0\n5: oooo, 0\n"


def program(*lines: str) -> str:
    """A whole program: the setup, then [PROGRAM] from line 6 on."""
    return SETUP + "[PROGRAM]\n" + "".join(f"{line}\n" for line in lines)


def w718(text: str) -> list[int]:
    """The lines W718 stands at."""
    diagnostics = check_source(from_string("t.asi", text)).diagnostics
    return [d.span.line for d in diagnostics if d.code == "W718" and d.span]


ASK = ("    A I 1.0", "    L KP 5.3", "    PARAM")  # lines 6-8


def test_reading_the_answer_right_after_param_is_reported_with_the_param():
    text = program(*ASK, "    A F 127.7", "    = Q 2.0")
    diagnostics = check_source(from_string("t.asi", text)).diagnostics
    [d] = [d for d in diagnostics if d.code == "W718"]
    assert (d.span.line, d.span.column) == (9, 7)
    assert "F 127.7" in d.message and "PARAM" in d.message and "next cycle" in d.message
    assert [(span.line, note) for span, note in d.related] == [(8, "PARAM asks here")]


@pytest.mark.parametrize("read", ["    A F 127.0", "    A F 127.3", "    L FY 127",
                                  "    L FW 126", "    L PSeg 1"])
def test_every_way_to_read_the_answer_bits_is_reported(read: str):
    assert w718(program(*ASK, "***", read, "    T FY 20" if read.startswith("    L") else
                        "    = F 20.0")) == [10]


def test_bits_param_keeps_and_bits_the_program_wrote_since_are_no_answer():
    """PARAM keeps F 127.4-6; after the program writes a bit, it reads its own write."""
    assert w718(program(*ASK, "***", "    A F 127.5", "    = Q 2.0")) == []
    assert w718(program(*ASK, "***", "    A I 1.1", "    = F 127.7", "***",
                        "    A F 127.7", "    = Q 2.0")) == []
    assert w718(program(*ASK, "    L KB 0", "    T FY 127", "    L FY 127",
                        "    T FY 20")) == []


def test_reading_it_before_asking_reads_the_answer_of_the_cycle_before():
    assert w718(program("    A F 127.7", "    = Q 2.0", "***", *ASK)) == []


def test_a_backward_jump_stays_in_the_cycle():
    text = program("top: A F 127.7", "    = Q 2.0", "***", *ASK, "    A I 1.2",
                   "    JC = top")
    assert w718(text) == [6]


def test_a_path_that_may_have_asked_is_enough():
    text = program("    A I 1.1", "    JC = skip", "    L KP 5.3", "    PARAM",
                   "skip: A F 127.7", "    = Q 2.0")
    assert w718(text) == [10]


def test_the_end_of_the_cycle_ends_it():
    """BE, BEU end the cycle; a BEC may not (the register 0 goes on)."""
    assert w718(program(*ASK, "    BEU", "    A F 127.7", "    = Q 2.0")) == []
    assert w718(program(*ASK, "***", "    A I 1.1", "    BEC", "    A F 127.7",
                        "    = Q 2.0")) == [12]


@pytest.mark.parametrize("block,read,warned", [
    ("SendPrm", "PSeg 1", True), ("Command", "PSeg 0", True), ("Address", "PSeg 0", True),
    ("Address", "PSeg 1", False),  # its input, not an answer
    ("GetPP", "PSeg 1", False),    # the master's own memory: there at once on any master
    ("GetLAS", "PSeg 4", False),
])
def test_firmware_blocks_that_send_on_the_cable(block: str, read: str, warned: bool):
    text = program("    L KB 5", "    T PSeg 0", "    L KB 3", "    T PSeg 1",
                   f"    JU FB {block}", f"    L {read}", "    T FY 20")
    assert w718(text) == ([11] if warned else [])


def test_writing_the_segment_again_clears_the_answer():
    text = program("    L KB 5", "    T PSeg 0", "    JU FB Command", "    L KB 1",
                   "    T PSeg 0", "    L PSeg 0", "    T FY 20")
    assert w718(text) == []


def test_a_block_that_asks_makes_the_answer_pending_at_its_call(tmp_path: Path):
    (tmp_path / "send.fb").write_text("[PROGRAM]\n    A I 1.0\n    L KP 5.3\n    PARAM\n"
                                      "    BE\n")
    (tmp_path / "reads.fb").write_text("[PROGRAM]\n    A I 1.0\n    L KP 5.3\n    PARAM\n"
                                       "    A F 127.7\n    = F 21.0\n    BE\n")
    main = tmp_path / "main.asi"
    main.write_text(SETUP.replace("[SETUP]", "[DECL]\nSend FB send.fb\nReads FB reads.fb\n"
                                  "[SETUP]")
                    + "[PROGRAM]\n    A I 1.0\n    JC FB Send\n    A F 127.0\n    = Q 2.0\n"
                    "***\n    A I 1.1\n    JC FB Reads\n")
    diagnostics = check_source(read_source(main)).diagnostics
    found = sorted((Path(d.span.file).name, d.span.line)
                   for d in diagnostics if d.code == "W718" and d.span)
    assert found == [("main.asi", 11), ("reads.fb", 5)]
