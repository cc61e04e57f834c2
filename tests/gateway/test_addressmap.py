"""The chapter-7 address map over the master model: layouts, inversions, functions 1000-1009."""

from __future__ import annotations

from modbus_helpers import (
    FakeClock,
    bits,
    exception,
    read_holding,
    read_input,
    request,
    write_holding,
)

from asictl.board.asi import Slave
from asictl.board.execution import Phase
from asictl.gateway.addressmap import EXCEPTION_STATUS_ERROR
from asictl.gateway.slave import GatewaySlave
from asictl.platform import pc2 as d


def test_input_data_four_slaves_a_register_slave_4k_in_the_top_nibble(gw, board):
    board.bus.set_inputs(1, 0b1010)
    board.bus.set_inputs(13, 0b0011)
    board.advance(10)
    # register 0: slave 0 bits 12-15, slave 1 bits 8-11, slave 2 4-7, slave 3 0-3
    assert read_input(gw, 0, 4) == [0x0A00, 0, 0, 0x0300]
    assert read_holding(gw, 600, 4) == [0x0A00, 0, 0, 0x0300]
    # discrete inputs: slave 1 D0..D3 are 4..7, D1 and D3 set
    assert bits(gw, 2, 4, 4) == [False, True, False, True]


def test_output_data_reach_the_slave_and_the_inverted_odi(gw, board):
    write_holding(gw, 1, 0x0500)  # register 1: slave 4 bits 12-15, slave 5 8-11, slave 6 4-7
    write_holding(gw, 1, 0x0090)
    board.advance(10)
    assert board.bus.outputs(6) == 0x9
    assert board.dpram[d.ODI + 3] == 0xFF - 0x09  # slave 6 = low nibble of byte 3, inverted
    assert read_holding(gw, 1) == [0x0090]
    assert bits(gw, 1, 24, 4) == [True, False, False, True]
    assert request(gw, 5, "HH", 25, 0xFF00) == bytes([5, 0, 25, 0xFF, 0])
    board.advance(10)
    assert board.bus.outputs(6) == 0xB


def test_register_0_bits_12_15_are_reserved(gw, board):
    write_holding(gw, 0, 0xF000)
    assert read_holding(gw, 0) == [0]
    assert bits(gw, 1, 0, 4) == [False] * 4


def test_host_interface_flags_inverted_bits(gw, board):
    assert read_holding(gw, 8) == [0]  # data exchange active, online, auto address enabled
    assert bits(gw, 1, 128, 3) == [False, False, False]
    # coil 128 "Data_Exchange_Active (invertiert!)": setting it stops the data exchange
    assert request(gw, 5, "HH", 128, 0xFF00) is not None
    board.advance(10)
    assert not board.execution.data_exchange_active
    assert read_holding(gw, 399)[0] >> 8 == 0b001
    # coil 129 Off-line (not inverted) sends the master offline
    write_holding(gw, 8, 0b010)
    board.advance(10)
    assert board.phase is Phase.OFFLINE
    assert bits(gw, 2, 128 + 7, 1) == [True]  # ec-flag Offline_Ready
    write_holding(gw, 8, 0)
    board.advance(20)
    assert board.phase is Phase.NORMAL and board.execution.data_exchange_active


def test_ec_flags_and_lists(gw, board):
    ec = board.dpram[d.EC_FLAGS]
    assert read_input(gw, 8) == [ec]
    assert bits(gw, 2, 128, 8) == [bool(ec >> i & 1) for i in range(8)]
    detected = (1 << 1) | (1 << 6) | (1 << 13)
    assert read_input(gw, 9, 4) == [detected, 0, detected, 0]  # LAS (config mode), LDS
    assert read_holding(gw, 609, 4) == [detected, 0, detected, 0]
    assert bits(gw, 2, 300, 8) == [i in (1, 6) for i in range(8)]
    assert bits(gw, 2, 413, 1) == [True]
    # writes to master-owned registers are ignored without an error (manual 7.3)
    write_holding(gw, 609, 0)
    assert read_holding(gw, 609) == [detected]


def test_cdi_and_pcd_have_the_id_code_in_the_low_nibble(gw, board):
    # slave 6: I/O code 8, ID code 2 -> 0x82 on Modbus; the PC2 byte is 0x28
    assert board.dpram[d.CDI + 6] == 0x28
    assert read_input(gw, 106) == [0x82]
    assert read_holding(gw, 706) == [0x82]
    write_holding(gw, 305, 0x37)  # PCD slave 5: ID 7, I/O 3
    assert board.dpram[d.PCD + 5] == 0x73
    assert board.execution.pcd[5] == 0x73
    assert read_holding(gw, 305) == [0x37]


def test_lps_words_and_coils(gw, board):
    write_holding(gw, 140, 0b0100_0000_0100_0010)  # slaves 1, 6, 14
    write_holding(gw, 141, 0x0001)  # slave 16
    assert board.execution.lps == (1 << 1) | (1 << 6) | (1 << 14) | (1 << 16)
    assert bits(gw, 1, 200, 8) == [i in (1, 6) for i in range(8)]
    assert request(gw, 5, "HH", 213, 0xFF00) is not None
    assert read_holding(gw, 140, 2) == [0b0110_0000_0100_0010, 1]


def test_parameters_pi_pp(gw, board):
    write_holding(gw, 106, 0x5)  # Write_Parameter to slave 6
    assert board.bus.slave(6).parameter == 0x5
    assert read_holding(gw, 106) == [0x5]
    assert bits(gw, 1, 300 + 4 * 6, 4) == [True, False, True, False]
    assert request(gw, 7) == bytes([7, 0x05])  # slave's answer (echo) in bits 0-3, no error
    write_holding(gw, 206, 0x3)  # projected parameter
    assert board.execution.pp[6] == 0x3
    assert bits(gw, 1, 500 + 4 * 6, 4) == [True, True, False, False]


def test_user_memory_m0_m127_both_layouts(gw, board):
    write_holding(gw, 400, 0x12)
    write_holding(gw, 527, 0xAB)
    assert board.dpram[d.FLAGS] == 0x12 and board.dpram[d.FLAGS + 127] == 0xAB
    assert read_holding(gw, 800) == [0x1200]
    assert read_holding(gw, 863) == [0x00AB]
    write_holding(gw, 801, 0x3456)  # M2 high byte, M3 low byte
    assert read_holding(gw, 402, 2) == [0x34, 0x56]
    assert exception(gw, 6, "HH", 400, 0x100) == 3


def test_operation_mode_and_function_7(gw, board):
    assert read_holding(gw, 1000) == [1]  # a new master is in configuration mode
    write_holding(gw, 1004, 1)  # Store_Actual_Configuration
    assert request(gw, 7) == bytes([7, 0])
    assert board.execution.lps == (1 << 1) | (1 << 6) | (1 << 13)
    write_holding(gw, 1000, 0)
    assert board.mode == "protected" and read_holding(gw, 1000) == [0]
    write_holding(gw, 1004, 1)  # refused in protected mode: the error bit
    assert request(gw, 7)[1] & EXCEPTION_STATUS_ERROR


def test_change_slave_address(gw, board):
    write_holding(gw, 1001, 13)
    write_holding(gw, 1002, 20)
    board.advance(20)
    assert board.bus.at(20) and not board.bus.at(13)
    assert request(gw, 7) == bytes([7, 0])
    write_holding(gw, 1001, 30)  # no slave there
    write_holding(gw, 1002, 21)
    assert request(gw, 7) == bytes([7, EXCEPTION_STATUS_ERROR | d.Status.NO_SLAVE])


def test_a_slave_that_cannot_be_deleted_is_status_05_in_function_7(gw, board):
    """PC2 status byte 05 (10.2.7): the slave cannot be set to address 0, the first step
    of every address change; the gateway keeps it as the exception status (6.3.10)."""
    board.bus.attach(Slave(20, 0x0, 0x0, address_fault="delete"))
    board.advance(20)
    write_holding(gw, 1001, 20)
    write_holding(gw, 1002, 21)
    board.advance(20)
    assert request(gw, 7) == bytes([7, EXCEPTION_STATUS_ERROR | d.Status.CANNOT_PROGRAM_ZERO])
    assert board.bus.at(20) and not board.bus.at(21)


def test_execute_command_answer_in_function_7(gw, board):
    expected = board.bus.slave(6).command(0x10)
    write_holding(gw, 1005, 6)
    write_holding(gw, 1006, 0x10)
    assert request(gw, 7) == bytes([7, expected & 0xF])
    write_holding(gw, 1005, 30)
    write_holding(gw, 1006, 0x10)
    assert request(gw, 7)[1] & EXCEPTION_STATUS_ERROR


def test_start_stop_register_is_the_control_flags_byte(gw, board):
    write_holding(gw, 1009, 0b0000_1100)  # ignore config errors, wait for set button
    assert board.control_flags & 0x0C == 0x0C
    assert read_holding(gw, 1009)[0] & 0x1F == 0x0C
    write_holding(gw, 1009, 0b11)  # start + reset: no program in the EEPROM
    assert read_holding(gw, 1009)[0] & 0x02 == 0  # the reset bit never reads back
    assert request(gw, 7)[1] & EXCEPTION_STATUS_ERROR  # nothing to load


def test_key_lock_and_watchdog_letters(gw, board):
    assert request(gw, 65, "BB", 1, 3)[2:18] == b"cBFE....DoA...wT"
    write_holding(gw, 1007, 1)
    write_holding(gw, 1008, 50)
    assert read_holding(gw, 1007) == [1]
    assert request(gw, 65, "BB", 1, 3)[2:18] == b"cBFE....DoA...Wt"


def test_modbus_watchdog_sends_the_master_offline(gw, board, clock: FakeClock):
    write_holding(gw, 1008, 5)  # 50 ms
    clock.now += 0.03
    assert read_holding(gw, 1008) == [3]  # longest pause between telegrams, 10 ms units
    clock.now += 0.04
    gw.sync()
    assert board.phase is not Phase.OFFLINE  # fed 40 ms ago
    clock.now += 0.2
    gw.sync()
    assert board.phase is Phase.OFFLINE
    assert bits(gw, 1, 129, 1) == [True]  # stays offline until the host clears Off-line
    write_holding(gw, 1008, 0)
    assert read_holding(gw, 1008) == [0]
    assert request(gw, 5, "HH", 129, 0) is not None
    board.advance(20)
    assert board.phase is Phase.NORMAL


def test_illegal_addresses_values_counts(gw):
    assert exception(gw, 3, "HH", 9, 1) == 2
    assert exception(gw, 3, "HH", 0, 16) == 3  # more than 15 registers
    assert exception(gw, 4, "HH", 13, 1) == 2
    assert exception(gw, 4, "HH", 0, 0) == 3
    assert exception(gw, 1, "HH", 126, 8) == 2  # 128..130 exist, 131 does not
    assert exception(gw, 2, "HH", 136, 1) == 2
    assert exception(gw, 5, "HH", 0, 0x1234) == 3
    assert exception(gw, 6, "HH", 100, 0x10) == 3  # a parameter is a nibble
    assert exception(gw, 6, "HH", 1010, 0) == 2
    assert exception(gw, 20) == 1  # Read File Record is not provided (17 identifies asictl)
    assert exception(gw, 99) == 1
    assert exception(gw, 16, "HHB" + "H" * 16, 400, 16, 32, *range(16)) == 3
    assert exception(gw, 16, "HHBH", 400, 2, 4, 1) == 3  # byte count lies
    assert exception(gw, 15, "HHBB", 0, 9, 1, 0xFF) == 3
    assert exception(gw, 3, "H", 0) == 3  # truncated


def test_multiple_writes(gw, board):
    response = request(gw, 16, "HHB" + "H" * 3, 400, 3, 6, 1, 2, 3)
    assert response == bytes([16, 1, 0x90, 0, 3])
    assert board.dpram[d.FLAGS : d.FLAGS + 3] == b"\x01\x02\x03"
    assert request(gw, 15, "HHBB", 24, 4, 1, 0b0110) == bytes([15, 0, 24, 0, 4])
    board.advance(10)
    assert board.bus.outputs(6) == 0b0110


def test_unit_id_other_slaves_are_ignored(board, clock):
    gw = GatewaySlave(board, unit=7, clock=clock)
    assert request(gw, 3, "HH", 0, 1, unit=1) is None
    assert request(gw, 3, "HH", 0, 1, unit=7) is not None
