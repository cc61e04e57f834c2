"""Commissioning procedures on the emulated board and through Modbus (gateway and stub).

The oracle is the board's own state (its cable, its execution control), read apart from
the procedures under test.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import pytest
from gateway_stub import stub_gateway

from asictl.board.asi import Slave
from asictl.board.board import Pc2Board
from asictl.gateway.server import background_gateway
from asictl.gateway.slave import GatewaySlave
from asictl.host.commissioning import (
    Commissioning,
    ModbusCommissioning,
    NotOffered,
    Pc2Commissioning,
)
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.host.transports.jobs import JobError
from asictl.host.transports.modbus import open_modbus
from asictl.host.transports.target import parse_target
from asictl.image.eeprom import Configuration, SlaveConfig
from asictl.platform.master import ControlFlag


def board_with(*slaves: Slave, configuration_mode: bool = True) -> Pc2Board:
    board = Pc2Board()
    for slave in slaves:
        board.bus.attach(slave)
    board.advance(100)
    if not configuration_mode:
        Pc2Commissioning(Pc2Driver(EmulatedPort(board)), "300h").set_mode(configuration=False)
        board.advance(50)
    return board


@contextmanager
def commissioning(board: Pc2Board, kind: str) -> Iterator[Commissioning]:
    """The procedures for ``kind`` over ``board``; the board belongs to the server while
    a Modbus kind serves it."""
    if kind == "pc2":
        yield Pc2Commissioning(Pc2Driver(EmulatedPort(board)), "300h")
        return
    if kind == "stub":
        with stub_gateway(board) as url, open_modbus(parse_target(url)) as transport:
            yield ModbusCommissioning(transport)
        return
    with background_gateway(GatewaySlave(board)) as gateway:
        host, port = gateway.server.tcp_address
        with open_modbus(parse_target(f"tcp://{host}:{port}")) as transport:
            yield ModbusCommissioning(transport)


KINDS = pytest.mark.parametrize("kind", ["pc2", "gateway", "stub"])


@KINDS
def test_change_address(kind):
    board = board_with(Slave(9, 0x7, 0xF))
    with commissioning(board, kind) as tools:
        tools.change_address(9, 10)
    assert [s.address for s in board.bus] == [10]


@KINDS
@pytest.mark.parametrize(
    ("old", "new", "status"),
    [(9, 10, 0x83A1), (5, 6, 0x83A3)],
)
def test_a_refused_address_change_says_why(kind, old, new, status):
    board = board_with(Slave(5, 0x7, 0xF), Slave(6, 0x7, 0xF))
    with commissioning(board, kind) as tools, pytest.raises(JobError) as caught:
        tools.change_address(old, new)
    assert caught.value.status == status
    assert f"[STATUS {status:04X}h]" in str(caught.value)
    assert sorted(s.address for s in board.bus) == [5, 6], "nothing changed"


@KINDS
@pytest.mark.parametrize("new", [6, 0])
def test_a_slave_that_cannot_be_set_to_address_0_is_83a4(kind, new):
    """Status byte 05 (PC2 manual 10.2.7: "slave could not be programmed to address 0"):
    changing an address deletes it first, and this slave refuses; it keeps its address."""
    board = board_with(Slave(5, 0x7, 0xF, address_fault="delete"))
    with commissioning(board, kind) as tools, pytest.raises(JobError) as caught:
        tools.change_address(5, new)
    assert caught.value.status == 0x83A4
    assert "[STATUS 83A4h]" in str(caught.value)
    assert [s.address for s in board.bus] == [5]


@KINDS
def test_protected_mode_with_a_slave_zero_is_8385(kind):
    board = board_with(Slave(0, 0x7, 0xF))
    with commissioning(board, kind) as tools, pytest.raises(JobError) as caught:
        tools.set_mode(configuration=False)
    assert caught.value.status == 0x8385
    assert board.mode == "configuration"


@KINDS
def test_store_actual_configuration_and_parameters(kind):
    board = board_with(Slave(3, 0x7, 0xA), Slave(12, 0x1, 0x2))
    with commissioning(board, kind) as tools:
        tools.store_configuration()
        tools.write_parameter(3, 0x5)
        tools.store_parameters()
        tools.set_mode(configuration=False)
    ec = board.execution
    assert ec.lps == 1 << 3 | 1 << 12
    assert ec.pcd[3] == 0xA7 and ec.pcd[12] == 0x21
    assert ec.pp[3] == 0x5 and board.bus.slave(3).parameter == 0x5
    assert board.mode == "protected"


@KINDS
def test_store_configuration_refused_in_protected_mode(kind):
    board = board_with(Slave(3, 0x7, 0xA), configuration_mode=False)
    with commissioning(board, kind) as tools, pytest.raises(JobError) as caught:
        tools.store_configuration()
    assert caught.value.status == 0x8384 and "configuration mode" in str(caught.value)


@KINDS
def test_execute_command_answers(kind):
    board = board_with(Slave(3, 0x7, 0xA))
    with commissioning(board, kind) as tools:
        assert tools.execute_command(3, 0x10) == 0x7  # read I/O configuration
        assert tools.execute_command(3, 0x11) == 0xA  # read ID code


@KINDS
def test_flags_and_outputs(kind):
    board = board_with(Slave(3, 0x8, 0x0))
    with commissioning(board, kind) as tools:
        tools.write_flags(10, bytes([0x12, 0x34]))
        assert tools.read_flags()[10:12] == bytes([0x12, 0x34])
        tools.write_outputs({3: (0xF, 0b1010)})
        tools.write_outputs({3: (0b0001, 0b0001)})
    board.advance(20)
    assert board.dpram[0x20A:0x20C] == bytes([0x12, 0x34])
    assert board.bus.slave(3).outputs == 0b1011


def test_outputs_refused_while_the_program_runs(tmp_path):
    from asictl.build import build_file
    from asictl.host.transfer import Pc2Transport, StartMode, download

    board = board_with(Slave(31, 0x8, 0x0))
    transport = Pc2Transport(Pc2Driver(EmulatedPort(board)))
    built = build_file("demos/blink.asi", entry_points=transport.entry_points())
    assert built.image is not None
    download(transport, built.image, start=StartMode.START)
    board.advance(50)
    assert board.control_flags & ControlFlag.CONTROL_ACTIVE
    with pytest.raises(Exception, match="running and owns the outputs"):
        Pc2Commissioning(transport.driver, "300h").write_outputs({31: (0xF, 1)})


def test_diagnostics_read_and_clear_on_the_pc2():
    board = board_with(Slave(3, 0x7, 0xA))
    tools = Pc2Commissioning(Pc2Driver(EmulatedPort(board)), "300h")
    tools.set_configuration(Configuration.of([SlaveConfig(3, 0x7, 0xA, 0xF),
                                               SlaveConfig(4, 0x7, 0xA, 0xF)]))
    tools.set_los([7, 9])
    board.advance(50)
    first = tools.diagnostics()
    assert 4 in first.lcs, "slave 4 is projected but missing"
    assert first.los == [7, 9]
    assert first.telegrams > 0
    board.bus.attach(Slave(4, 0x7, 0xA))
    board.advance(50)
    tools.diagnostics()  # clears what came from the missing slave
    board.advance(20)
    assert tools.diagnostics().lcs == []


@pytest.mark.parametrize("kind", ["gateway", "stub"])
def test_the_gateway_has_no_diagnostics(kind):
    with commissioning(Pc2Board(), kind) as tools:
        with pytest.raises(NotOffered):
            tools.diagnostics()
        with pytest.raises(NotOffered):
            tools.set_los([3])
