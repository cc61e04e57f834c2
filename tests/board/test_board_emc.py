"""Command 130, the EMC test mode (PC2 manual 7.3, lines 443-457), through the port.

The parameters go to program buffer bytes 0-5, the counters come back in bytes 8-11
(requests, then failed or wrong answers, 16 bits each); each 130 reports and clears
them. The counts are checked against the cycles the board ran, counted independently
through the board's observer.
"""

from __future__ import annotations

import pytest
from board_host import Host

from asictl.board.asi import Slave
from asictl.board.board import Pc2Board
from asictl.platform import pc2 as d
from asictl.platform.pc2 import Command


def parameters(*, slaves: set[int], request: int, expected: int = 0, check: bool = False,
               repetitions: bool = False) -> bytes:
    """Bytes 0-5 as line 449 lays them out, written out bit by bit."""
    byte0 = repetitions | check << 1 | expected << 3
    data = bytes([byte0, request]) + d.list_bytes(slaves)
    assert data == d.emc_parameters(
        slaves, request, expected=expected if check else None, repetitions=repetitions
    )
    return data


def emc(host: Host, data: bytes) -> tuple[int, int]:
    """Command 130 with ``data``; the (requests, failures) it reports."""
    host.write(d.PROGRAM_BUFFER, data)
    assert host.command(Command.EMC_TEST_MODE) == d.ACK
    counts = host.read(d.PROGRAM_BUFFER + 8, 4)
    return int.from_bytes(counts[:2], "little"), int.from_bytes(counts[2:], "little")


@pytest.fixture
def running(board: Pc2Board, host: Host) -> Pc2Board:
    """Two slaves in normal operation; AS-i cycles of exactly 0.5 ms, so that counts are
    cycles: 200 in 100 ms."""
    board.cycle_period_us = 500
    board.bus.attach(Slave(1, 0x7, 0xF, inputs=0b0101))
    board.bus.attach(Slave(2, 0x7, 0xF, inputs=0b0011))
    board.advance(50)
    return board


def cycles_between(start_ms: float, end_ms: float) -> float:
    return (end_ms - start_ms) / 0.5


def test_the_letters_offer_it(host: Host):
    """Byte 3 of the installed software is 'E': the master has the EMC test mode (10.2.5)."""
    assert host.letters()[3] == "E"


def test_the_request_goes_to_the_listed_slaves_and_nothing_fails(running: Pc2Board, host):
    assert emc(host, parameters(slaves={1, 2}, request=0b00110)) == (0, 0)  # nothing before
    before = running.now_ms
    running.advance(100)
    requests, failures = emc(host, parameters(slaves={1, 2}, request=0b00110))
    cycles = cycles_between(before, running.now_ms)
    assert failures == 0
    assert abs(requests - 2 * cycles) <= 2 * 2, (requests, cycles)
    assert running.bus.slave(1).outputs == 0b0110  # a data call carries I0..I3
    assert emc(host, parameters(slaves=set(), request=0))[0] > 0  # the last report ...
    running.advance(10)
    assert emc(host, parameters(slaves=set(), request=0)) == (0, 0)  # ... and the mode ends


def test_a_missing_slave_fails_every_request_and_repetitions_double_them(
    running: Pc2Board, host: Host,
):
    """Each 130 reports what the test it ends counted: the parameters of the 130 before."""
    emc(host, parameters(slaves={1, 9}, request=0))
    running.advance(45)
    requests, failures = emc(host, parameters(slaves={9}, request=0, repetitions=True))
    assert requests == 2 * failures > 0  # slave 9 never answers; slave 1 always does
    before = running.now_ms
    running.advance(45)
    requests, failures = emc(host, parameters(slaves=set(), request=0))
    assert requests == failures  # every request to slave 9 fails ...
    cycles = cycles_between(before, running.now_ms)
    assert abs(requests - 2 * cycles) <= 4, "... and each is sent twice"


def test_checked_answers_must_be_the_expected_bits(running: Pc2Board, host: Host):
    """Slave 1 answers a data call with its inputs 0101b, slave 2 with 0011b."""
    checked = parameters(slaves={1, 2}, request=0, check=True, expected=0b0101)
    emc(host, checked)
    running.advance(45)
    requests, failures = emc(host, checked)
    assert requests == 2 * failures > 0  # slave 2's answer is wrong each time
    running.bus.slave(2).inputs = 0b0101
    emc(host, checked)
    running.advance(45)
    requests, failures = emc(host, checked)
    assert requests > 0 and failures == 0


def test_lost_telegrams_are_failed_requests(running: Pc2Board, host: Host):
    repeated = parameters(slaves={1}, request=0, repetitions=True)
    emc(host, repeated)
    running.bus.slave(1).lose_telegrams(3)
    running.advance(20)
    assert emc(host, parameters(slaves={1}, request=0))[1] == 3
    running.bus.slave(1).lose_telegrams(3)
    running.advance(20)
    assert emc(host, parameters(slaves={1}, request=0))[1] == 3, (
        "without repetitions, too, each lost telegram is one failed request"
    )


def test_a_parameter_call_is_answered_as_a_parameter(running: Pc2Board, host: Host):
    emc(host, parameters(slaves={1}, request=0x10 | 0x9, check=True, expected=0x9))
    running.advance(20)
    requests, failures = emc(host, parameters(slaves={1}, request=0))
    assert requests > 0 and failures == 0
    assert running.bus.slave(1).parameter == 0x9


def test_data_exchange_stops_while_the_test_runs_and_returns_after(
    running: Pc2Board, host: Host,
):
    host.write(d.ODI, bytes(0xFF - b for b in bytes([0x00, 0x0A] + [0] * 14)))  # slave 2: Ah
    running.advance(10)
    assert running.bus.slave(2).outputs == 0xA
    emc(host, parameters(slaves={1}, request=0))
    running.advance(10)
    assert running.bus.slave(2).outputs == 0, "no data calls: its watchdog switches it off"
    idi = host.read(d.IDI, 2)
    running.bus.slave(1).inputs = 0b1111
    running.advance(10)
    assert host.read(d.IDI, 2) == idi, "the IDI stands still"
    emc(host, parameters(slaves=set(), request=0))
    running.advance(10)
    assert running.bus.slave(2).outputs == 0xA
    assert host.read(d.IDI, 1)[0] >> 4 == 0b1111


def test_a_power_up_ends_the_mode(running: Pc2Board, host: Host):
    emc(host, parameters(slaves={1}, request=0))
    running.io_write(d.PORT_PAGE, d.PAGE_RESET_BIT)
    running.advance(200)
    running.io_write(d.PORT_PAGE, 0)
    running.advance(50)
    assert emc(host, parameters(slaves=set(), request=0)) == (0, 0)
    assert running.execution.emc is None


def test_idle_cycles_skipped_by_the_board_are_counted_alike(running: Pc2Board, host: Host):
    """A quiet board skips AS-i cycles; the test's counts must not notice."""
    emc(host, parameters(slaves={1, 2}, request=0))
    before = running.now_ms
    running.advance(1000)
    requests, _ = emc(host, parameters(slaves={1, 2}, request=0))
    assert abs(requests - 2 * cycles_between(before, running.now_ms)) <= 2 * 2
