"""The 8051 assembler: Intel ASM51 and as31 source in, an ``Assembly`` out.

Two passes. Every 8051 instruction's length follows from its addressing modes alone
(the generic ``JMP``/``CALL`` always become ``LJMP``/``LCALL``), so the first pass can
size everything and place the labels, and the second only evaluates and encodes.
Symbols defined with EQU and its relatives are evaluated when first needed, which
lets them refer forward to labels and to each other in any order.

A program that builds its code as objects (the IL compiler) hands it over parsed
already (``ParsedSource``): its lines are assembled as they are, not written out and
read back, and ``locate`` runs the first pass alone, so such a program can see where
its code lands before choosing the forms of its jumps.

All problems of all files are collected and raised together as one
``DiagnosticError``; nothing is returned when any of them is an error.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from asictl.diagnostics import DiagnosticError, Reporter, Span
from asictl.errors import UserError
from asictl.mcs51.asm_errors import AsmError, Code
from asictl.mcs51.asm_expr import (
    BitSelect,
    Env,
    Expr,
    SymbolRef,
    Undefined,
    format_hex,
    operator_count,
)
from asictl.mcs51.asm_parser import (
    DataString,
    Definition,
    Directive,
    Instruction,
    ParsedLine,
    ParsedOperand,
    Shape,
    parse_line,
)
from asictl.mcs51.assembly import Assembly, ListingEntry, Symbol
from asictl.mcs51.isa import OPCODES, REGISTERS, SFR_BITS, SFRS, OpcodeInfo, Operand
from asictl.mcs51.words import RESERVED
from asictl.source import SourceText, from_string, read_source

__all__ = [
    "Assembly",
    "Layout",
    "ListingEntry",
    "ParsedSource",
    "Symbol",
    "assemble",
    "assemble_text",
    "locate",
]

#: Loads an included file: (name as written, the including source) -> its text.
IncludeLoader = Callable[[str, SourceText], SourceText]

_MAX_INCLUDE_DEPTH = 16
_ADDRESS_LIMIT = 0x10000
#: Symbols are evaluated on first use, recursively; this bounds the evaluation's depth (in
#: operators and symbols) well inside Python's stack, however the definitions chain.
_MAX_NESTING = 400

# Range of each operand kind's value; negative immediates are two's complement.
_RANGES: dict[Operand, tuple[int, int, str]] = {
    Operand.IMM: (-0x80, 0xFF, "#data"),
    Operand.IMM16: (-0x8000, 0xFFFF, "#data16"),
    Operand.DIRECT: (0, 0xFF, "a direct address"),
    Operand.BIT: (0, 0xFF, "a bit address"),
    Operand.NBIT: (0, 0xFF, "a bit address"),
    Operand.ADDR16: (0, 0xFFFF, "a code address"),
    Operand.ADDR11: (0, 0xFFFF, "a code address"),
    Operand.REL: (-0x8000, 0xFFFF, "a code address"),
}
_DEFINITION_RANGES: dict[str, tuple[int, int, str]] = {
    "BIT": (0, 0xFF, "a bit address"),
    "DATA": (0, 0xFF, "a data address"),
    "IDATA": (0, 0xFF, "an idata address"),
    "XDATA": (0, 0xFFFF, "an xdata address"),
    "CODE": (0, 0xFFFF, "a code address"),
}
_DB_RANGE = (-0x80, 0xFF, "a byte")
_DW_RANGE = (-0x8000, 0xFFFF, "a word")

_BIT_KINDS = frozenset({"BIT", "SFR bit"})
_BYTE_KINDS = frozenset({"DATA", "IDATA", "SFR"})

_ORDINALS = ("first", "second", "third")


def _shape_of(kind: Operand) -> Shape:
    if kind in (Operand.IMM, Operand.IMM16):
        return Shape.IMMEDIATE
    if kind is Operand.NBIT:
        return Shape.NOT_BIT
    return Shape.VALUE if kind.size else Shape.REGISTER


def _key(kind: Operand) -> Operand | Shape:
    """What of an operand kind shows in the source: the register itself, or a shape."""
    return kind if kind.is_fixed else _shape_of(kind)


def _written_key(operand: ParsedOperand) -> Operand | Shape:
    return operand.register if operand.register is not None else operand.shape


#: mnemonic -> its forms, for explaining why written operands fit none of them.
_FORMS: dict[str, list[OpcodeInfo]] = {}
#: (mnemonic, operand keys) -> the one opcode written that way. AJMP and ACALL map to
#: their first opcode (01h, 11h); encoding ORs in bits 10-8 of the target.
_BY_KEYS: dict[tuple[str, tuple[Operand | Shape, ...]], OpcodeInfo] = {}
for _info in OPCODES:
    if _info is not None:
        _keys = (_info.mnemonic, tuple(_key(kind) for kind in _info.operands))
        if _keys not in _BY_KEYS:
            _BY_KEYS[_keys] = _info
            _FORMS.setdefault(_info.mnemonic, []).append(_info)
# ASM51's generic JMP and CALL to an address are always the long forms, so that their
# size is known before their target.
for _generic, _long in (("JMP", "LJMP"), ("CALL", "LCALL")):
    _BY_KEYS[(_generic, (Shape.VALUE,))] = _BY_KEYS[(_long, (Shape.VALUE,))]
    _FORMS.setdefault(_generic, []).extend(_FORMS[_long])


def _fits(kind: Operand, operand: ParsedOperand) -> bool:
    return _key(kind) == _written_key(operand)


def _describe(kinds: set[Operand]) -> str:
    """Operand kinds for an error message, with R0..R7 and @R0/@R1 folded."""
    names = []
    for kind in sorted(kinds, key=lambda k: list(Operand).index(k)):
        if kind in REGISTERS:
            name = "Rn"
        elif kind in (Operand.AT_R0, Operand.AT_R1):
            name = "@Ri"
        else:
            name = kind.value
        if name not in names:
            names.append(name)
    return ", ".join(names)


@dataclass(frozen=True)
class ParsedSource:
    """A source whose lines a program has parsed already, one per line of its text: the
    text is what the listing and the diagnostics show, ``lines`` what is assembled."""

    source: SourceText
    lines: Sequence[ParsedLine]


@dataclass
class Layout:
    """Where the first pass put things: the address of each line of the first source (up
    to its END) and the value of every label, by its upper-case name.

    ``assemble`` finishes the assembly from here (once), so a caller that accepts the
    layout it sees does not run the first pass again."""

    addresses: tuple[int, ...]
    labels: Mapping[str, int]
    _assembler: _Assembler | None = field(default=None, repr=False)

    def assemble(self) -> Assembly:
        """The second pass over what was located. Raises ``DiagnosticError``."""
        if self._assembler is None:
            raise RuntimeError("this layout has been assembled already")
        asm, self._assembler = self._assembler, None
        return _second_pass(asm)


@dataclass(slots=True)
class _SymbolEntry:
    name: str
    kind: str
    span: Span | None
    value: int | None = None
    #: A definition not yet evaluated: its expression and the location counter there.
    expr: Expr | None = None
    here: int = 0
    resolving: bool = False
    #: Its definition had an error (already reported): uses fail without a second one.
    failed: bool = False


class _Reported(Exception):
    """The problem has been reported already; abandon the statement silently."""


@dataclass(slots=True)
class _Line:
    source: SourceText
    number: int
    text: str
    parsed: ParsedLine
    address: int = 0
    info: OpcodeInfo | None = None
    size: int = 0

    def span(self, column: int = 1, length: int = 1) -> Span:
        return Span(self.source.name, self.number, column, length)


@dataclass
class _Assembler:
    loader: IncludeLoader
    reporter: Reporter = field(default_factory=Reporter)
    symbols: dict[str, _SymbolEntry] = field(default_factory=dict)
    lines: list[_Line] = field(default_factory=list)
    memory: bytearray = field(default_factory=lambda: bytearray(_ADDRESS_LIMIT))
    used: bytearray = field(default_factory=lambda: bytearray(_ADDRESS_LIMIT))
    listing: list[ListingEntry] = field(default_factory=list)
    location: int = 0
    #: How deep the symbol definitions being evaluated nest now (see ``_MAX_NESTING``).
    nesting: int = 0

    # ----- diagnostics -----

    def error(
        self, line: _Line, code: Code, message: str, column: int = 1, length: int = 1
    ) -> None:
        self.reporter.error(code, message, line.span(column, length))

    def report(self, line: _Line, exc: AsmError) -> None:
        self.error(line, exc.code, exc.message, exc.column, exc.length)

    # ----- symbols -----

    def predefine(self, names: Mapping[str, int], kind: str) -> None:
        for name, value in names.items():
            self.symbols[name.upper()] = _SymbolEntry(name, kind, None, value)

    def define(
        self,
        line: _Line,
        name: str,
        column: int,
        kind: str,
        value: int | None,
        expr: Expr | None = None,
    ) -> None:
        key = name.upper()
        span = line.span(column, len(name))
        old = self.symbols.get(key)
        if old is not None and not self.may_redefine(old, kind, value, expr):
            where = f"at {old.span}" if old.span else f"as {format_hex(old.value or 0)}"
            pre = "predefined" if old.span is None else "already defined"
            message = f"symbol '{name}' is {pre} {where}"
            self.error(line, Code.DUPLICATE, message, column, len(name))
            return
        self.symbols[key] = _SymbolEntry(name, kind, span, value, expr, self.location)

    def may_redefine(
        self, old: _SymbolEntry, kind: str, value: int | None, expr: Expr | None
    ) -> bool:
        """SET may follow SET; an SFR may be restated with its own address (as headers do)."""
        if kind == "SET" and old.kind == "SET":
            return True
        if not old.kind.startswith("SFR"):
            return False
        if value is None and expr is not None:
            try:
                value = self.evaluate(expr)
            except (AsmError, _Reported):
                return False
        return value == old.value

    def lookup(self, name: str, column: int) -> int:
        entry = self.symbols.get(name.upper())
        if entry is None:
            raise Undefined(name, column)
        if entry.failed:
            raise _Reported
        if entry.value is None:
            if entry.expr is None:  # a SET symbol before its first SET in this pass
                raise Undefined(name, column)
            if entry.resolving:
                raise AsmError(
                    f"symbol '{entry.name}' is defined in terms of itself",
                    column,
                    len(name),
                    Code.EXPRESSION,
                )
            depth = operator_count(entry.expr) + 1
            if self.nesting + depth > _MAX_NESTING:
                raise AsmError(
                    f"symbol '{name}': definitions in terms of later ones nest too deeply "
                    "(define symbols before their use)",
                    column,
                    len(name),
                    Code.EXPRESSION,
                )
            entry.resolving = True
            self.nesting += depth
            try:
                entry.value = entry.expr.value(Env(self.lookup, entry.here))
            except Undefined:
                raise
            except AsmError as exc:
                self.report_at_definition(entry, exc)
                raise _Reported from None
            finally:
                entry.resolving = False
                self.nesting -= depth
        return entry.value

    def report_at_definition(self, entry: _SymbolEntry, exc: AsmError) -> None:
        """A problem in a symbol's own expression belongs to the line that defines it,
        not to the line that happened to use the symbol first."""
        entry.failed = True
        assert entry.span is not None  # only source definitions have an expression
        where = Span(entry.span.file, entry.span.line, exc.column, exc.length)
        self.reporter.error(exc.code, exc.message, where)

    def evaluate(self, expr: Expr) -> int:
        return expr.value(Env(self.lookup, self.location))

    # ----- pass 1: parse, size, place labels -----

    def read(
        self,
        source: SourceText,
        including: tuple[str, ...] = (),
        parsed: Sequence[ParsedLine] | None = None,
    ) -> None:
        """Pass 1 over one file; ``including`` are the files whose includes led here, and
        ``parsed`` its lines when the caller has parsed them already."""
        text_lines = source.text.split("\n")
        if text_lines and text_lines[-1] == "":
            text_lines.pop()
        if parsed is not None and len(parsed) != len(text_lines):
            raise ValueError(f"{source.name}: {len(parsed)} parsed lines for {len(text_lines)}")
        for number, text in enumerate(text_lines, start=1):
            read = parse_line(text) if parsed is None else parsed[number - 1]
            line = _Line(source, number, text, read, self.location)
            self.lines.append(line)
            if line.parsed.error is not None:
                self.report(line, line.parsed.error)
            self.size(line)
            statement = line.parsed.statement
            if isinstance(statement, Directive) and statement.name == "END":
                self.warn_trailing(source, text_lines, number)
                return
            if isinstance(statement, Directive) and statement.name == "INCLUDE":
                self.include(line, statement, (*including, source.name))

    def warn_trailing(self, source: SourceText, text_lines: list[str], end_line: int) -> None:
        for number in range(end_line + 1, len(text_lines) + 1):
            if text_lines[number - 1].split(";", 1)[0].strip():
                self.reporter.warning(
                    Code.AFTER_END, "text after END is ignored", Span(source.name, number, 1, 1)
                )
                return

    def include(self, line: _Line, directive: Directive, chain: tuple[str, ...]) -> None:
        length = len(line.text.rstrip()) - directive.column + 1
        if len(chain) > _MAX_INCLUDE_DEPTH:
            message = f"includes nested deeper than {_MAX_INCLUDE_DEPTH} levels"
            self.error(line, Code.INCLUDE, message, directive.column, length)
            return
        try:
            included = self.loader(directive.text, line.source)
        except UserError as exc:
            self.error(line, Code.INCLUDE, str(exc), directive.column, length)
            return
        if included.name in chain:
            message = f"{included.name} includes itself"
            self.error(line, Code.INCLUDE, message, directive.column, length)
            return
        self.read(included, chain)

    def size(self, line: _Line) -> None:
        """Pass 1 for one line: define its label, size it, move the location counter."""
        label, statement = line.parsed.label, line.parsed.statement
        line.address = self.location
        if label is not None:
            self.define(line, label.name, label.column, "label", self.location)
        try:
            if isinstance(statement, Instruction):
                line.info = self.select_form(statement)
                line.size = line.info.length
            elif isinstance(statement, Definition):
                self.define_statement(line, statement)
            elif isinstance(statement, Directive):
                self.size_directive(line, statement)
        except AsmError as exc:
            self.report(line, exc)
        except _Reported:
            pass
        self.location += line.size
        if self.location > _ADDRESS_LIMIT:
            message = f"code runs past the end of the 64 KB code space (to {self.location - 1:X}h)"
            self.error(line, Code.OVERLAP, message)
            self.location &= 0xFFFF

    def define_statement(self, line: _Line, definition: Definition) -> None:
        if definition.kind == "SET":
            try:
                value = self.evaluate(definition.expr)
            except (AsmError, _Reported):
                value = None  # settled (and reported) in pass 2, where every label is known
            self.define(line, definition.name, definition.column, "SET", value)
        else:
            self.define(
                line, definition.name, definition.column, definition.kind, None, definition.expr
            )

    def size_directive(self, line: _Line, directive: Directive) -> None:
        if directive.name in ("ORG", "DS"):
            expr = directive.args[0]
            assert not isinstance(expr, DataString)
            try:
                value = self.evaluate(expr)
            except Undefined as exc:
                raise AsmError(
                    f"{directive.name} needs a value known at this point; "
                    f"'{exc.name}' is defined later or not at all",
                    expr.column,
                    expr.length,
                    Code.NOT_YET_KNOWN,
                ) from None
            if directive.name == "ORG":
                self.check_range(value, expr, (0, 0xFFFF, "an address"))
                self.location = line.address = value
            else:
                self.check_range(value, expr, (0, 0xFFFF, "a byte count"))
                line.size = value
        elif directive.name in ("DB", "DW"):
            width = 1 if directive.name == "DB" else 2
            line.size = sum(
                len(arg.data) if isinstance(arg, DataString) else width for arg in directive.args
            )

    def select_form(self, insn: Instruction) -> OpcodeInfo:
        """The opcode whose operand kinds fit the written operands, or a located error."""
        operands = insn.operands
        found = _BY_KEYS.get((insn.mnemonic, tuple(_written_key(op) for op in operands)))
        if found is not None:
            return found
        forms = _FORMS[insn.mnemonic]
        counts = sorted({len(f.operands) for f in forms})
        candidates = [f for f in forms if len(f.operands) == len(operands)]
        if not candidates:
            wanted = " or ".join(str(c) for c in counts)
            plural = "" if counts == [1] else "s"
            raise AsmError(
                f"{insn.mnemonic} takes {wanted} operand{plural}, not {len(operands)}",
                insn.column,
                len(insn.mnemonic),
                Code.BAD_OPERAND,
            )
        for position, operand in enumerate(operands):
            fitting = [f for f in candidates if _fits(f.operands[position], operand)]
            if not fitting:
                expected = _describe({f.operands[position] for f in candidates})
                raise AsmError(
                    f"{insn.mnemonic} cannot take '{operand.text}' as its "
                    f"{_ORDINALS[position]} operand here; expected {expected}",
                    operand.column,
                    operand.length,
                    Code.BAD_OPERAND,
                )
            candidates = fitting
        return candidates[0]

    # ----- pass 2: evaluate and encode -----

    def settle_definitions(self) -> None:
        """Evaluate every EQU-like definition at its own line, so errors point there."""
        for line in self.lines:
            statement = line.parsed.statement
            if not isinstance(statement, Definition) or statement.kind == "SET":
                continue
            entry = self.symbols.get(statement.name.upper())
            if entry is None or entry.span != line.span(statement.column, len(statement.name)):
                continue  # a rejected duplicate
            try:
                value = self.lookup(statement.name, statement.column)
                limits = _DEFINITION_RANGES.get(statement.kind)
                if limits:
                    self.check_range(value, statement.expr, limits)
            except AsmError as exc:
                self.report(line, exc)
                entry.failed = True
            except _Reported:
                entry.failed = True

    def emit_all(self) -> None:
        for entry in self.symbols.values():
            if entry.kind == "SET":
                entry.value = None  # replayed in source order below
        for line in self.lines:
            self.location = line.address
            data = b""
            statement = line.parsed.statement
            try:
                if isinstance(statement, Instruction) and line.info is not None:
                    data = self.encode(line, statement, line.info)
                elif isinstance(statement, Directive) and statement.name in ("DB", "DW"):
                    data = self.encode_data(line, statement)
                elif isinstance(statement, Definition) and statement.kind == "SET":
                    entry = self.symbols[statement.name.upper()]
                    if entry.kind == "SET":  # not a rejected redefinition of another symbol
                        entry.value = self.evaluate(statement.expr)
            except AsmError as exc:
                self.report(line, exc)
            except _Reported:
                pass
            if data and statement is not None:
                self.place(line, statement.column, data)
            self.listing.append(self.listing_entry(line, statement, data))

    def listing_entry(self, line: _Line, statement: object, data: bytes) -> ListingEntry:
        has_address = (
            data
            or line.size
            or line.parsed.label
            or (isinstance(statement, Directive) and statement.name == "ORG")
        )
        return ListingEntry(
            address=line.address if has_address else None,
            data=data,
            cycles=line.info.cycles if line.info is not None and data else None,
            span=Span(line.source.name, line.number, 1, max(1, len(line.text))),
            text=line.text,
        )

    def place(self, line: _Line, column: int, data: bytes) -> None:
        start = line.address
        if start + len(data) > _ADDRESS_LIMIT:
            return  # reported in pass 1
        clash = self.used.find(1, start, start + len(data))
        if clash >= 0:
            earlier = next(
                e
                for e in self.listing
                if e.data and e.address is not None and e.address <= clash < e.address + len(e.data)
            )
            self.error(
                line,
                Code.OVERLAP,
                f"code at {clash:04X}h overlaps code already placed there by "
                f"{earlier.span.file}:{earlier.span.line}",
                column,
            )
            return
        self.memory[start : start + len(data)] = data
        self.used[start : start + len(data)] = b"\x01" * len(data)

    def check_range(self, value: int, expr: Expr, limits: tuple[int, int, str]) -> None:
        low, high, what = limits
        if not low <= value <= high:
            raise AsmError(
                f"value {format_hex(value)} is out of range for {what} "
                f"({format_hex(low)}..{format_hex(high)})",
                expr.column,
                expr.length,
                Code.OUT_OF_RANGE,
            )

    def encode(self, line: _Line, insn: Instruction, info: OpcodeInfo) -> bytes:
        opcode = info.opcode
        out = bytearray()
        problems: list[AsmError] = []
        for index in info.encoding:
            kind = info.operands[index]
            operand = insn.operands[index]
            assert operand.expr is not None
            try:
                value = self.evaluate(operand.expr)
                self.check_range(value, operand.expr, _RANGES[kind])
                self.check_type(line, operand, kind)
                if kind is Operand.REL:
                    out.append(self.relative(line, info, value, operand.expr))
                elif kind is Operand.ADDR11:
                    opcode |= self.page_bits(line, info, value, operand.expr)
                    out.append(value & 0xFF)
                elif kind in (Operand.IMM16, Operand.ADDR16):
                    out += (value & 0xFFFF).to_bytes(2, "big")
                else:
                    out.append(value & 0xFF)
            except AsmError as exc:
                problems.append(exc)
        for problem in problems:
            self.report(line, problem)
        if problems:
            raise _Reported
        return bytes([opcode]) + out

    def relative(self, line: _Line, info: OpcodeInfo, target: int, expr: Expr) -> int:
        """The rel byte reaching ``target``; the program counter wraps at 64 KB."""
        target &= 0xFFFF
        offset = (target - line.address - info.length + 0x8000) % 0x10000 - 0x8000
        if not -128 <= offset <= 127:
            excess = offset - 127 if offset > 0 else -128 - offset
            raise AsmError(
                f"{info.mnemonic} target {target:04X}h is {excess} byte{'s' * (excess != 1)} "
                f"out of range (offset {offset:+d}, reach -128..+127)",
                expr.column,
                expr.length,
                Code.JUMP_TOO_FAR,
            )
        return offset & 0xFF

    def page_bits(self, line: _Line, info: OpcodeInfo, target: int, expr: Expr) -> int:
        """Bits 10-8 of an AJMP/ACALL target, which must be in the next instruction's page."""
        page = (line.address + info.length) & 0xF800  # also drops a carry out of bit 15
        if target & 0xF800 != page:
            raise AsmError(
                f"{info.mnemonic} target {target:04X}h is outside the 2 KB page "
                f"{page:04X}h..{page + 0x7FF:04X}h; use L{info.mnemonic[1:]}",
                expr.column,
                expr.length,
                Code.OTHER_PAGE,
            )
        return (target >> 3) & 0xE0

    def check_type(self, line: _Line, operand: ParsedOperand, kind: Operand) -> None:
        """Warn when a bit name is used as a byte address or a byte name as a bit."""
        expr = operand.expr
        if isinstance(expr, BitSelect):
            symbol_kind = "BIT"
        elif isinstance(expr, SymbolRef) and expr.name.upper() in self.symbols:
            symbol_kind = self.symbols[expr.name.upper()].kind
        else:
            return
        if kind is Operand.DIRECT and symbol_kind in _BIT_KINDS:
            message = f"'{operand.text}' is a bit address, used here as a byte address"
        elif kind in (Operand.BIT, Operand.NBIT) and symbol_kind in _BYTE_KINDS:
            message = f"'{operand.text}' is a byte address, used here as a bit address"
        else:
            return
        self.reporter.warning(
            Code.TYPE_MISMATCH, message, line.span(operand.column, operand.length)
        )

    def encode_data(self, line: _Line, directive: Directive) -> bytes:
        out = bytearray()
        word = directive.name == "DW"
        for arg in directive.args:
            if isinstance(arg, DataString):
                out += arg.data
                continue
            value = self.evaluate(arg)
            self.check_range(value, arg, _DW_RANGE if word else _DB_RANGE)
            out += (value & 0xFFFF).to_bytes(2, "big") if word else bytes([value & 0xFF])
        return bytes(out)

    # ----- result -----

    def segments(self) -> Iterator[tuple[int, bytes]]:
        address = self.used.find(1)
        while address >= 0:
            end = self.used.find(0, address)
            end = _ADDRESS_LIMIT if end < 0 else end
            yield address, bytes(self.memory[address:end])
            address = self.used.find(1, end)

    def user_symbols(self) -> dict[str, Symbol]:
        return {
            key: Symbol(e.name, e.value, e.kind, e.span)
            for key, e in self.symbols.items()
            if not e.kind.startswith("SFR") and e.value is not None and not e.failed
        }


def load_relative(name: str, including: SourceText) -> SourceText:
    """Find an included file next to the file that includes it (or as given, if absolute)."""
    return read_source(Path(including.name).parent / name)


Source = SourceText | ParsedSource


def _first_pass(
    sources: Source | Sequence[Source],
    predefined: Mapping[str, int] | None,
    include: IncludeLoader,
) -> _Assembler:
    if isinstance(sources, SourceText | ParsedSource):
        sources = [sources]
    asm = _Assembler(include)
    asm.predefine(SFRS, "SFR")
    asm.predefine(SFR_BITS, "SFR bit")
    if predefined:
        reserved = sorted(name for name in predefined if name.upper() in RESERVED)
        if reserved:
            raise ValueError(f"reserved words cannot be predefined: {', '.join(reserved)}")
        asm.predefine(predefined, "predefined")
    for source in sources:
        if isinstance(source, ParsedSource):
            asm.read(source.source, parsed=source.lines)
        else:
            asm.read(source)
    return asm


def locate(
    sources: Source | Sequence[Source],
    *,
    predefined: Mapping[str, int] | None = None,
    include: IncludeLoader = load_relative,
) -> Layout:
    """The first pass alone: where each line of the first source goes, and every label.

    Problems are not reported here (``assemble`` reports them); a line that has one
    takes no room.
    """
    asm = _first_pass(sources, predefined, include)
    first = asm.lines[0].source if asm.lines else None
    return Layout(
        addresses=tuple(line.address for line in asm.lines if line.source is first),
        labels={
            name: entry.value
            for name, entry in asm.symbols.items()
            if entry.kind == "label" and entry.value is not None
        },
        _assembler=asm,
    )


def assemble(
    sources: Source | Sequence[Source],
    *,
    predefined: Mapping[str, int] | None = None,
    include: IncludeLoader = load_relative,
) -> Assembly:
    """Assemble one source, or several as one unit (in order, sharing symbols).

    ``predefined`` adds symbols (e.g. addresses the caller has laid out); they may
    replace SFR names but not reserved words. ``END`` ends the file it is in.
    Raises ``DiagnosticError`` with every problem found if any is an error.
    """
    return _second_pass(_first_pass(sources, predefined, include))


def _second_pass(asm: _Assembler) -> Assembly:
    asm.settle_definitions()
    asm.emit_all()
    if asm.reporter.has_errors:
        raise DiagnosticError(asm.reporter.diagnostics)
    return Assembly(
        segments=tuple(asm.segments()),
        symbols=asm.user_symbols(),
        listing=tuple(asm.listing),
        diagnostics=tuple(asm.reporter.diagnostics),
    )


def assemble_text(
    text: str, name: str = "<input>", *, predefined: Mapping[str, int] | None = None
) -> Assembly:
    """Assemble source held in a string, as generated code and tests have it."""
    return assemble(from_string(name, text), predefined=predefined)
