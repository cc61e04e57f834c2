"""Every host command of the PC2 (manual 7.3), driven through the port like a driver does."""

from __future__ import annotations

import pytest
from board_host import Host, compile_image

from asictl.board.asi import Slave
from asictl.board.board import Pc2Board
from asictl.platform import pc2 as d
from asictl.platform.master import CONTROL_FLAGS_NONVOLATILE, EEPROM_SIZE, ControlFlag
from asictl.platform.pc2 import Command, ProgramStatus, Status
from asictl.runtime.layout import default_entry_points


def settle(board: Pc2Board) -> None:
    board.advance(30)


@pytest.fixture
def two_slaves(board: Pc2Board) -> tuple[Slave, Slave]:
    """Slave 1 a sensor (I/O 0, ID 1), slave 3 four outputs (I/O 8, ID 0): configuration mode."""
    slaves = board.bus.attach(Slave(1, 0x0, 0x1)), board.bus.attach(Slave(3, 0x8, 0x0))
    settle(board)
    return slaves


def protect(host: Host, lps: set[int], pcd: dict[int, int]) -> None:
    image = bytearray([0xFF]) * 32
    for a, profile in pcd.items():
        image[a] = profile
    host.write(d.LPS, d.list_bytes(lps))
    host.ok(Command.SET_LPS)
    host.write(d.PCD, image)
    host.ok(Command.SET_PERMANENT_CONFIGURATION)
    host.ok(Command.SET_OPERATION_MODE, data=0)
    settle(host.board)


@pytest.mark.parametrize("code", [1, 2, 4, 6, 9, 11, 13, 21, 55, 57, 73, 127, 131, 200, 254])
def test_unknown_codes_are_refused(host: Host, code: int):
    assert host.command(code) == d.NAK


def test_writing_00_or_ff_issues_nothing(board: Pc2Board, host: Host):
    host.write(d.COMMAND, d.NAK)
    board.advance(10)
    assert host.byte(d.COMMAND) == d.NAK


# --- parameters -------------------------------------------------------------------


def test_3_set_permanent_parameter(board: Pc2Board, host: Host):
    pp = bytearray([0xFF] * 16)
    pp[1] = 0x5F  # slave 3 = 5
    host.write(d.PP, pp)
    host.ok(Command.SET_PERMANENT_PARAMETER)
    assert board.execution.pp[3] == 5
    assert board.nonvolatile()["pp"][2:4] == "5f"
    assert host.read(d.PP, 16) == pp


def test_5_write_parameter_answers_with_the_slaves_response(two_slaves, board, host: Host):
    sensor, actuator = two_slaves
    host.ok(Command.WRITE_PARAMETER, data=0x6, address=3)
    assert actuator.parameter == 6
    assert host.byte(d.DATA) == 6  # echoed
    assert d.nibbles(host.read(d.PI, 16))[3] == 6
    sensor.parameter_echo, sensor.parameter_response = False, 0x9
    host.ok(Command.WRITE_PARAMETER, data=0x2, address=1)
    assert host.byte(d.DATA) == 0x9 and sensor.parameter == 2


def test_5_write_parameter_to_an_inactive_slave_is_refused_but_kept_in_pi(two_slaves, host):
    assert host.command(Command.WRITE_PARAMETER, data=0x4, address=7) == d.NAK
    assert d.nibbles(host.read(d.PI, 16))[7] == 4
    assert host.command(Command.WRITE_PARAMETER, data=0x4, address=40) == d.NAK


def test_pi_written_by_the_host_is_sent_cyclically(two_slaves, board, host: Host):
    _, actuator = two_slaves
    pi = bytearray(host.read(d.PI, 16))
    pi[1] = pi[1] & 0x0F | 0xA0  # slave 3
    host.write(d.PI, pi)
    board.advance(2)
    assert actuator.parameter == 0xA


def test_7_store_actual_parameter(two_slaves, board, host: Host):
    host.ok(Command.WRITE_PARAMETER, data=0x3, address=3)
    host.ok(Command.STORE_ACTUAL_PARAMETER)
    assert board.execution.pp[3] == 3
    assert d.nibbles(host.read(d.PP, 16))[3] == 3


# --- configuration -------------------------------------------------------------------


def test_8_set_permanent_configuration_only_in_configuration_mode(board, host: Host):
    pcd = bytearray([0xFF]) * 32
    pcd[5] = 0x18
    host.write(d.PCD, pcd)
    host.ok(Command.SET_PERMANENT_CONFIGURATION)
    assert board.execution.pcd[5] == 0x18
    host.ok(Command.SET_OPERATION_MODE, data=0)
    pcd[5] = 0x77
    host.write(d.PCD, pcd)
    assert host.command(Command.SET_PERMANENT_CONFIGURATION) == d.NAK
    assert host.byte(d.PCD + 5) == 0x18  # the image shows what the master kept


def test_10_store_actual_configuration(two_slaves, board, host: Host):
    host.ok(Command.STORE_ACTUAL_CONFIGURATION)
    assert host.slaves(d.LPS) == {1, 3}
    assert host.byte(d.PCD + 1) == 0x10 and host.byte(d.PCD + 3) == 0x08
    assert host.byte(d.PCD + 2) == 0xFF
    settle(board)
    assert host.ec_flags() & d.EcFlag.CONFIG_OK
    host.ok(Command.SET_OPERATION_MODE, data=0)
    assert host.command(Command.STORE_ACTUAL_CONFIGURATION) == d.NAK


def test_12_set_lps_never_projects_slave_0(board, host: Host):
    host.write(d.LPS, d.list_bytes({0, 4, 31}))
    host.ok(Command.SET_LPS)
    assert host.slaves(d.LPS) == {4, 31}
    assert board.nonvolatile()["lps"] == [4, 31]


def test_12_set_lps_refused_in_protected_mode(board, host: Host):
    host.ok(Command.SET_OPERATION_MODE, data=0)
    host.write(d.LPS, d.list_bytes({4}))
    assert host.command(Command.SET_LPS) == d.NAK
    assert host.slaves(d.LPS) == set()


def test_17_set_operation_mode(board, host: Host):
    host.ok(Command.SET_OPERATION_MODE, data=0)
    assert board.mode == "protected" and not host.ec_flags() & d.EcFlag.CONFIGURATION_ACTIVE
    host.ok(Command.SET_OPERATION_MODE, data=0x80)
    assert board.mode == "configuration" and host.ec_flags() & d.EcFlag.CONFIGURATION_ACTIVE


def test_17_protected_mode_refused_while_a_slave_0_is_present(board, host: Host):
    board.bus.attach(Slave(0, 0, 0))
    settle(board)
    assert host.ec_flags() & d.EcFlag.LDS_0
    assert host.command(Command.SET_OPERATION_MODE, data=0) == d.NAK
    assert board.mode == "configuration"


# --- slaves ---------------------------------------------------------------------------


def test_20_change_slave_address(two_slaves, board, host: Host):
    sensor, _ = two_slaves
    host.ok(Command.CHANGE_SLAVE_ADDRESS, data=9, address=1)
    assert host.byte(d.DATA) == Status.OK and sensor.address == 9
    settle(board)
    assert host.slaves(d.LDS) == {3, 9}


@pytest.mark.parametrize(
    ("old", "new", "status"),
    [
        (5, 9, Status.NO_SLAVE),
        (1, 3, Status.ADDRESS_OCCUPIED),
        (1, 1, Status.ADDRESS_OCCUPIED),
        (1, 40, Status.ERROR),
    ],
)
def test_20_change_slave_address_failures(two_slaves, host: Host, old, new, status):
    assert host.command(Command.CHANGE_SLAVE_ADDRESS, data=new, address=old) == d.NAK
    assert host.byte(d.DATA) == status


def test_20_address_0_must_be_free(two_slaves, board, host: Host):
    board.bus.attach(Slave(0, 0, 0))
    settle(board)
    assert host.command(Command.CHANGE_SLAVE_ADDRESS, data=0, address=1) == d.NAK
    assert host.byte(d.DATA) == Status.SLAVE_ZERO_PRESENT
    host.ok(Command.CHANGE_SLAVE_ADDRESS, data=12, address=0)  # a new slave gets an address
    settle(board)
    assert host.slaves(d.LDS) == {1, 3, 12}


def test_22_execute_command(two_slaves, host: Host):
    host.ok(Command.EXECUTE_COMMAND, data=0x10, address=3)  # read I/O configuration
    assert host.byte(d.DATA) == 0x8
    host.ok(Command.EXECUTE_COMMAND, data=0x11, address=1)  # read ID code
    assert host.byte(d.DATA) == 0x1
    assert host.command(Command.EXECUTE_COMMAND, data=0x05, address=1) == d.NAK
    assert host.command(Command.EXECUTE_COMMAND, data=0x10, address=2) == d.NAK


# --- AS-i Control -----------------------------------------------------------------------


def test_50_reset_with_an_empty_eeprom_is_refused(board, host: Host):
    assert host.control_flags(ControlFlag.RESET | ControlFlag.START) == d.NAK
    assert host.byte(d.PROGRAM_STATUS) == ProgramStatus.NOT_LOADED
    assert host.byte(d.STOP_REASON) == d.StopReason.NO_PROGRAM
    assert host.byte(d.CONTROL_FLAGS) == ControlFlag.START  # reset reads back 0
    assert "no program image" in board.stop_message


def test_50_reset_with_a_corrupted_image_reports_it(board, host: Host):
    image = bytearray(compile_image("[PROGRAM]\n    A I 1.0\n    = Q 2.0\n").to_bytes())
    image[-1] ^= 0xFF
    host.download(bytes(image))
    assert host.control_flags(ControlFlag.RESET) == d.NAK
    assert host.byte(d.PROGRAM_STATUS) == ProgramStatus.BAD_IMAGE
    assert "CRC" in board.program_error and "CRC" in board.stop_message


def test_50_flags_are_non_volatile_and_control_active_read_only(board, host: Host):
    assert host.control_flags(0xFF & ~ControlFlag.RESET) == d.ACK
    flags = CONTROL_FLAGS_NONVOLATILE
    assert host.byte(d.CONTROL_FLAGS) == flags  # no program: not active
    assert board.nonvolatile()["control_flags"] == flags


def test_51_get_status_updates_flags_and_cycle_times(board, host: Host):
    board.bus.attach(Slave(1, 0, 0))
    image = compile_image("[SETUP]\n1: iiii, 0\n[PROGRAM]\n    A I 1.0\n    = F 0.0\n")
    assert host.install(image) == d.ACK
    board.advance(20)
    host.write(d.CONTROL_FLAGS, 0)  # scribbled by the host: 51 writes the truth
    host.ok(Command.GET_STATUS)
    assert host.byte(d.CONTROL_FLAGS) == ControlFlag.START | ControlFlag.CONTROL_ACTIVE
    previous, maximum = (int.from_bytes(host.read(a, 2), "little") for a in (0x300, 0x302))
    assert 1 <= previous <= maximum
    assert previous == -(-board.cycle_times_us[0] // d.CYCLE_TIME_UNIT_US)


# --- download and upload ----------------------------------------------------------------


def test_52_53_blocks_of_up_to_240_bytes(board, host: Host):
    data = bytes(range(256)) * 3
    host.download(data, start=0x1000)
    assert board.eeprom[0x1000 : 0x1000 + len(data)] == data
    assert host.upload(0x1000, len(data)) == data


@pytest.mark.parametrize(
    ("size", "start", "answer"),
    [
        (240, 0, d.ACK),
        (241, 0, d.NAK),
        (0, 0, d.NAK),
        (16, EEPROM_SIZE - 16, d.ACK),
        (16, EEPROM_SIZE - 15, d.NAK),
        (1, 0x8000, d.NAK),
    ],
)
def test_52_53_eeprom_limits(host: Host, size: int, start: int, answer: int):
    for code in (Command.DOWNLOAD, Command.UPLOAD):
        assert host.command(code, data=size, address=start & 0xFF, extension=start >> 8) == answer


def test_53_from_ff00h_reads_the_entry_point_table(host: Host):
    table = host.upload(d.ENTRY_TABLE_ADDRESS, d.ENTRY_TABLE_SIZE)
    entries = [int.from_bytes(table[i : i + 2], "little") for i in range(0, 32, 2)]
    assert entries == list(default_entry_points().values())
    assert entries[0] == 0x0100 and entries[-1] == 0x013C  # SetPP ... GetId
    assert host.upload(d.ENTRY_TABLE_ADDRESS + 30, 2) == table[30:]
    assert host.command(Command.UPLOAD, data=3, address=0x1E, extension=0xFF) == d.NAK


def test_54_56_communication_memory_with_consistency(board, host: Host):
    host.write(d.PROGRAM_BUFFER, b"\x11\x22\x33")
    host.ok(Command.WRITE_COMM_MEMORY, data=3, address=0xFD)
    assert board.dpram[0x2FD:0x300] == b"\x11\x22\x33"
    host.write(0x240, b"\x44\x55")
    host.ok(Command.READ_COMM_MEMORY, data=2, address=0x40)
    assert host.read(d.PROGRAM_BUFFER, 2) == b"\x44\x55"
    assert host.command(Command.WRITE_COMM_MEMORY, data=4, address=0xFD) == d.NAK
    assert host.command(Command.READ_COMM_MEMORY, data=241, address=0) == d.NAK


# --- diagnostics ----------------------------------------------------------------------


def test_70_read_and_clear_lcs(two_slaves, board, host: Host):
    protect(host, {1, 3}, {1: 0x10, 3: 0x08})
    host.ok(Command.READ_CLEAR_LCS)  # whatever the set-up left
    sensor, _ = two_slaves
    board.bus.remove(sensor)
    settle(board)
    board.bus.attach(sensor)
    settle(board)
    assert host.ec_flags() & d.EcFlag.CONFIG_OK
    host.ok(Command.READ_CLEAR_LCS)
    assert d.slave_list(host.read(d.PROGRAM_BUFFER, 4)) == {1}
    host.ok(Command.READ_CLEAR_LCS)
    assert d.slave_list(host.read(d.PROGRAM_BUFFER, 4)) == set()


def test_70_lcs_shows_power_fail_as_slave_0(two_slaves, board, host: Host):
    board.bus.power_fail()
    settle(board)
    board.bus.power_restore()
    settle(board)
    host.ok(Command.READ_CLEAR_LCS)
    assert 0 in d.slave_list(host.read(d.PROGRAM_BUFFER, 4))


def test_71_error_counters(two_slaves, board, host: Host):
    _, actuator = two_slaves
    actuator.lose_telegrams(1)
    settle(board)
    assert host.slaves(d.LAS) == {1, 3}  # repeated at once: no configuration error
    host.ok(Command.READ_CLEAR_ERROR_COUNTERS)
    counters = host.read(d.PROGRAM_BUFFER, 32)
    assert counters[3] == 1 and counters[1] == 0
    host.ok(Command.READ_CLEAR_ERROR_COUNTERS)
    assert host.read(d.PROGRAM_BUFFER, 32) == bytes(32)


def test_71_error_counters_saturate(two_slaves, board, host: Host):
    _, actuator = two_slaves
    actuator.lose_telegrams(300)
    board.advance(200)
    host.ok(Command.READ_CLEAR_ERROR_COUNTERS)
    assert host.byte(d.PROGRAM_BUFFER + 3) == 255


def test_72_set_los(board, host: Host):
    host.write(d.LOS, d.list_bytes({2, 7}))
    host.ok(Command.SET_LOS)
    assert board.nonvolatile()["los"] == [2, 7]


def test_128_update_dpram_rewrites_all_but_watchdog_and_odi(two_slaves, board, host: Host):
    expected = board.dpram
    host.write(d.MASTER_NAME, b"xxxx")
    host.write(d.LPS, b"\x0f")
    host.write(d.WATCHDOG_COUNTER, 0x33)
    host.write(d.ODI, 0x12)
    host.ok(Command.UPDATE_DPRAM)
    after = board.dpram
    assert after[d.MASTER_NAME : d.MASTER_NAME + 4] == expected[d.MASTER_NAME : d.MASTER_NAME + 4]
    assert after[d.LPS] == expected[d.LPS]
    assert after[d.WATCHDOG_COUNTER] == 0x33 and after[d.ODI] == 0x12


def test_master_owned_bytes_are_rewritten_cyclically(two_slaves, board, host: Host):
    host.write(d.LAS, b"\x00\x00\x00\x00")
    host.write(d.EC_FLAGS, 0xFF)
    board.advance(2)
    assert host.slaves(d.LAS) == {1, 3}
    assert host.byte(d.EC_FLAGS) != 0xFF


def test_129_telegram_counters(two_slaves, board, host: Host):
    host.ok(Command.READ_TELEGRAM_COUNTERS)
    two_slaves[0].lose_telegrams(2)
    board.advance(100)
    host.ok(Command.READ_TELEGRAM_COUNTERS)
    buffer = host.read(d.PROGRAM_BUFFER, 4)
    requests, failures = (int.from_bytes(buffer[i : i + 2], "little") for i in (0, 2))
    cycles = 100_000 // (150 * 3)
    assert cycles - 5 <= requests // 3 <= cycles + 5
    assert failures == 2
