"""The reserved words of the 8051 assembly language: mnemonics, registers, directives.

A module of their own, apart from the instruction-set table and the assembler, because
the IL front end needs them too: a declared IL variable is a symbol of the program's
assembly, so it must not be one of these words, and a diagnostic recognises a mnemonic
written in [PROGRAM]. Checking an IL program then loads these lists, not the assembler.
``tests/mcs51/test_isa.py`` holds the mnemonics to the opcode table.
"""

from __future__ import annotations

#: Every mnemonic of the instruction set.
MNEMONICS = frozenset({
    "ACALL", "ADD", "ADDC", "AJMP", "ANL", "CJNE", "CLR", "CPL", "DA", "DEC", "DIV", "DJNZ",
    "INC", "JB", "JBC", "JC", "JMP", "JNB", "JNC", "JNZ", "JZ", "LCALL", "LJMP", "MOV", "MOVC",
    "MOVX", "MUL", "NOP", "ORL", "POP", "PUSH", "RET", "RETI", "RL", "RLC", "RR", "RRC",
    "SETB", "SJMP", "SUBB", "SWAP", "XCH", "XCHD", "XRL",
})

#: Names of registers; they are operands, never values.
REGISTER_NAMES = frozenset({"A", "AB", "C", "DPTR", "PC", *(f"R{i}" for i in range(8))})

#: Words introducing an ASM51 symbol definition (NAME word value).
DEFINITION_WORDS = frozenset({"EQU", "SET", "BIT", "DATA", "IDATA", "XDATA", "CODE"})

#: The directives of both dialects (ASM51 and as31) and the one each stands for.
DIRECTIVES = {
    "ORG": "ORG",
    "DB": "DB",
    "DW": "DW",
    "DS": "DS",
    "END": "END",
    ".ORG": "ORG",
    ".DB": "DB",
    ".BYTE": "DB",
    ".DW": "DW",
    ".WORD": "DW",
    ".SKIP": "DS",
    ".END": "END",
    ".INC": "INCLUDE",
    ".INCLUDE": "INCLUDE",
}

#: The operators of expressions that are words.
UNARY_WORDS = frozenset({"HIGH", "LOW"})

#: Words that can never name a symbol.
RESERVED = frozenset(
    {*MNEMONICS, "CALL", *REGISTER_NAMES, *DEFINITION_WORDS, *DIRECTIVES, *UNARY_WORDS}
)
