"""Fixtures for the emulated Modbus gateway: a board with slaves and the slave in front of it."""

from __future__ import annotations

import pytest
from modbus_helpers import FakeClock

from asictl.board.asi import AsiBus, Slave
from asictl.board.board import Pc2Board
from asictl.gateway.panel import SELF_TEST_MS
from asictl.gateway.slave import GatewaySlave


@pytest.fixture
def board() -> Pc2Board:
    """Slave 1: 4 inputs (IO 0, ID 1); slave 6: 4 outputs (IO 8, ID 2); slave 13: bidirectional."""
    board = Pc2Board(bus=AsiBus())
    board.bus.attach(Slave(1, io_code=0x0, id_code=0x1))
    board.bus.attach(Slave(6, io_code=0x8, id_code=0x2))
    board.bus.attach(Slave(13, io_code=0x7, id_code=0xF))
    board.advance(SELF_TEST_MS + 100)  # past the front panel's display test (222)
    return board


@pytest.fixture
def clock() -> FakeClock:
    return FakeClock()


@pytest.fixture
def gw(board: Pc2Board, clock: FakeClock) -> GatewaySlave:
    return GatewaySlave(board, unit=1, clock=clock)
