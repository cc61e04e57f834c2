"""Fixtures for the emulated PC2 board: a board with its cable, and a host on its port."""

from __future__ import annotations

import pytest
from board_host import Host

from asictl.board.asi import AsiBus
from asictl.board.board import Pc2Board


@pytest.fixture
def board() -> Pc2Board:
    return Pc2Board(bus=AsiBus())


@pytest.fixture
def host(board: Pc2Board) -> Host:
    return Host(board)
