"""Hypothesis strategies for valid IL programs, as typed ASTs (``asictl.il.ast``).

The programs are valid beyond syntax too, so that tests of later stages can reuse them:
operands are in range, variables, timers and counters above 14 are declared before use,
jumps go to labels of the same program, stores and transfers write only writable
images, and every logic string starts with A/AN/O/ON (first check). Spans are left out
(None): they do not take part in equality.

``modules()`` draws a whole file; the smaller strategies compose it. What a program may
refer to depends on its declarations (a ``Scope``); the strategies that need one are
composites drawing from module-level strategies, because hypothesis validates every new
strategy object on first use and building strategies per scope made drawing ten times
slower.
"""

from __future__ import annotations

from dataclasses import dataclass

from hypothesis import assume
from hypothesis import strategies as st

from asictl.il import ast
from asictl.il.checks import check_program
from asictl.il.loader import Program
from asictl.il.parser import RESERVED

FIRMWARE_BLOCKS = (
    "SetPP", "GetPP", "SendPrm", "GetPI", "GetPCD", "GetCDI", "GetLPS", "GetLAS", "GetLDS",
    "DataEx", "Address", "AutoAddr", "Command", "RdEeprom", "WrEeprom", "GetId",
)
OPTION_NAMES = ("auto_start", "ignore_config_errors", "map_counters")
_MARK_PREFIXES = ("I2B", "IB", "QB", "FY", "FW", "PSEG", "KT", "KC", "KP", "KB", "KW",
                  "I2", "I", "Q", "F", "T", "C")


def is_plain_name(name: str) -> bool:
    """Not a keyword, and not a mark glued to a number (``T1`` reads as timer 1)."""
    upper = name.upper()
    if upper in RESERVED:
        return False
    return not any(upper.startswith(m) and upper[len(m):][:1].isdigit() for m in _MARK_PREFIXES)


names = st.from_regex(r"[A-Za-z][A-Za-z0-9_]{0,9}", fullmatch=True).filter(is_plain_name)
file_names = st.from_regex(r"[a-z][a-z0-9_]{0,7}\.fb", fullmatch=True)
asm_texts = st.sampled_from(
    ["nop", "clr c", "setb c", "mov a,#12h", "inc r0", "mov r7,a", "cpl a", "rl a"]
)


# ------------------------------------------------------------------------ operands

K = ast.OperandKind
W = ast.Width
operand = ast.Operand.of


def _image_bits(kinds: list[ast.OperandKind], addresses: int, bits: int) -> st.SearchStrategy:
    return st.builds(operand, st.sampled_from(kinds), st.integers(0, addresses),
                     st.integers(0, bits))


slave_bits = _image_bits([K.I, K.I2, K.Q], 31, 3)
output_bits = _image_bits([K.Q], 31, 3)
flag_bits = _image_bits([K.F], 127, 7)
image_bits = slave_bits | flag_bits

constants = st.one_of(
    st.builds(operand, st.just(K.KT), st.integers(0, 4095).map(lambda ticks: ticks * 10)),
    st.builds(operand, st.just(K.KC), st.integers(0, 4095)),
    st.builds(operand, st.just(K.KB), st.integers(0, 255)),
    st.builds(operand, st.just(K.KW), st.integers(0, 65535)),
)
param_constants = st.builds(operand, st.just(K.KP), st.integers(0, 31), st.integers(0, 15))

_even_slaves = st.integers(0, 15).map(lambda n: 2 * n)
_memory_bytes = st.builds(operand, st.just(K.FY), st.integers(0, 127)) | (
    st.builds(operand, st.just(K.PSEG), st.integers(0, 15)))
readable_bytes = st.builds(operand, st.sampled_from([K.IB, K.I2B, K.QB]),
                           _even_slaves) | _memory_bytes
writable_bytes = st.builds(operand, st.just(K.QB), _even_slaves) | _memory_bytes
flag_words = st.builds(operand, st.just(K.FW), st.integers(0, 126))

_always = st.integers(0, 14)
_bits = st.integers(0, 7)


@dataclass(frozen=True)
class Scope:
    """What a program may refer to: declared variables (name -> size), timers, counters."""

    variables: tuple[tuple[str, int], ...] = ()
    timers: tuple[int, ...] = ()
    counters: tuple[int, ...] = ()


@st.composite
def timer_refs(draw: st.DrawFn, scope: Scope, width: ast.Width = W.BIT) -> ast.Operand:
    declared = st.sampled_from(scope.timers) if scope.timers else _always
    return operand(K.T, draw(_always | declared), width=width)


@st.composite
def counter_refs(draw: st.DrawFn, scope: Scope, width: ast.Width = W.BIT) -> ast.Operand:
    declared = st.sampled_from(scope.counters) if scope.counters else _always
    return operand(K.C, draw(_always | declared), width=width)


@st.composite
def var_bits(draw: st.DrawFn, scope: Scope) -> ast.Operand:
    name, size = draw(st.sampled_from(scope.variables))
    return operand(K.VAR, draw(st.integers(0, size - 1)), draw(_bits), name=name)


@st.composite
def var_bytes(draw: st.DrawFn, scope: Scope) -> ast.Operand:
    name, size = draw(st.sampled_from(scope.variables))
    return operand(K.VAR, draw(st.integers(0, size - 1)), name=name)


_INDEX = [st.integers(0, n) for n in range(8)]


def _choose(draw: st.DrawFn, scope: Scope, *options: st.SearchStrategy,
            var: st.SearchStrategy | None = None) -> object:
    """One of ``options``, or ``var`` (a variable operand) when variables are declared."""
    usable = [*options, *([var] if var is not None and scope.variables else [])]
    return draw(usable[draw(_INDEX[len(usable) - 1])])


@st.composite
def bit_operands(draw: st.DrawFn, scope: Scope) -> ast.Operand:
    """Anything that can be read as a bit."""
    return _choose(draw, scope, image_bits, timer_refs(scope), counter_refs(scope),
                   var=var_bits(scope))


@st.composite
def writable_bits(draw: st.DrawFn, scope: Scope) -> ast.Operand:
    """Bits ``=`` may write: outputs, flags, variables."""
    return _choose(draw, scope, output_bits, flag_bits, var=var_bits(scope))


@st.composite
def settable_bits(draw: st.DrawFn, scope: Scope) -> ast.Operand:
    """Operands of S and R: also timers (start, stop) and counters (load, clear)."""
    return _choose(draw, scope, output_bits, flag_bits, timer_refs(scope), counter_refs(scope),
                   var=var_bits(scope))


@st.composite
def load_operands(draw: st.DrawFn, scope: Scope) -> ast.Operand:
    return _choose(draw, scope, constants, param_constants, readable_bytes, flag_words,
                   timer_refs(scope, W.WORD), counter_refs(scope, W.WORD), var=var_bytes(scope))


@st.composite
def transfer_operands(draw: st.DrawFn, scope: Scope) -> ast.Operand:
    return _choose(draw, scope, writable_bytes, flag_words, timer_refs(scope, W.WORD),
                   counter_refs(scope, W.WORD), var=var_bytes(scope))


# -------------------------------------------------------------------- statements

_fixed_statements = st.one_of(
    st.builds(ast.Not),
    st.builds(ast.Arith, st.sampled_from(ast.ArithOp)),
    st.builds(ast.Compare, st.sampled_from(ast.CompareOp)),
    st.builds(ast.BlockEnd, st.sampled_from(ast.EndKind)),
    st.builds(ast.CallFB, st.booleans(), st.sampled_from(FIRMWARE_BLOCKS)),
    st.builds(ast.Param),
    st.builds(ast.Asm, asm_texts),
)
_logic_ops = st.sampled_from(ast.LogicOp)
_set_reset = st.sampled_from([ast.StoreOp.SET, ast.StoreOp.RESET])


@st.composite
def logic(draw: st.DrawFn, scope: Scope) -> ast.Logic:
    return ast.Logic(draw(_logic_ops), draw(bit_operands(scope)))


@st.composite
def statements(draw: st.DrawFn, scope: Scope) -> ast.Statement:
    """Any statement but labels and jumps (placed by ``programs``)."""
    kind = draw(_INDEX[6])
    if kind == 0:
        return draw(logic(scope))
    if kind == 1:
        return ast.Store(ast.StoreOp.ASSIGN, draw(writable_bits(scope)))
    if kind == 2:
        return ast.Store(draw(_set_reset), draw(settable_bits(scope)))
    if kind == 3:
        return ast.Load(draw(load_operands(scope)))
    if kind == 4:
        return ast.Transfer(draw(transfer_operands(scope)))
    if kind == 5:
        return ast.Count(draw(st.sampled_from(ast.CountOp)), draw(counter_refs(scope, W.WORD)))
    return draw(_fixed_statements)


@st.composite
def programs(draw: st.DrawFn, scope: Scope) -> ast.ProgramSection:
    """Segments that each start with a logic instruction and end with ``***``; some lines
    carry a label, and jumps go to those labels."""
    body: list = []
    for _ in range(draw(st.integers(1, 5))):
        body += [draw(logic(scope)), *draw(st.lists(statements(scope), max_size=6)),
                 ast.SegmentEnd()]
    labels = draw(st.lists(names, max_size=3, unique_by=str.casefold))
    for label in labels:
        body.insert(draw(st.integers(0, len(body))), ast.Label(label))
    for _ in range(draw(st.integers(0, 3)) if labels else 0):
        jump = ast.Jump(draw(st.booleans()), draw(st.sampled_from(labels)))
        body.insert(draw(st.integers(0, len(body))), jump)
    return ast.ProgramSection(tuple(body))


@st.composite
def gatings(draw: st.DrawFn, scope: Scope) -> ast.GatingSection:
    def term(op: ast.GatingOp | None) -> ast.GatingTerm:
        return ast.GatingTerm(op, draw(st.booleans()), draw(bit_operands(scope)))

    lines = []
    for _ in range(draw(st.integers(0, 4))):
        more = draw(st.lists(st.sampled_from(ast.GatingOp), max_size=3))
        terms = (term(None), *(term(op) for op in more))
        lines.append(ast.GatingLine(draw(writable_bits(scope)), terms))
    return ast.GatingSection(tuple(lines))


# ------------------------------------------------------------------------- sections

options_sections = st.lists(
    st.builds(ast.Option, st.sampled_from(OPTION_NAMES), st.booleans()),
    max_size=3, unique_by=lambda o: o.name,
).map(lambda options: ast.OptionsSection(tuple(options)))

setup_sections = st.lists(
    st.builds(ast.SlaveSetup, st.integers(1, 31), st.integers(0, 15), st.integers(0, 15),
              st.none() | st.integers(0, 15)),
    max_size=6, unique_by=lambda s: s.address,
).map(lambda slaves: ast.SetupSection(tuple(slaves)))

assembly_sections = st.lists(st.builds(ast.AsmLine, asm_texts), max_size=4).map(
    lambda lines: ast.AssemblySection(tuple(lines))
)


def intel_hex_record(address: int, data: bytes) -> str:
    """A data record (type 00) with its checksum."""
    body = bytes([len(data), address >> 8, address & 0xFF, 0]) + data
    return ":" + (body + bytes([-sum(body) & 0xFF])).hex().upper()


raw_sections = st.lists(
    st.builds(intel_hex_record, st.integers(0, 0xFFF0), st.binary(min_size=1, max_size=16)),
    max_size=3,
).map(lambda records: ast.RawSection((*records, ":00000001FF")))

_variables = st.lists(st.tuples(names, st.integers(1, 8)), max_size=3,
                      unique_by=lambda v: v[0].casefold())
_declared = st.lists(st.integers(15, 1023), max_size=2, unique=True)
_blocks = st.lists(st.tuples(names, file_names), max_size=2, unique_by=lambda b: b[0].casefold())
_firmware = {b.casefold() for b in FIRMWARE_BLOCKS}


@st.composite
def scopes(draw: st.DrawFn) -> tuple[Scope, ast.DeclSection]:
    """The declarations of a module, and what its programs may therefore use."""
    variables, timers, counters = draw(_variables), draw(_declared), draw(_declared)
    taken = {name.casefold() for name, _ in variables} | _firmware
    blocks = [b for b in draw(_blocks) if b[0].casefold() not in taken]
    declarations = (
        [ast.VarDecl(name, size) for name, size in variables]
        + [ast.TimerDecl(n) for n in timers]
        + [ast.CounterDecl(n) for n in counters]
        + [ast.FBDecl(name, file) for name, file in blocks]
    )
    scope = Scope(tuple(variables), tuple(timers), tuple(counters))
    return scope, ast.DeclSection(tuple(draw(st.permutations(declarations))))


@st.composite
def modules(draw: st.DrawFn, file: str = "<string>") -> ast.Module:
    """A main program: at most one [OPTIONS], [SETUP] and [DECL], then any mix of
    [PROGRAM], [GATING], [ASSEMBLY] and [RAW] sections, in the manual's order."""
    scope, decl = draw(scopes())
    head = [draw(options_sections)] if draw(st.booleans()) else []
    head += [draw(setup_sections)] if draw(st.booleans()) else []
    head += [decl] if decl.declarations or draw(st.booleans()) else []
    body = []
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.integers(0, 3))
        body.append(draw(programs(scope)) if kind == 0 else draw(gatings(scope)) if kind == 1
                    else draw(assembly_sections) if kind == 2 else draw(raw_sections))
    return ast.Module(file, (*head, *body))


# ------------------------------------------------------------------ traceable programs


def forward_only(section: ast.ProgramSection, *, asm: bool) -> ast.ProgramSection:
    """Without backward jumps: they make endless loops, which run into the cycle budget
    but take long. Without ``asm`` also without ASM lines: the reference interpreter has
    no 8051."""
    seen: set[str] = set()
    kept = []
    for statement in section.statements:
        if isinstance(statement, ast.Label):
            seen.add(statement.name.casefold())
        if isinstance(statement, ast.Asm) and not asm:
            continue
        if isinstance(statement, ast.Jump) and statement.label.casefold() in seen:
            continue
        kept.append(statement)
    return ast.ProgramSection(tuple(kept))


@st.composite
def traceable_sources(draw: st.DrawFn) -> dict[str, str]:
    """A main file and perhaps one block file, as text (the trace needs real lines)."""
    scope, decl = draw(scopes())
    decl_items = [d for d in decl.declarations if not isinstance(d, ast.FBDecl)]
    files: dict[str, str] = {}
    block = draw(st.booleans())
    if block:
        decl_items.append(ast.FBDecl("Blk", "blk.fb"))
        block_body = forward_only(draw(programs(scope)), asm=False)
        files["blk.fb"] = ast.Module("blk.fb", (block_body,)).to_source()
    body = []
    for _ in range(draw(st.integers(1, 2))):
        statements = list(forward_only(draw(programs(scope)), asm=False).statements)
        if block:
            statements.insert(draw(st.integers(1, max(1, len(statements)))),
                              ast.CallFB(draw(st.booleans()), "Blk"))
        body.append(ast.ProgramSection(tuple(statements)))
    main_module = ast.Module("main.asi", (ast.DeclSection(tuple(decl_items)), *body))
    files["main.asi"] = main_module.to_source()
    return files


# ------------------------------------------------------------------ programs that run


@st.composite
def checked_programs(draw: st.DrawFn, *, asm: bool, options: bool) -> Program:
    """A whole program that checks clean and ends every cycle: a main file with program
    and gating sections, and up to two function-block files it calls; ``asm`` keeps ASM
    lines, ``options`` may add ``map_counters``."""
    scope, decl = draw(scopes())
    decl = ast.DeclSection(tuple(d for d in decl.declarations if not isinstance(d, ast.FBDecl)))
    names = draw(st.lists(st.sampled_from(["BlkA", "BlkB"]), unique=True, max_size=2))
    blocks = {
        name.casefold(): ast.Module(
            f"{name}.fb", (forward_only(draw(programs(scope)), asm=asm),)
        )
        for name in names
    }
    sections: list[ast.Section] = []
    if options and draw(st.booleans()):
        sections.append(ast.OptionsSection((ast.Option("map_counters", draw(st.booleans())),)))
    sections.append(ast.DeclSection(
        (*decl.declarations, *(ast.FBDecl(n, f"{n}.fb") for n in names))
    ))
    for _ in range(draw(st.integers(1, 3))):
        if draw(st.integers(0, 3)):
            statements = list(forward_only(draw(programs(scope)), asm=asm).statements)
            for name in names:
                call = ast.CallFB(draw(st.booleans()), name)
                statements.insert(draw(st.integers(1, max(1, len(statements)))), call)
            sections.append(ast.ProgramSection(tuple(statements)))
        else:
            sections.append(draw(gatings(scope)))
    program = Program(main=ast.Module("main.asi", tuple(sections)), blocks=blocks)
    for name in names:
        program.fb_decls[name.casefold()] = ast.FBDecl(name, f"{name}.fb")
    assume(not any(d.is_error for d in check_program(program)))
    return program


#: One program cycle: its inputs, the 10 ms ticks before it, perhaps a host's flag write.
CycleStep = tuple[bytes, int, tuple[int, int] | None]


def cycle_steps(max_size: int) -> st.SearchStrategy[list[CycleStep]]:
    """Up to ``max_size`` program cycles to run."""
    return st.lists(
        st.tuples(
            st.binary(min_size=16, max_size=16),
            st.sampled_from([0, 0, 1, 2, 5, 60]),
            st.none() | st.tuples(st.integers(0, 127), st.integers(0, 255)),
        ),
        min_size=1,
        max_size=max_size,
    )


class ModelFirmware:
    """A deterministic stand-in for the master's firmware blocks that notes every call."""

    def __init__(self) -> None:
        self.log: list[tuple[str, bytes]] = []

    def call(self, name: str, pseg: bytearray) -> None:
        self.log.append((name, bytes(pseg)))
        h = (sum(pseg[:4]) * 7 + len(name)) & 0xFF
        pseg[0] = 0 if h % 3 else 0x80
        pseg[1] = (pseg[1] ^ h) & 0xFF
        pseg[2] = h
