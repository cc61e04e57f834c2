"""What an editor shows about the language: one table of every instruction, operand
mark, section and option, in the wording of docs/language.md.

Hover and completion both read these tables; ``tests/lsp`` checks that every operator of
the grammar has an entry and that each text stands in docs/language.md, so the editor
and the documentation say the same. (Firmware blocks are described by
``asictl.runtime.firmware``.)
"""

from __future__ import annotations

from dataclasses import dataclass

from asictl.platform.master import IO_CODES


@dataclass(frozen=True)
class Entry:
    #: how it is written, e.g. "A <bit operand>"
    syntax: str
    #: what it does, as docs/language.md says it
    meaning: str


#: Operators of [PROGRAM] lines (§3.4), keyed by their canonical spelling.
INSTRUCTIONS: dict[str, Entry] = {
    "A": Entry("A <bit>", "register := register and operand"),
    "AN": Entry("AN <bit>", "register := register and not operand"),
    "O": Entry("O <bit>", "register := register or operand"),
    "ON": Entry("ON <bit>", "register := register or not operand"),
    "=": Entry("= <bit>", "operand := register"),
    "S": Entry("S <bit>", "operand := 1 when the register is 1"),
    "R": Entry("R <bit>", "operand := 0 when the register is 1"),
    "N": Entry("N", "register := not register"),
    "L": Entry("L <byte, word, KB or KW>", "ACCU2 := ACCU1, ACCU1 := operand"),
    "T": Entry("T <byte or word>", "operand := ACCU1"),
    "+": Entry("+ F", "ACCU1 := ACCU2 + ACCU1 (bytes, unsigned, modulo 256)"),
    "-": Entry("- F", "ACCU1 := ACCU2 - ACCU1 (bytes, unsigned, modulo 256)"),
    "!=": Entry("!= F", "register := ACCU2 **=** ACCU1 (the manual: \"equality (!)\")"),
    "><": Entry(">< F", "register := ACCU2 ≠ ACCU1"),
    ">": Entry("> F", "register := ACCU2 > ACCU1"),
    ">=": Entry(">= F", "register := ACCU2 ≥ ACCU1"),
    "<": Entry("< F", "register := ACCU2 < ACCU1"),
    "<=": Entry("<= F", "register := ACCU2 ≤ ACCU1"),
    "CU": Entry("CU C <n>", "with the register 1: add 1"),
    "CD": Entry("CD C <n>", "with the register 1: subtract 1"),
    "STP": Entry("STP C <n>", "unconditionally: add 1 when the register is 1, subtract 1 "
                 "when it is 0"),
    "***": Entry("***", "segment end: the register becomes undefined, the next A/O loads it "
                 "(first check)"),
    "BE": Entry("BE", "block end: ends the program cycle (in a function block: returns)"),
    "BEC": Entry("BEC", "ends the cycle (returns) when the register is 1, else goes on"),
    "BEU": Entry("BEU", "ends the cycle (returns) unconditionally (Control II)"),
    "JU": Entry("JU = <label> | JU FB <block>", "jumps to the label; `JU FB name` calls a "
                "function block"),
    "JC": Entry("JC = <label> | JC FB <block>", "jumps when the register is 1; leaves the "
                "register as it is either way; `JC FB name` calls a function block when the "
                "register is 1"),
    "PARAM": Entry("PARAM", "with the register 1, sends the parameter of the last `L KP a.d` "
                   "to slave a"),
    "ASM": Entry("ASM <8051 instruction>", "passes the rest of the line, up to its comment "
                 "and without surrounding blanks, to the assembler unexamined"),
}

#: ``L`` of a KT, KC or KP constant loads the constant register (il-semantics: "a
#: register independent of previous operations"), not the accumulators.
CONSTANT_LOADS: dict[str, Entry] = {
    "KT": Entry("L KT <ms>", "constant register := the time (for S T); ACCU1 and ACCU2 "
                "keep their values"),
    "KC": Entry("L KC <n>", "constant register := the count (for S C); ACCU1 and ACCU2 "
                "keep their values"),
    "KP": Entry("L KP <slave>.<data>", "constant register := slave and parameter (for "
                "PARAM); ACCU1 and ACCU2 keep their values"),
}

#: Operand marks (§3.4.1-3.4.3), keyed by their canonical spelling.
OPERANDS: dict[str, Entry] = {
    "I": Entry("I a.b", "input: slave a 0..31, data bit b 0..3"),
    "I2": Entry("I2 a.b", "input of the previous cycle: as I; compare I and I2 for edges"),
    "Q": Entry("Q a.b", "output: slave a 0..31, data bit b 0..3"),
    "F": Entry("F y.b", "flag: byte 0..127, bit 0..7"),
    "T": Entry("T n", "The status bit (A T n) is 1 while the remaining time is not 0; "
               "the remaining time of timer n in 10 ms ticks"),
    "C": Entry("C n", "The status bit (A C n) is 1 while the count is not 0; "
               "the count of counter n"),
    "IB": Entry("IB n", "n an *even* slave address (the byte holds slave n in its low nibble "
                "and slave n+1 in its high nibble)"),
    "I2B": Entry("I2B n", "input of the previous cycle; n an *even* slave address (the byte "
                 "holds slave n in its low nibble and slave n+1 in its high nibble)"),
    "QB": Entry("QB n", "n an *even* slave address (the byte holds slave n in its low nibble "
                "and slave n+1 in its high nibble)"),
    "FY": Entry("FY n", "flag byte 0..127"),
    "FW": Entry("FW n", "flag word: FY n is the high byte, FY n+1 the low byte, as in STEP5"),
    "PSEG": Entry("PSeg n", "byte n of the parameter passing segment (16 bytes)"),
    "KT": Entry("KT ms", "time in ms, 0..40950; also the preset of the next `S T n`"),
    "KC": Entry("KC n", "count 0..4095; also the preset of the next `S C n`"),
    "KP": Entry("KP a.d", "slave a 0..31, parameter d 0..15, for `PARAM`"),
    "KB": Entry("KB n", "byte 0..255"),
    "KW": Entry("KW n", "word 0..65535"),
}

#: Section titles (§3), keyed by their canonical spelling.
SECTIONS: dict[str, Entry] = {
    "OPTIONS": Entry("[OPTIONS]", "options (§3.1)"),
    "SETUP": Entry("[SETUP]", "expected configuration (§3.2)"),
    "DECL": Entry("[DECL]", "declarations (§3.3)"),
    "PROGRAM": Entry("[PROGRAM]", "logic in STEP5-like IL (§3.4)"),
    "GATING": Entry("[GATING]", "logic in the gating syntax (§3.5)"),
    "ASSEMBLY": Entry("[ASSEMBLY]", "8051 assembler (§3.6)"),
    "RAW": Entry("[RAW]", "EEPROM image as Intel HEX (§3.7)"),
    "END": Entry("[END]", "end of the source"),
}

#: [OPTIONS] flags (§3.1): the default, then the meaning.
OPTIONS: dict[str, Entry] = {
    "ignore_config_errors": Entry(
        "no", "yes: keep running when the configuration does not match [SETUP]"),
    "auto_start": Entry("yes", "no: after a stop, wait for the Set button before restarting"),
    "map_counters": Entry("no", "yes: counters 0..14 appear in flag bytes 96..125"),
}

OPTION_VALUES = ("yes", "no", "on", "off", "true", "false")

#: The letters of each AS-i I/O code, D0 first (§3.2); F has no letters (tristate).
IO_LETTERS = tuple(IO_CODES)


def io_code_text(code: int) -> str:
    """``1`` -> "1 (iiio: D0 in, D1 in, D2 in, D3 out)"."""
    if not 0 <= code < len(IO_LETTERS):
        return f"{code:X}h (tristate)" if code == 0xF else f"{code}"
    letters = IO_LETTERS[code]
    words = {"i": "in", "o": "out", "b": "in/out"}
    bits = ", ".join(f"D{n} {words[c]}" for n, c in enumerate(letters))
    return f"{code:X}h ({letters}: {bits})"
