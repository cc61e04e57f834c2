"""The execution control as the host sees it: phases, modes, lists, config_ok, offline."""

from __future__ import annotations

from pathlib import Path

import pytest
from board_host import Host

from asictl.board.asi import Slave
from asictl.board.board import Pc2Board
from asictl.board.execution import Phase
from asictl.observe.operands import parse_operand
from asictl.observe.view import read_on_board
from asictl.platform import pc2 as d
from asictl.platform.pc2 import Command, EcFlag, HiFlag, InterruptSource

SENSOR, ACTUATOR = (0x0, 0x1), (0x8, 0x0)  # (I/O code, ID code)


def profile(kind: tuple[int, int]) -> int:
    return kind[1] << 4 | kind[0]


def project(host: Host, slaves: dict[int, tuple[int, int]], *, los: set[int] = frozenset()):
    """Configure LPS/PCD (and LOS) in configuration mode, then go protected."""
    host.ok(Command.SET_OPERATION_MODE, data=1)
    pcd = bytearray([0xFF]) * 32
    for a, kind in slaves.items():
        pcd[a] = profile(kind)
    host.write(d.LPS, d.list_bytes(set(slaves)))
    host.ok(Command.SET_LPS)
    host.write(d.PCD, pcd)
    host.ok(Command.SET_PERMANENT_CONFIGURATION)
    host.write(d.LOS, d.list_bytes(los))
    host.ok(Command.SET_LOS)
    host.ok(Command.SET_OPERATION_MODE, data=0)
    host.board.advance(30)


@pytest.fixture
def installed(board: Pc2Board, host: Host) -> dict[int, Slave]:
    """Sensor at 1, actuators at 3 and 4, projected, protected mode, configuration OK."""
    slaves = {
        1: board.bus.attach(Slave(1, *SENSOR)),
        3: board.bus.attach(Slave(3, *ACTUATOR)),
        4: board.bus.attach(Slave(4, *ACTUATOR)),
    }
    project(host, {1: SENSOR, 3: ACTUATOR, 4: ACTUATOR})
    assert host.ec_flags() & EcFlag.CONFIG_OK
    return slaves


def test_detection_waits_for_a_slave(board: Pc2Board, host: Host):
    assert board.phase is Phase.OFFLINE
    board.advance(100)
    assert board.phase is Phase.DETECTION
    flags = host.ec_flags()
    assert not flags & (EcFlag.NORMAL_OPERATION_ACTIVE | EcFlag.OFFLINE_READY | EcFlag.CONFIG_OK)
    board.bus.attach(Slave(5, *SENSOR))
    board.advance(2)
    assert board.phase is Phase.NORMAL
    assert host.ec_flags() & EcFlag.NORMAL_OPERATION_ACTIVE


def test_configuration_mode_activates_every_detected_slave_but_0(board: Pc2Board, host: Host):
    for address in (0, 2, 7):
        board.bus.attach(Slave(address, *SENSOR))
    board.advance(10)
    assert host.slaves(d.LDS) == {0, 2, 7}
    assert host.slaves(d.LAS) == {2, 7}
    assert host.byte(d.CDI + 7) == profile(SENSOR) and host.byte(d.CDI + 3) == 0xFF
    flags = host.ec_flags()
    assert flags & EcFlag.LDS_0 and flags & EcFlag.CONFIGURATION_ACTIVE
    assert not flags & EcFlag.CONFIG_OK  # detected, not projected


def test_protected_mode_activates_projected_slaves_with_their_profile(board, host: Host):
    board.bus.attach(Slave(1, *SENSOR))
    board.bus.attach(Slave(2, *SENSOR))  # not projected
    board.bus.attach(Slave(3, *SENSOR))  # projected as an actuator
    project(host, {1: SENSOR, 3: ACTUATOR})
    assert host.slaves(d.LDS) == {1, 2, 3}
    assert host.slaves(d.LAS) == {1}
    assert not host.ec_flags() & EcFlag.CONFIG_OK


def test_config_ok_rises_after_its_delay_and_falls_at_once(installed, board, host: Host):
    host.write(d.CONFIG_OK_DELAY, 10)  # 100 ms
    board.bus.remove(installed[4])
    board.advance(2)
    assert not host.ec_flags() & EcFlag.CONFIG_OK
    assert host.slaves(d.LAS) == {1, 3}
    board.bus.attach(installed[4])
    board.advance(50)
    assert host.slaves(d.LAS) == {1, 3, 4}
    assert not host.ec_flags() & EcFlag.CONFIG_OK
    board.advance(60)
    assert host.ec_flags() & EcFlag.CONFIG_OK
    assert board.nonvolatile()["config_ok_delay"] == 10


def test_default_delay_is_20_ms(installed, board, host: Host):
    board.bus.remove(installed[4])
    board.advance(2)
    board.bus.attach(installed[4])
    board.advance(15)
    assert not host.ec_flags() & EcFlag.CONFIG_OK
    board.advance(10)
    assert host.ec_flags() & EcFlag.CONFIG_OK


def test_a_slave_with_the_wrong_profile_is_a_configuration_error(installed, board, host: Host):
    board.bus.remove(installed[3])
    board.bus.attach(Slave(3, *SENSOR))
    board.advance(5)
    assert 3 in host.slaves(d.LDS) and 3 not in host.slaves(d.LAS)
    assert not host.ec_flags() & EcFlag.CONFIG_OK


def test_two_slaves_at_one_address_are_not_detected(installed, board, host: Host):
    board.bus.attach(Slave(4, *ACTUATOR))
    board.advance(5)
    assert 4 not in host.slaves(d.LDS)
    assert not host.ec_flags() & EcFlag.CONFIG_OK


def test_auto_addressing_replaces_one_missing_slave(installed, board, host: Host):
    board.bus.remove(installed[3])
    board.advance(5)
    flags = host.ec_flags()
    assert flags & EcFlag.AUTO_ADDRESS_ASSIGN and flags & EcFlag.AUTO_ADDRESS_AVAILABLE
    new = board.bus.attach(Slave(0, *ACTUATOR))
    board.advance(30)
    assert new.address == 3
    assert host.slaves(d.LAS) == {1, 3, 4}
    assert host.ec_flags() & EcFlag.CONFIG_OK


def test_auto_addressing_needs_the_same_profile(installed, board, host: Host):
    board.bus.remove(installed[3])
    new = board.bus.attach(Slave(0, *SENSOR))
    board.advance(30)
    assert new.address == 0 and host.ec_flags() & EcFlag.LDS_0


def test_auto_addressing_needs_exactly_one_missing_slave(installed, board, host: Host):
    board.bus.remove(installed[3])
    board.bus.remove(installed[4])
    new = board.bus.attach(Slave(0, *ACTUATOR))
    board.advance(30)
    assert new.address == 0
    assert not host.ec_flags() & EcFlag.AUTO_ADDRESS_AVAILABLE


def test_auto_addressing_can_be_disabled(installed, board, host: Host):
    host.write(d.HI_FLAGS, HiFlag.AUTO_ADDRESS_OFF)  # stored inverted
    board.bus.remove(installed[3])
    new = board.bus.attach(Slave(0, *ACTUATOR))
    board.advance(30)
    assert new.address == 0
    assert not host.ec_flags() & EcFlag.AUTO_ADDRESS_ASSIGN
    assert host.letters()[10] == "a"


def test_no_auto_addressing_in_configuration_mode(installed, board, host: Host):
    host.ok(Command.SET_OPERATION_MODE, data=1)
    board.bus.remove(installed[3])
    new = board.bus.attach(Slave(0, *ACTUATOR))
    board.advance(30)
    assert new.address == 0


def test_los_slave_error_forces_offline_until_los_is_rewritten(board, host: Host):
    slaves = [board.bus.attach(Slave(a, *ACTUATOR)) for a in (3, 4)]
    project(host, {3: ACTUATOR, 4: ACTUATOR}, los={3})
    assert board.phase is Phase.NORMAL
    board.bus.remove(slaves[1])  # not in the LOS: only an error
    board.advance(5)
    assert board.phase is Phase.NORMAL
    board.bus.attach(slaves[1])
    board.bus.remove(slaves[0])  # in the LOS: offline
    board.advance(5)
    assert board.phase is Phase.OFFLINE
    assert host.ec_flags() & EcFlag.OFFLINE_READY
    assert host.slaves(d.LAS) == set() and slaves[1].outputs == 0
    board.bus.attach(slaves[0])
    board.advance(50)
    assert board.phase is Phase.OFFLINE  # repaired, still offline
    host.ok(Command.SET_LOS)  # rewriting the LOS (even unchanged) lets it go
    board.advance(30)
    assert board.phase is Phase.NORMAL and host.ec_flags() & EcFlag.CONFIG_OK


def test_los_has_no_effect_in_configuration_mode(board, host: Host):
    slave = board.bus.attach(Slave(3, *ACTUATOR))
    host.write(d.LOS, d.list_bytes({3}))
    host.ok(Command.SET_LOS)
    board.bus.remove(slave)
    board.advance(10)
    assert board.phase is Phase.NORMAL
    assert not host.ec_flags() & EcFlag.OFFLINE_READY


def test_watchdog_times_out_into_the_offline_phase(installed, board, host: Host):
    host.set_outputs({3: 0x9})
    host.write(d.WATCHDOG_COUNTER, 5)
    host.write(d.WATCHDOG_ENABLE, 1)
    board.advance(2)
    assert host.letters()[14] == "W" and installed[3].outputs == 0x9
    for _ in range(10):  # the host triggers it in time
        host.write(d.WATCHDOG_COUNTER, 5)
        board.advance(30)
    assert board.phase is Phase.NORMAL
    board.advance(60)
    assert board.phase is Phase.OFFLINE
    assert host.read(d.WATCHDOG_ENABLE, 2) == b"\0\0"  # how the host recognises it
    assert host.byte(d.HI_FLAGS) & HiFlag.OFFLINE and host.letters()[9] == "O"
    assert installed[3].outputs == 0
    host.write(d.HI_FLAGS, 0)
    board.advance(30)
    assert board.phase is Phase.NORMAL and installed[3].outputs == 0x9


def test_offline_host_flag(installed, board, host: Host):
    host.write(d.HI_FLAGS, HiFlag.OFFLINE)
    board.advance(2)
    assert board.phase is Phase.OFFLINE and host.ec_flags() & EcFlag.OFFLINE_READY
    host.write(d.HI_FLAGS, 0)
    board.advance(5)
    assert board.phase is Phase.NORMAL


def test_data_exchange_off(installed, board, host: Host):
    host.set_outputs({3: 0x5})
    installed[1].inputs = 0x3
    board.advance(2)
    assert installed[3].outputs == 5 and host.inputs()[1] == 3
    host.write(d.HI_FLAGS, HiFlag.DATA_EXCHANGE_OFF)
    board.advance(2)
    installed[1].inputs = 0x6
    board.advance(2)
    assert installed[3].outputs == 0  # no calls: the slave's watchdog
    # a scenario's Q reads the output image, not the slave (docs/simulation.md, Q a.b)
    assert read_on_board(board, parse_operand("Q 3")) == 5
    assert "which `Q` does not show: it tests the program, not the cable" in " ".join(
        (Path(__file__).resolve().parents[2] / "docs" / "simulation.md").read_text().split())
    assert host.inputs()[1] == 3  # IDI not updated
    assert host.letters()[8] == "d" and board.phase is Phase.NORMAL
    host.write(d.HI_FLAGS, 0)
    board.advance(2)
    assert installed[3].outputs == 5 and host.inputs()[1] == 6


def test_power_fail(installed, board, host: Host):
    host.set_outputs({3: 0x7})
    board.advance(2)
    board.bus.power_fail()
    board.advance(2)
    flags = host.ec_flags()
    assert flags & EcFlag.APF and flags & EcFlag.OFFLINE_READY and not flags & EcFlag.CONFIG_OK
    assert installed[3].outputs == 0 and host.slaves(d.LDS) == set()
    board.advance(500)
    assert board.phase is Phase.OFFLINE  # stays offline without AS-i power
    board.bus.power_restore()
    board.advance(30)
    assert board.phase is Phase.NORMAL and not host.ec_flags() & EcFlag.APF
    assert installed[3].outputs == 0x7 and host.ec_flags() & EcFlag.CONFIG_OK


def test_activation_sends_the_parameter_image(installed, board, host: Host):
    pp = bytearray([0xFF]) * 16
    pp[2] = 0xF6  # slave 4: 6
    host.write(d.PP, pp)
    host.ok(Command.SET_PERMANENT_PARAMETER)
    assert installed[4].parameter == 0xF  # PP is for power-up; PI still F
    board.io_write(d.PORT_PAGE, d.PAGE_RESET_BIT)
    board.io_write(d.PORT_PAGE, 0)
    board.advance(10)
    assert installed[4].parameter == 6
    assert d.nibbles(host.read(d.PI, 16))[4] == 6


def test_a_slave_losing_two_telegrams_misses_one_cycle(installed, board, host: Host):
    host.ok(Command.READ_CLEAR_LCS)
    installed[4].lose_telegrams(2)
    board.advance(50)
    assert host.slaves(d.LAS) == {1, 3, 4} and host.ec_flags() & EcFlag.CONFIG_OK
    host.ok(Command.READ_CLEAR_LCS)
    assert d.slave_list(host.read(d.PROGRAM_BUFFER, 4)) == {4}


def test_interrupt_events(installed, board, host: Host):
    host.write(d.INTERRUPT_ENABLE, InterruptSource.CONFIG_OK_CHANGE | InterruptSource.IDI_CHANGE)
    board.advance(5)
    assert host.byte(d.INTERRUPT_EVENT) == 0 and not board.interrupt_request
    installed[1].inputs = 1
    board.advance(2)
    assert host.byte(d.INTERRUPT_EVENT) == InterruptSource.IDI_CHANGE and board.interrupt_request
    host.write(d.INTERRUPT_EVENT, 0)
    board.bus.remove(installed[4])
    board.advance(2)
    assert host.byte(d.INTERRUPT_EVENT) == InterruptSource.CONFIG_OK_CHANGE
    host.write(d.INTERRUPT_EVENT, 0)
    host.write(d.INTERRUPT_ENABLE, InterruptSource.ASI_CYCLE)
    board.advance(1)
    assert host.byte(d.INTERRUPT_EVENT) == InterruptSource.ASI_CYCLE


@pytest.mark.parametrize(("count", "period_us"), [(1, 300), (2, 450), (31, 4800)])
def test_asi_cycle_time(board, host: Host, count: int, period_us: int):
    for address in range(1, count + 1):
        board.bus.attach(Slave(address, *SENSOR))
    board.advance(20)
    host.ok(Command.READ_TELEGRAM_COUNTERS)
    board.advance(1000)
    host.ok(Command.READ_TELEGRAM_COUNTERS)
    requests = int.from_bytes(host.read(d.PROGRAM_BUFFER, 2), "little")
    cycles = requests / (count + 1)
    assert abs(cycles - 1_000_000 / period_us) <= 2 + 1_000_000 / period_us * 0.01
