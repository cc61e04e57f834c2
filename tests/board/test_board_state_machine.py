"""Random host sessions against the board: after every step the DPRAM must make sense.

The machine drives only the port (commands with random parameters, random writes to the
host images), the bus (slaves plugged in and out, inputs, power, lost telegrams) and
time. The invariants are the manual's relations between the lists and flags; they are
checked once the board has had a full AS-i cycle to catch up with the last change. The
lists the master writes (LAS, LDS, CDI, ec-flags) are read from the DPRAM; LPS and PCD
from the master, since their DPRAM images hold whatever the host wrote until a command.
"""

from __future__ import annotations

from board_host import Host, compile_image
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, precondition, rule

from asictl.board.asi import Slave
from asictl.board.board import Pc2Board
from asictl.board.emc import EmcTest
from asictl.board.execution import Phase
from asictl.platform import pc2 as d
from asictl.platform.master import ControlFlag
from asictl.platform.pc2 import Command, ControlState, EcFlag, HiFlag, StopReason

IMAGE = compile_image("""
[SETUP]
1: iiii, 1
3: oooo, 0
[PROGRAM]
        A   I 1.0
        =   Q 3.0
***
        AN  I 1.1
        O   F 0.0
        =   Q 3.2
***
        A   I 1.2
        L   KP 3.5
        PARAM
""")
PROGRAM = IMAGE.to_bytes()
KINDS = [(0x0, 0x1), (0x8, 0x0)]  # the program's sensor and actuator profiles
CODES = [*(int(c) for c in Command), 1, 99, 200]
#: long enough for the slowest AS-i cycle (31 slaves) and a phase step
SYNC_MS = 6


def projected(board: Pc2Board) -> set[int]:
    return d.slave_list(board.execution.lps.to_bytes(4, "little"))


class BoardMachine(RuleBasedStateMachine):
    @initialize(installed=st.booleans())
    def power_up(self, installed: bool) -> None:
        """A new board with the program in its EEPROM; half the time set up and started."""
        self.board = Pc2Board()
        self.host = Host(self.board)
        self.host.download(PROGRAM)
        if installed:
            self.attach_expected(1)
            self.attach_expected(3)
            self.project()
            self.start(0)
        self.synced = False
        self.settled_for_ms = 0.0
        #: in EMC test mode (command 130 with slaves to test) the test's request replaces
        #: the data exchange, so inputs do not reach the IDI
        self.emc = False

    # --- the bus ------------------------------------------------------------------

    @rule(address=st.sampled_from([0, 1, 2, 3, 5]), kind=st.sampled_from(KINDS))
    def attach(self, address: int, kind: tuple[int, int]) -> None:
        self.board.bus.attach(Slave(address, *kind))
        self.changed()

    @rule(address=st.sampled_from([1, 3]))
    def attach_expected(self, address: int) -> None:
        """The slave the program wants, where it wants it."""
        self.board.bus.attach(Slave(address, *KINDS[address == 3]))
        self.changed()

    @precondition(lambda self: len(self.board.bus))
    @rule(data=st.data())
    def remove(self, data) -> None:
        self.board.bus.remove(data.draw(st.sampled_from(self.board.bus.slaves)))
        self.changed()

    @precondition(lambda self: len(self.board.bus))
    @rule(data=st.data(), value=st.integers(0, 15))
    def set_inputs(self, data, value: int) -> None:
        data.draw(st.sampled_from(self.board.bus.slaves)).inputs = value
        self.changed()

    @precondition(lambda self: len(self.board.bus))
    @rule(data=st.data(), count=st.integers(1, 3))
    def lose_telegrams(self, data, count: int) -> None:
        data.draw(st.sampled_from(self.board.bus.slaves)).lose_telegrams(count)
        self.changed()

    @rule(on=st.booleans())
    def power(self, on: bool) -> None:
        if on:
            self.board.bus.power_restore()
        else:
            self.board.bus.power_fail()
        self.changed()

    @rule()
    def set_button(self) -> None:
        self.board.press_set_button()
        self.changed()

    # --- the host -------------------------------------------------------------------

    @rule(
        code=st.sampled_from(CODES),
        data=st.integers(0, 255),
        address=st.integers(0, 255),
        extension=st.integers(0, 0x3F) | st.just(0xFF),
    )
    def command(self, code: int, data: int, address: int, extension: int) -> None:
        if code == Command.WRITE_CONTROL_FLAGS:
            self.host.write(d.CONTROL_FLAGS, data)
        if code == Command.EMC_TEST_MODE:
            asked = self.host.read(d.PROGRAM_BUFFER, d.EMC_PARAMETERS_SIZE)
        answer = self.host.command(code, data=data, address=address, extension=extension)
        assert answer in (d.ACK, d.NAK)
        if code == Command.EMC_TEST_MODE and answer == d.ACK:
            self.emc = EmcTest.from_buffer(asked) is not None
        self.changed()

    @rule()
    def project(self) -> None:
        """The program's LPS/PCD/PP (refused steps are fine: a slave 0 may be present)."""
        configuration = IMAGE.configuration
        for code, where, image in (
            (Command.SET_LPS, d.LPS, configuration.lps),
            (Command.SET_PERMANENT_CONFIGURATION, d.PCD, configuration.pcd),
            (Command.SET_PERMANENT_PARAMETER, d.PP, configuration.pp),
        ):
            self.host.command(Command.SET_OPERATION_MODE, data=1)
            self.host.write(where, image)
            self.host.command(code)
        self.host.command(Command.SET_OPERATION_MODE, data=0)
        self.changed()

    @rule(options=st.sampled_from([0, 4, 8, 12]))
    def start(self, options: int) -> None:
        """Reset and start, with ignore_config_errors / wait-for-set-button as drawn."""
        self.host.control_flags(ControlFlag.RESET | ControlFlag.START | options)
        self.changed()

    @rule(
        where=st.sampled_from([d.LPS, d.LOS, d.PCD, d.PP, d.PI, d.ODI, d.FLAGS]),
        values=st.binary(min_size=1, max_size=32),
    )
    def write_image(self, where: int, values: bytes) -> None:
        self.host.write(where, values)
        self.changed()

    @rule(
        hi=st.integers(0, 7),
        watchdog=st.tuples(st.integers(0, 1), st.integers(0, 20)),
        delay=st.integers(0, 5),
    )
    def write_settings(self, hi: int, watchdog: tuple[int, int], delay: int) -> None:
        self.host.write(d.HI_FLAGS, hi)
        self.host.write(d.WATCHDOG_ENABLE, watchdog)
        self.host.write(d.CONFIG_OK_DELAY, delay)
        self.changed()

    @rule(ms=st.sampled_from([SYNC_MS, 20, 75, 300]))
    def advance(self, ms: float) -> None:
        self.board.advance(ms)
        self.synced = True
        self.settled_for_ms = ms

    def changed(self) -> None:
        self.synced = False

    # --- invariants -------------------------------------------------------------------

    @invariant()
    def command_byte_is_answered(self) -> None:
        assert self.board.dpram[d.COMMAND] in (0, d.ACK, d.NAK)

    @invariant()
    def lists_are_consistent(self) -> None:
        if not self.synced:
            return
        host, board = self.host, self.board
        las, lds, lps = host.slaves(d.LAS), host.slaves(d.LDS), projected(board)
        cdi, pcd = host.read(d.CDI, 32), board.execution.pcd
        assert las <= lds and 0 not in las and 0 not in lps
        assert {a for a in range(32) if cdi[a] != 0xFF} == lds
        if board.phase is not Phase.NORMAL:
            assert las == set() or board.phase is Phase.ACTIVATION
        elif board.mode == "protected":
            assert las <= lps
            assert all(cdi[a] == pcd[a] for a in las)
        else:
            assert las == lds - {0}

    @invariant()
    def ec_flags_match_the_state(self) -> None:
        if not self.synced:
            return
        host, board = self.host, self.board
        flags = host.ec_flags()
        lds, lps = host.slaves(d.LDS), projected(board)
        assert bool(flags & EcFlag.LDS_0) == (0 in lds)
        assert bool(flags & EcFlag.CONFIGURATION_ACTIVE) == (board.mode == "configuration")
        assert bool(flags & EcFlag.NORMAL_OPERATION_ACTIVE) == (board.phase is Phase.NORMAL)
        assert bool(flags & EcFlag.OFFLINE_READY) == (board.phase is Phase.OFFLINE)
        assert bool(flags & EcFlag.APF) == (not board.bus.powered)
        cdi, pcd = host.read(d.CDI, 32), board.execution.pcd
        configuration_right = (
            board.phase is Phase.NORMAL
            and lds - {0} == lps
            and all(cdi[a] == pcd[a] for a in lps)
        )
        if flags & EcFlag.CONFIG_OK:
            assert configuration_right
        delay_ms = 10 * host.byte(d.CONFIG_OK_DELAY)
        if configuration_right and self.settled_for_ms >= delay_ms + 50 and not any(
            s.lost_telegrams for s in board.bus
        ):
            assert flags & EcFlag.CONFIG_OK
        if flags & EcFlag.AUTO_ADDRESS_AVAILABLE:
            assert flags & EcFlag.AUTO_ADDRESS_ASSIGN and len(lps - lds) == 1

    @invariant()
    def installed_software_letters_match(self) -> None:
        if not self.synced:
            return
        host, board = self.host, self.board
        letters = host.letters()
        hi = host.byte(d.HI_FLAGS)
        running = board.control_state is ControlState.RUNNING
        assert letters[0] == ("C" if running else "c")
        assert letters[1:8] == "BFEDC.."
        assert letters[8] == ("d" if hi & HiFlag.DATA_EXCHANGE_OFF else "D")
        assert letters[9] == ("O" if hi & HiFlag.OFFLINE else "o")
        assert letters[10] == ("a" if hi & HiFlag.AUTO_ADDRESS_OFF else "A")
        assert letters[14] == ("W" if host.byte(d.WATCHDOG_ENABLE) else "w")

    @invariant()
    def control_program_rules(self) -> None:
        if not self.synced:
            return
        host, board = self.host, self.board
        state = board.control_state
        assert host.byte(d.CONTROL_STATE) == state
        assert (host.byte(d.STOP_REASON) == StopReason.NONE) == (state is ControlState.RUNNING)
        if state is not ControlState.RUNNING:
            return
        flags = board.control_flags
        assert flags & ControlFlag.START and board.phase is Phase.NORMAL
        assert host.ec_flags() & EcFlag.CONFIG_OK or flags & ControlFlag.IGNORE_CONFIG_ERRORS
        outputs = board.program.outputs
        assert host.read(d.ODI, 16) == bytes(~b & 0xFF for b in outputs)
        # an EMC test sends its request instead of the data exchange (board/emc.py): the
        # slaves' outputs go off until it ends
        if not self.emc and not host.byte(d.HI_FLAGS) & HiFlag.DATA_EXCHANGE_OFF:
            values = d.nibbles(outputs)
            for address in host.slaves(d.LAS):
                assert board.bus.slave(address).outputs == values[address]

    @invariant()
    def inputs_reach_the_idi(self) -> None:
        if self.emc or not self.synced or self.host.byte(d.HI_FLAGS) & HiFlag.DATA_EXCHANGE_OFF:
            return
        idi = self.host.inputs()
        for address in self.host.slaves(d.LAS):
            assert idi[address] == self.board.bus.slave(address).inputs


TestBoardMachine = BoardMachine.TestCase
TestBoardMachine.settings = settings(
    max_examples=150,
    stateful_step_count=40,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
