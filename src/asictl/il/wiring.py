"""The program against its wiring: what [SETUP] says each slave is (W701-W704).

The master exchanges data only with the slaves [SETUP] projects, and each data bit of a
slave is an input or an output by its I/O code (``platform.master.IO_CODE_BITS``). So
reading an output bit, writing an input bit, or using a slave [SETUP] does not know
compiles and runs, and does nothing: the mistakes that cost commissioning time. Each
warning stands at the operand and has a note at the [SETUP] line it contradicts.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import assert_never

from asictl.codes import AnalysisCode
from asictl.diagnostics import Related, Reporter, Span
from asictl.il import ast
from asictl.il.ast import key
from asictl.il.loader import Program
from asictl.il.usage import Key, Name, Usage
from asictl.platform.master import IO_CODE_BITS, SLAVES
from asictl.runtime.firmware import FIRMWARE_BLOCKS

#: The operands of input data (any access reads the input image) and of output data.
_INPUTS = (ast.OperandKind.I, ast.OperandKind.I2, ast.OperandKind.IB, ast.OperandKind.I2B)
_OUTPUTS = (ast.OperandKind.Q, ast.OperandKind.QB)
_BITS_PER_SLAVE = 4


@dataclass(frozen=True)
class Wiring:
    """The projected slaves, and where [SETUP] says so."""

    slaves: Mapping[int, ast.SlaveSetup]
    #: the [SETUP] titles, for notes about slaves it does not list
    titles: tuple[Span, ...]
    ignore_config_errors: bool

    @classmethod
    def of(cls, program: Program) -> Wiring:
        slaves: dict[int, ast.SlaveSetup] = {}
        for slave in program.slaves:
            slaves.setdefault(slave.address, slave)
        titles = tuple(
            s.span for s in program.main.sections_of(ast.SetupSection) if s.span is not None
        )
        return cls(slaves, titles, program.options.ignore_config_errors)

    def setup_note(self) -> tuple[Related, ...]:
        if not self.titles:
            return ()
        listed = ", ".join(str(a) for a in sorted(self.slaves)) or "none"
        return ((self.titles[0], f"[SETUP] projects these slaves: {listed}"),)

    def slave_note(self, address: int) -> tuple[Related, ...]:
        slave = self.slaves[address]
        if slave.span is None:
            return ()
        return ((slave.span, f"slave {address} is set up here as {io_code_text(slave.io_code)}"),)

    def not_projected(self, it: str) -> str:
        """What an unprojected slave on the bus does to the program."""
        if self.ignore_config_errors:
            verb = "is" if it == "it" else "are"
            return f"ignore_config_errors keeps the program running while {it} {verb} on the bus"
        return (f"with {it} on the bus the configuration is wrong and the program stops "
                "(a configuration error)")


def io_code_text(code: int) -> str:
    letters = IO_CODE_BITS[code]
    return f"{code:X}h (tristate)" if "t" in letters else f"{letters} ({code:X}h)"


def check_wiring(program: Program, index: Usage, report: Reporter) -> None:
    """W701, W702 and W704 against the projected slaves; W703 when there are none."""
    wiring = Wiring.of(program)
    if not wiring.slaves:
        _no_slaves(program, wiring, report)
        return
    verdicts: dict[Key, _Verdict | None] = {}
    for use in index.of_kind(*_INPUTS, *_OUTPUTS):
        operand = use.operand
        if operand not in verdicts:
            verdicts[operand] = _judge(index.text(operand), operand, wiring)
        verdict = verdicts[operand]
        if verdict is not None:
            report.warning(verdict.code, verdict.message, use.span, verdict.notes)
    if any(r.mark == "PARAM" or r.operand.kind is Name.BLOCK for r in index.uses):
        for module in program.modules():
            _check_slave_commands(module, wiring, report)


def has_logic(module: ast.Module) -> bool:
    return any(
        (isinstance(s, ast.ProgramSection) and s.statements)
        or (isinstance(s, ast.GatingSection) and s.lines)
        for s in module.sections
    )


def _no_slaves(program: Program, wiring: Wiring, report: Reporter) -> None:
    main = program.main
    if not has_logic(main):
        return
    logic = [s for s in main.sections if isinstance(s, ast.ProgramSection | ast.GatingSection)]
    where = wiring.titles[0] if wiring.titles else logic[0].span
    if wiring.ignore_config_errors:
        effect = ("the master exchanges data with no slave, so the program reads only "
                  "zeros and its outputs reach no slave")
    else:
        effect = ("the master never reaches normal operation without slaves, and every "
                  "slave it finds is a configuration error, so the program never runs")
    report.warning(
        AnalysisCode.NO_SLAVES,
        f"no slave in [SETUP]: {effect}; list each slave as 'address: I/O code, ID code'",
        where,
    )


@dataclass(frozen=True)
class _Verdict:
    """What is wrong with every use of one operand."""

    code: AnalysisCode
    message: str
    notes: tuple[Related, ...]


def _judge(text: str, operand: Key, wiring: Wiring) -> _Verdict | None:
    assert isinstance(operand.kind, ast.OperandKind)  # (only slave data is judged)
    slaves = [a for a in ast.slaves_of(operand.kind, operand.address) if 0 <= a < SLAVES]
    if not slaves:
        return None
    is_input = operand.kind in _INPUTS
    projected = [a for a in slaves if a in wiring.slaves]
    if not projected:
        if len(slaves) == 1:
            which, it = f"slave {slaves[0]}, which is not", "it"
        else:
            which, it = f"slaves {slaves[0]} and {slaves[1]}, neither of which is", "them"
        effect = "stays 0" if is_input else "reaches no slave"
        return _Verdict(
            AnalysisCode.SLAVE_NOT_PROJECTED,
            f"{text} addresses {which} in [SETUP]: the master exchanges no data with {it} "
            f"({text} {effect}), and {wiring.not_projected(it)}",
            wiring.setup_note(),
        )
    wanted = "i" if is_input else "o"
    bits = [operand.bit] if operand.bit >= 0 else list(range(_BITS_PER_SLAVE))
    directions = [IO_CODE_BITS[wiring.slaves[a].io_code][b] for a in projected for b in bits]
    if any(d in (wanted, "b") for d in directions):
        return None
    notes = tuple(n for a in projected for n in wiring.slave_note(a))
    if operand.bit >= 0:
        slave = wiring.slaves[projected[0]]
        direction = {"i": "an input", "o": "an output", "t": "tristate"}[directions[0]]
        effect = ("the slave sends nothing on it" if is_input
                  else "the slave takes no output on it")
        message = (f"{text} is data bit D{operand.bit} of slave {slave.address}, which is "
                   f"{direction} by its I/O code {io_code_text(slave.io_code)}: {effect}")
    else:
        kind = "input" if is_input else "output"
        message = (f"{text} holds no {kind} bit: no data bit of slave"
                   f"{'s' if len(projected) > 1 else ''} "
                   f"{' and '.join(str(a) for a in projected)} is an {kind} by [SETUP]")
    return _Verdict(AnalysisCode.WRONG_DIRECTION, message, notes)


# --------------------------------------------------------- parameters and commands


@dataclass
class _Known:
    """Constants a straight run of statements has loaded: (value, where it was loaded)."""

    parameter: tuple[ast.Operand, Span] | None = None  # the constant register's KP
    accu: tuple[int, Span] | None = None  # ACCU1
    pseg0: tuple[int, Span] | None = None  # PSeg 0


def _check_slave_commands(module: ast.Module, wiring: Wiring, report: Reporter) -> None:
    """PARAM and the firmware blocks that work on one slave (W704).

    Which slave they address is read from the constants loaded before them in the same
    straight run of statements (a label starts a new one: another path may lead there).
    """
    known = _Known()
    K = ast.OperandKind
    for statement in module.statements():
        match statement:
            case ast.Label() | ast.Asm():
                known = _Known()
            case ast.Load(operand=operand, span=span):
                if span and operand.kind is K.KP:
                    known.parameter = (operand, span)
                elif span and operand.kind in (K.KB, K.KW):
                    known.accu = (operand.address & 0xFF, span)
                elif span and operand.kind in (K.KT, K.KC):  # the constant register, as KP
                    known.parameter = None
                else:
                    known.accu = None
            case ast.Arith():
                known.accu = None
            case ast.Transfer(operand=operand):
                if operand.kind is K.PSEG and operand.address == 0:
                    known.pseg0 = known.accu
            case ast.Param(span=span):
                if known.parameter is not None and span:
                    _param(known.parameter, span, wiring, report)
            case ast.CallFB(name=name, span=span):
                block = FIRMWARE_BLOCKS.get(key(name))
                if block is not None and block.for_projected_slave and known.pseg0 and span:
                    _firmware(block.name, known.pseg0, span, wiring, report)
                known.pseg0 = None
                if block is None:  # a user block may load anything
                    known = _Known()
            case (ast.Logic() | ast.Store() | ast.Not() | ast.Compare() | ast.Count()
                  | ast.SegmentEnd() | ast.BlockEnd() | ast.Jump()):
                pass
            case _:
                assert_never(statement)


def _param(kp: tuple[ast.Operand, Span], at: Span, wiring: Wiring, report: Reporter) -> None:
    constant, loaded = kp
    if constant.address in wiring.slaves:
        return
    report.warning(
        AnalysisCode.SLAVE_COMMAND_NOT_PROJECTED,
        f"PARAM sends parameter {constant.bit} to slave {constant.address}, which is not in "
        "[SETUP]: the master sends parameters only to projected slaves",
        at, ((loaded, f"slave {constant.address} comes from 'L {constant}' here"),
             *wiring.setup_note()),
    )


def _firmware(
    name: str, pseg0: tuple[int, Span], at: Span, wiring: Wiring, report: Reporter
) -> None:
    slave, loaded = pseg0
    if slave in wiring.slaves:
        return
    report.warning(
        AnalysisCode.SLAVE_COMMAND_NOT_PROJECTED,
        f"{name} is called for slave {slave} (PSeg 0), which is not in [SETUP]",
        at, ((loaded, f"slave {slave} is loaded here"), *wiring.setup_note()),
    )
