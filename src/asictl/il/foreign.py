"""Words of the languages AS-i Control users come from, for hints in diagnostics.

Most users know STEP 5 with German mnemonics (``U E 1.0``, ``= A 2.0``, ``U M 1.1``) or
IEC 61131-3 IL (``LD``, ``ST``); the master's IL is STEP 5 with English mnemonics. A
diagnostic that meets one of these words says what the master's IL calls it (and where
8051 assembler goes, for an assembler line in [PROGRAM]).
"""

from __future__ import annotations

from asictl.mcs51.words import MNEMONICS

#: STEP 5's German operators whose English form differs (O, ON, S, R, L, T, BE are equal).
STEP5_OPERATORS = {
    "U": "A", "UN": "AN", "SPA": "JU", "SPB": "JC", "BEB": "BEC", "BEA": "BEU",
    "ZV": "CU", "ZR": "CD",
}
#: STEP 5's German operand marks: Eingang, Ausgang, Merker, Zähler, and their bytes.
STEP5_OPERANDS = {
    "E": "I", "A": "Q", "M": "F", "Z": "C", "EB": "IB", "AB": "QB", "MB": "FY", "MW": "FW",
}
#: IEC 61131-3 IL operators and what does the same here.
IEC_OPERATORS = {
    "LD": "A", "LDN": "AN", "ST": "=", "AND": "A", "ANDN": "AN", "OR": "O", "ORN": "ON",
    "NOT": "N", "JMP": "JU", "JMPC": "JC", "RET": "BE", "RETC": "BEC", "CAL": "JU FB",
    "CALC": "JC FB", "ADD": "+ F", "SUB": "- F",
}
#: IEC's LD and ST of a constant or a byte load and transfer the accumulator: L and T here.
IEC_BYTE_OPERATORS = {"LD": "L", "ST": "T"}
#: byte and word operands (constants all start with K: KB, KC, KT, KP, ...)
_BYTE_OPERANDS = frozenset({"IB", "I2B", "QB", "FY", "FW"})
_OPERAND_WORDS = frozenset(STEP5_OPERANDS)


def step5_line(code: str) -> str | None:
    """A line of STEP 5 with German mnemonics in the master's IL (None: nothing to say).

    ``U E 1.0`` -> ``A I 1.0``; ``= A 2.0`` -> ``= Q 2.0``; ``SPB = x`` -> ``JC = x``.
    """
    words = code.split()
    if not words:
        return None
    changed = False
    operator = words[0].upper()
    if operator in STEP5_OPERATORS:
        words[0], changed = STEP5_OPERATORS[operator], True
    if len(words) > 1 and words[1].upper() in _OPERAND_WORDS:
        words[1], changed = STEP5_OPERANDS[words[1].upper()], True
    return " ".join(words) if changed else None


def operator_hint(word: str, code: str) -> str | None:
    """What a foreign operator at the start of ``code`` is here, as a phrase."""
    upper = word.upper()
    if upper in STEP5_OPERATORS:
        translated = step5_line(code)
        return (f"STEP 5's German '{word}' is '{STEP5_OPERATORS[upper]}' here"
                + (f": '{translated}'" if translated else ""))
    if upper in IEC_OPERATORS:
        operand = code.split()[1:2]
        if upper in IEC_BYTE_OPERATORS and operand and (
                operand[0].upper().startswith("K") or operand[0].upper() in _BYTE_OPERANDS):
            return (f"IEC 61131-3's '{word}' of a constant or a byte is "
                    f"'{IEC_BYTE_OPERATORS[upper]}' here")
        return f"IEC 61131-3's '{word}' is '{IEC_OPERATORS[upper]}' here"
    if upper in MNEMONICS:
        return "8051 assembler belongs after ASM or in an [ASSEMBLY] section"
    return None


def operand_hint(word: str) -> str | None:
    """What a German operand mark is here, as a phrase."""
    upper = word.upper()
    if upper not in STEP5_OPERANDS:
        return None
    return f"STEP 5's German '{word}' is '{STEP5_OPERANDS[upper]}' here"
