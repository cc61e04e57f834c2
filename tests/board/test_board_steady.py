"""The board's steady path (``Pc2Board._steady_cycles``) against the general AS-i cycle.

The steady path runs an AS-i cycle in which nothing but the data exchange and the program
happens without asking ``_cycle``'s other questions. Here two boards with the same
program, slaves and host run through the same random history (inputs changing, host
writes, forces, stops and starts, a cycle time-out, an observer that pauses): one with
the steady path, one with every cycle through ``_cycle`` (``steady_path = False``). After
every step the two must agree on everything the master holds and shows.
"""

from __future__ import annotations

import random
import zlib

import pytest
from board_host import Host, compile_image

from asictl.board.asi import AsiBus, Slave
from asictl.board.board import Pc2Board
from asictl.board.forcing import Area
from asictl.platform import pc2 as d
from asictl.platform.master import ControlFlag
from asictl.platform.pc2 import HiFlag
from asictl.runtime import layout

#: Busy every cycle while I 2.1 is 0 (F 20.0 toggles), quiet between the blinks of its
#: timer while it is 1; outputs from inputs and flags; F 97 is a mapped counter's high
#: byte when the host maps the counters; an endless loop while I 1.3 is set (a cycle
#: time-out).
PROGRAM = """[SETUP]
1: iiii, 0
2: iiii, 0
3: oooo, 0
4: oooo, 0
[PROGRAM]
        A   I 1.0
        AN  I 1.1
        O   F 0.0
        =   Q 3.0
***
        A   I 2.0
        A   F 1.1
        =   Q 3.1
***
        AN  F 20.0
        AN  I 2.1
        =   F 20.0
        =   F 97.4
***
        A   F 20.1
        =   Q 4.2
***
        A   T 0
        JC  = blink
        N
        L   KT 30
        S   T 0
***
        AN  Q 4.0
        =   Q 4.0
blink:  A   I 1.3
        JC  = blink
        BE
"""

IMAGE = compile_image(PROGRAM)


def state(board: Pc2Board, slaves: list[Slave]) -> tuple[object, ...]:
    """What the master holds and shows (a difference here is a difference anywhere)."""
    runner = board.program
    cpu = runner.cpu if runner is not None else None
    ec = board.execution
    return (
        board.now_us, board._next_cycle_us, board._next_tick_us, board.dpram,
        board.outputs, board.control_state, board.stop_reason, board.stop_message,
        board.cycle_times_us, board.interrupt_request, ec.requests, ec.failures,
        bytes(ec.idi), [s.outputs for s in slaves],
        board._quiet, board._probe_wait, board._probe_gap, board._program_ready_us,
        board._odi_sent,
        None if cpu is None else (bytes(cpu.iram), bytes(cpu.sfr), cpu.pc, cpu.cycles,
                                  cpu.instructions,
                                  bytes(cpu.xdata.ram[: layout.DATA_LIMIT])),
    )


class Rig:
    """A board, its slaves, a host, and an observer that notes every cycle and pauses
    ``advance`` every so many cycles (how many, or never, by the history's seed)."""

    def __init__(self, steady: bool, seed: int) -> None:
        self.board = board = Pc2Board(bus=AsiBus())
        board.steady_path = steady
        self.slaves = [board.bus.attach(Slave(a, 0x0 if a < 3 else 0x8, 0x0))
                       for a in (1, 2, 3, 4)]
        self.host = Host(board)
        assert self.host.install(IMAGE) == d.ACK
        self.seen: list[tuple[int, bytes, bool, int]] = []
        self.pause_every = random.Random(seed).choice((0, 7, 50))
        board.observer = self.observe

    def observe(self) -> None:
        board = self.board
        self.seen.append((board.now_us, board.outputs, board.running, zlib.crc32(board.dpram)))
        if self.pause_every and len(self.seen) % self.pause_every == 0:
            board.pause()


def act(rig: Rig, rng: random.Random) -> None:
    """One step of a history: something the host, the bus, a force or the master's
    settings do, or nothing."""
    board, host, slaves = rig.board, rig.host, rig.slaves
    for slave in slaves:  # a slave unplugged comes back soon (a configuration error)
        if slave.bus is None and rng.random() < 0.5:
            board.bus.attach(slave)
    what = rng.randrange(20)  # 16 and more: nothing
    if what == 0:
        rng.choice(slaves[:2]).inputs = rng.randrange(16) & 0b0111  # not I 1.3
    elif what == 1:
        host.write(d.FLAGS + rng.choice((0, 1, 2, 97)), rng.randrange(256))
    elif what == 2:
        board.force(Area.OUTPUTS, 3, 0b0001, rng.randrange(2))
    elif what == 3:
        board.release()
    elif what == 4:
        board.force(Area.FLAGS, 1, 0x02, rng.choice((0, 0x02)))
    elif what == 5:
        host.control_flags(rng.choice((0, 1, int(ControlFlag.MAP_COUNTERS) | 1)))
    elif what == 6:
        host.control_flags(1)
    elif what == 7:
        if rng.random() < 0.2:
            slaves[0].inputs |= 0b1000  # the program loops: a cycle time-out
        else:
            host.set_outputs({3: rng.randrange(16)})  # a running program's ODI wins
    elif what == 8:
        slaves[0].inputs &= 0b0111
        board.press_set_button()
    elif what == 9:
        host.write(d.INTERRUPT_ENABLE, rng.randrange(8))
        host.write(d.INTERRUPT_EVENT, 0)
    elif what == 10:  # the execution control is not settled for a while
        slave = rng.choice(slaves)
        if slave.bus is not None:
            board.bus.remove(slave)
    elif what == 11:
        rng.choice(slaves).lost_telegrams = rng.randrange(3)
    elif what == 12:  # a setting changed behind the host's back: its image follows
        board.execution.set_permanent_parameters(bytes(rng.randrange(16) for _ in range(32)))
    elif what == 13:  # AS-i cycles shorter than the program: it waits for its end
        board.cycle_period_us = rng.choice((None, 25, 400, 5000))
    elif what == 14:
        host.write(d.HI_FLAGS, rng.choice((0, 0, int(HiFlag.DATA_EXCHANGE_OFF))))
    elif what == 15:
        board.execution.config_ok_delay = rng.randrange(1, 4)


@pytest.mark.parametrize("seed", range(16))
def test_the_steady_path_does_what_the_general_cycle_does(seed: int):
    rigs = [Rig(True, seed), Rig(False, seed)]
    histories = [random.Random(seed), random.Random(seed)]
    for step in range(80):
        for rig, rng in zip(rigs, histories, strict=True):
            act(rig, rng)
            rig.board.advance(rng.choice((0.5, 3, 5, 20, 77, 300)))
        steady, general = rigs
        assert state(steady.board, steady.slaves) == state(general.board, general.slaves), \
            f"seed {seed}, step {step}"
        assert steady.seen == general.seen


def test_the_steady_path_runs_the_busy_cycles():
    """Not vacuous: with nothing happening, the steady path runs the cycles between the
    probes, and the general ``_cycle`` only those."""
    rig = Rig(True, 0)
    rig.pause_every = 0
    rig.board.advance(100)
    calls = 0
    general = rig.board._cycle

    def counted() -> None:
        nonlocal calls
        calls += 1
        general()

    rig.board._cycle = counted  # type: ignore[method-assign]
    cycles = len(rig.seen)
    rig.board.advance(1000)
    ran = len(rig.seen) - cycles
    assert ran > 100 and calls < ran / 4
