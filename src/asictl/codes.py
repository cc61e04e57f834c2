"""Every diagnostic code asictl reports, one enumeration per stage of the pipeline.

Codes let editors, CI filters and tests tell problems apart without matching message
text, so each is fixed here once and documented in docs/language.md (the assembler's also
in docs/assembler.md); a test holds the documentation and this registry together, and
another that no stage reports a code that is not registered here.

The hundreds are the stages: E1xx reading IL (syntax), E2xx checking it (semantics),
E3xx compiling it, E4xx scenarios and symbol tables, E5xx the 8051 assembler, E6xx program
images, W7xx analysing a checked program (wiring against [SETUP], data flow, reachability).
Warnings (W) share their stage's hundred.
"""

from __future__ import annotations

from enum import StrEnum


class SyntaxCode(StrEnum):
    """Reading IL source (``il.parser``, ``il.syntax_errors``)."""

    UNEXPECTED_CHARACTER = "E101"
    UNEXPECTED_END_OF_LINE = "E102"
    UNEXPECTED_WORD = "E103"
    UNKNOWN_INSTRUCTION = "E104"
    UNKNOWN_SECTION = "E105"
    MISSING_SECTION = "E106"
    NUMBER_TOO_LARGE = "E107"


class CheckCode(StrEnum):
    """Checking a whole program (``il.loader``, ``il.checks``)."""

    OUT_OF_RANGE = "E201"
    ODD_SLAVE_ADDRESS = "E202"
    UNDECLARED_TIMER_OR_COUNTER = "E203"
    DUPLICATE_LABEL = "E205"
    UNKNOWN_LABEL = "E206"
    UNKNOWN_BLOCK = "E207"
    BLOCK_FILE_NOT_FOUND = "E208"
    RECURSION = "E209"
    DUPLICATE_SLAVE = "E210"
    BAD_SETUP = "E211"
    UNKNOWN_OPTION = "E212"
    UNDEFINED_REGISTER = "E213"
    UNDECLARED_VARIABLE = "E214"
    DUPLICATE_DECLARATION = "E215"
    CONTROL2_ONLY = "E216"
    MISPLACED_SECTION = "E217"
    ASSIGNED_TIMER_OR_COUNTER = "E218"
    OPERAND_LIKE_NAME = "E219"
    NAME_TOO_LONG = "E220"
    TOO_MANY_FILES = "E221"
    DUPLICATE_FILE_NAME = "E222"
    LOGIC_AFTER_STORE = "W201"
    TIME_ROUNDED = "W202"
    DUPLICATE_OPTION = "W203"
    BUILTIN_DECLARED = "W204"
    ALWAYS_ZERO = "W205"
    TRANSFER_AFTER_CONSTANT = "W206"
    LANDING_UNDEFINED = "W207"
    ENDLESS_LOOP = "W208"


class AnalysisCode(StrEnum):
    """Analysing a program that checked clean (``il.wiring``, ``il.logic``, ``il.pragmas``).

    W70x: the program against its wiring ([SETUP]); W71x: its logic and data flow;
    W72x: asictl's own comment directives.
    """

    WRONG_DIRECTION = "W701"
    SLAVE_NOT_PROJECTED = "W702"
    NO_SLAVES = "W703"
    SLAVE_COMMAND_NOT_PROJECTED = "W704"
    ASSIGNED_TWICE = "W711"
    SET_NEVER_READ = "W712"
    READ_NEVER_SET = "W713"
    FLAG_NEVER_WRITTEN = "W714"
    UNREACHABLE = "W715"
    LABEL_UNUSED = "W716"
    BLOCK_UNUSED = "W717"
    ANSWER_READ_EARLY = "W718"
    BAD_DIRECTIVE = "W721"


class CompileCode(StrEnum):
    """Compiling a checked program (``codegen8051``, ``build``)."""

    DATA_TOO_LARGE = "E301"
    CODE_TOO_LARGE = "E302"
    IMAGE_TOO_LARGE = "E303"


class ScenarioCode(StrEnum):
    """Reading and running scenarios (``sim``), the symbol tables they use, and the other
    TOML inputs (a plant's inventory, ``fleet``)."""

    NOT_TOML = "E400"
    INVALID = "E401"
    NO_SUCH_SLAVE = "E402"
    SYMBOLS = "E403"
    INVENTORY = "E404"
    PROPERTIES = "E405"
    UNMODELLED = "E406"
    UNKNOWN_KEY = "E407"
    #: a condition (docs/conditions.md) that cannot be read, in any file that holds one
    CONDITION = "E410"
    #: an operand a property or [assume] names that the program and its bus do not have
    NO_SUCH_OPERAND = "E430"
    #: a never/always property no cycle of the program can change: the environment decides
    ENVIRONMENT_ONLY = "W431"


class AssemblerCode(StrEnum):
    """The 8051 assembler (``mcs51``), also for [ASSEMBLY] sections."""

    SYNTAX = "E501"
    UNKNOWN_MNEMONIC = "E502"
    BAD_OPERAND = "E503"
    OUT_OF_RANGE = "E504"
    JUMP_TOO_FAR = "E505"
    OTHER_PAGE = "E506"
    UNDEFINED = "E507"
    DUPLICATE = "E508"
    NOT_BIT_ADDRESSABLE = "E509"
    OVERLAP = "E510"
    INCLUDE = "E511"
    EXPRESSION = "E512"
    AMBIGUOUS_PRECEDENCE = "E513"
    NOT_YET_KNOWN = "E514"
    TYPE_MISMATCH = "W501"
    AFTER_END = "W502"


class ImageCode(StrEnum):
    """Program images in program files (``build``)."""

    RAW_INVALID = "E601"
    RAW_MISMATCH = "E602"
    RAW_HEX = "E603"


#: A short title of each code, as docs/language.md's table of all codes shows it.
TITLES: dict[str, str] = {
    "E101": "unexpected character",
    "E102": "unexpected end of line",
    "E103": "unexpected word",
    "E104": "unknown instruction",
    "E105": "unknown section title",
    "E106": "missing section title",
    "E107": "number too large",
    "E201": "value out of range",
    "E202": "odd slave address in a byte operand",
    "E203": "undeclared timer or counter",
    "E205": "label defined twice",
    "E206": "jump to an unknown label",
    "E207": "unknown function block",
    "E208": "function block file not found",
    "E209": "recursive function block call",
    "E210": "slave set up twice",
    "E211": "invalid slave setup",
    "E212": "unknown option",
    "E213": "register read while undefined",
    "E214": "undeclared variable",
    "E215": "name declared twice",
    "E216": "AS-i Control II only",
    "E217": "section not allowed here",
    "E218": "'=' on a timer or counter",
    "E219": "variable named like an operand",
    "E220": "name too long for the image",
    "E221": "too many source files for the image",
    "E222": "two source files of one name",
    "W201": "logic continues after a store",
    "W202": "time rounded to 10 ms",
    "W203": "option given twice",
    "W204": "built-in timer or counter declared",
    "W205": "register always 0 after a JC that did not jump",
    "W206": "T right after L KT, L KC or L KP",
    "W207": "jump lands on a combining A/O with the register undefined",
    "W208": "loop no cycle leaves once it jumps",
    "E301": "program data too large",
    "E302": "program code too large",
    "E303": "image too large for the EEPROM",
    "E400": "file is not valid TOML",
    "E401": "invalid scenario",
    "E402": "scenario sets or expects a slave that is not on the bus",
    "E403": "invalid symbol table",
    "E404": "invalid plant inventory",
    "E405": "invalid properties file",
    "E406": "construct the prover cannot model",
    "E407": "unknown key in a TOML file",
    "E410": "condition that cannot be read",
    "E430": "property names an operand the program or its bus lacks",
    "W431": "property decided by the environment alone",
    "E501": "syntax",
    "E502": "unknown mnemonic or directive",
    "E503": "operand not valid for the instruction",
    "E504": "value out of range",
    "E505": "relative jump too far",
    "E506": "AJMP/ACALL outside the 2 KB page",
    "E507": "undefined symbol",
    "E508": "duplicate symbol",
    "E509": "byte is not bit-addressable",
    "E510": "overlapping code, code past FFFFh",
    "E511": "include problem",
    "E512": "expression cannot be evaluated",
    "E513": "precedence differs between as31 and ASM51",
    "E514": "ORG/DS value not known yet",
    "W501": "bit name used as a byte address, or the reverse",
    "W502": "text after END",
    "E601": "invalid [RAW] image",
    "E602": "[OPTIONS] or [SETUP] do not match the [RAW] image",
    "E603": "invalid raw image HEX file",
    "W701": "I/O operand against the slave's I/O code",
    "W702": "slave not in [SETUP]",
    "W703": "no slave in [SETUP]",
    "W704": "parameter or command for a slave not in [SETUP]",
    "W711": "bit assigned with '=' in two places",
    "W712": "timer or counter set but never read",
    "W713": "timer or counter read but never set",
    "W714": "flag read but never written",
    "W715": "unreachable code",
    "W716": "label never jumped to",
    "W717": "function block never called",
    "W718": "slave's answer read in the cycle that asked for it",
    "W721": "invalid asictl directive",
}

#: The registry: every stage's codes.
STAGES: tuple[type[StrEnum], ...] = (
    SyntaxCode, CheckCode, CompileCode, ScenarioCode, AssemblerCode, ImageCode, AnalysisCode,
)


def all_codes() -> dict[str, StrEnum]:
    """Code -> its member, over all stages."""
    return {member.value: member for stage in STAGES for member in stage}
