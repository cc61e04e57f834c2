"""The PC2 manual's own host programs (10.3), ported line by line, against the board.

They reach the board as the C code does: ``inp``/``outp`` on the PC's I/O space, where the
board decodes its three registers at the jumpered base address and nothing else answers.
Each port access takes a microsecond of master time (an 8-bit ISA I/O cycle), so the
samples' polling loops see the board work while they wait, as they would on a PC.
"""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from asictl.board.asi import AsiBus, Slave
from asictl.board.board import Pc2Board
from asictl.board.execution import Phase
from asictl.board.images import VERSION_ID
from asictl.platform import pc2 as d

BASE_ADDRESS = 0x300
ACCESS_MS = 0.001


class IsaBus:
    """The PC's I/O space with one PC2 board at ``base``; other ports read FFh."""

    def __init__(self, board: Pc2Board, base: int = BASE_ADDRESS) -> None:
        self.board = board
        self.base = base

    def inp(self, port: int) -> int:
        self.board.advance(ACCESS_MS)
        if self.base <= port <= self.base + d.PORT_PAGE:
            return self.board.io_read(port - self.base)
        return 0xFF

    def outp(self, port: int, value: int) -> None:
        self.board.advance(ACCESS_MS)
        if self.base <= port <= self.base + d.PORT_PAGE:
            self.board.io_write(port - self.base, value & 0xFF)

    def time(self) -> float:
        """time(): seconds, here of master time."""
        return self.board.now_ms / 1000


# --- 10.3.3: CheckAsiPc2 ---------------------------------------------------------------

O_DATA = 0
ASI_PC2_NAME = b"AS-i PC2"


def check_asi_pc2(isa: IsaBus, io_port: int) -> int:
    """0: AS-i PC2 found at io_port; 1: io_port out of range; 2, 3: no PC2 found there."""
    if io_port < 0x100 or io_port > 0x3FF or io_port & 0x0003:
        return 1
    # read page 0
    test_pad = bytes(isa.inp(io_port + O_DATA) for _ in range(512))
    # search for name string
    for i in range(len(test_pad)):
        if test_pad[i : i + 8] == ASI_PC2_NAME:
            break
    else:
        return 3
    # check firmware version identifier
    identifier = test_pad[i + 64 : i + 72]
    if len(identifier) != 8 or not all(ord("0") <= c <= ord("9") for c in identifier):
        return 2
    # AS-i PC2 found
    return 0


def test_check_asi_pc2_finds_the_board():
    """The manual's board check needs eight digits 64 bytes after "AS-i PC2"."""
    isa = IsaBus(Pc2Board(bus=AsiBus()))
    assert check_asi_pc2(isa, BASE_ADDRESS) == 0


@given(st.integers(0, d.DPRAM_SIZE - 1))
def test_check_asi_pc2_finds_the_board_wherever_index_and_page_point(address: int):
    """It sets neither INDEX nor PAGE: 512 reads always pass all of page 0 once."""
    board = Pc2Board(bus=AsiBus())
    board.io_write(d.PORT_PAGE, address >> 8)
    board.io_write(d.PORT_INDEX, address & 0xFF)
    assert check_asi_pc2(IsaBus(board), BASE_ADDRESS) == 0


def test_check_asi_pc2_elsewhere():
    isa = IsaBus(Pc2Board(bus=AsiBus()))
    assert check_asi_pc2(isa, 0x304) == 3  # nothing answers there
    assert check_asi_pc2(isa, 0x302) == 1  # not a base address
    assert check_asi_pc2(isa, 0x400) == 1


def test_the_version_id_is_what_get_id_and_check_asi_pc2_read():
    ram = Pc2Board(bus=AsiBus()).dpram
    assert ram[d.VERSION_ID : d.VERSION_ID + d.VERSION_ID_SIZE] == VERSION_ID
    assert len(VERSION_ID) == d.VERSION_ID_SIZE and VERSION_ID.isdigit()
    assert ram.index(ASI_PC2_NAME) + 64 == d.VERSION_ID


# --- 10.3.1: ansidemo.c ----------------------------------------------------------------

# AS-i configuration: one standard sensor (IO=0x01, ID=0x01) and one 4xout module
# (IO=0x08, ID=0x00). C fills the rest of a static array with zeros.
LPS = bytes([0x06, 0x00, 0x00, 0x00])
PCD = bytes([0xFF, 0x11, 0x08, 0xFF] + [0xFF] * 8 + [0x00] * 20)
PP = bytes([0xFF] * 16)

# offsets of the 3 registers of the AS-i PC2 board
DATA, INDEX, PAGE = 0, 1, 2
# addresses in the DPRAM
D_COMMAND = 0x1F0
D_DATA = 0x1F1
D_LPS = 0x12C
D_PCD = 0x150
D_PP = 0x180
D_PI = 0x170
D_EC_FLAGS = 0x112
D_WDOG_ENA = 0x100
D_WDOG_CNT = 0x101
D_IDI = 0x102
D_ODI = 0x113
# command codes (used for the DPRAM's command byte)
C_SET_MODE = 17
C_SET_PP = 3
C_SET_PCD = 8
C_SET_LPS = 12


class AnsiDemo:
    """ansidemo.c: configure the master, then copy slave 1's sensor to slave 2's output.

    ``printf`` goes to ``screen``; ``main``'s early returns are ``DemoStopped``.
    """

    def __init__(self, isa: IsaBus) -> None:
        self.isa = isa
        self.screen: list[str] = []
        self.odata = bytearray([0xFF] * 16)
        self.which_bar_to_print = 1

    # the macros for addressing, reading and writing of the DPRAM
    def page(self, loc: int) -> None:
        self.isa.outp(BASE_ADDRESS + PAGE, loc >> 8)

    def index(self, loc: int) -> None:
        self.isa.outp(BASE_ADDRESS + INDEX, loc & 0xFF)

    def read(self) -> int:
        return self.isa.inp(BASE_ADDRESS + DATA)

    def write(self, value: int) -> None:
        self.isa.outp(BASE_ADDRESS + DATA, value)

    def printf(self, text: str) -> None:
        self.screen.append(text)

    def send_cmd(self, command: int) -> int:
        """0: o.k. (ACK); 1: o.k. (NAK); 3: invalid response; 4: timeout."""
        self.page(D_COMMAND)  # write the command code to DPRAM
        self.index(D_COMMAND)
        self.write(command)
        c = command
        timer = self.isa.time()  # store actual time
        while True:
            self.index(D_COMMAND)  # read command byte from DPRAM!
            c = self.read()
            if c != command:  # break loop, if command byte is changing...
                break
            if not self.isa.time() - timer < 0.2:  # ...or end loop after 200 ms (timeout)!
                break
        if c == command:
            return 0x0004  # timeout
        if c == 0x00:
            return 0x0000  # ACK
        if c == 0xFF:
            return 0x0001  # NAK
        return 0x0003  # invalid

    def configure(self) -> None:
        """main() up to "communication for ever"."""
        # disable watchdog
        self.page(D_WDOG_ENA)
        self.index(D_WDOG_ENA)
        self.write(0x00)
        # switch to configuration mode: write something bigger than 1 to "data"
        self.page(D_DATA)
        self.index(D_DATA)
        self.write(0x01)
        if self.send_cmd(C_SET_MODE):
            self.stop("can't switch to configuration mode.")
        # write new list of projected slaves (LPS)
        self.page(D_LPS)
        self.index(D_LPS)
        for value in LPS:
            self.write(value)
        if self.send_cmd(C_SET_LPS):
            self.stop("can't update LPS.")
        # write new permanent configuration data (PCD)
        self.page(D_PCD)
        self.index(D_PCD)
        for value in PCD:
            self.write(value)
        if self.send_cmd(C_SET_PCD):
            self.stop("can't update PCD.")
        # write new PP (the printed listing lost this loop's "for" line: it writes pp[i])
        self.page(D_PP)
        self.index(D_PP)
        for value in PP:
            self.write(value)
        if self.send_cmd(C_SET_PP):
            self.stop("can't update PP.")
        # return to protected operation mode: write 0 to the parameter "data"
        self.page(D_DATA)
        self.index(D_DATA)
        self.write(0x00)
        if self.send_cmd(C_SET_MODE):
            self.stop("can't return to protected operation mode.")
        # wait for normal operation
        self.page(D_EC_FLAGS)
        timer = self.isa.time()
        while True:  # loop until normal operation mode flag gets high
            self.index(D_EC_FLAGS)
            flags = self.read()
            if self.isa.time() - timer > 2:  # end program after 2 seconds timeout
                self.stop("can't start normal operation.")
            if flags & 0x20:
                break
        # write projected parameter (PP) to parameter image (PI):
        # AS-i PC2 board writes PI list only after power up!
        self.page(D_PI)
        self.index(D_PI)
        for value in PP:
            self.write(value)
        # initialize watchdog: counter 100 ms, then enable
        self.page(D_WDOG_CNT)
        self.index(D_WDOG_CNT)
        self.write(0x0A)
        self.page(D_WDOG_ENA)
        self.index(D_WDOG_ENA)
        self.write(0x01)

    def communicate(self) -> None:
        """One pass of the "communication for ever" loop."""
        # reload watchdog counter with 100 ms
        self.page(D_WDOG_CNT)
        self.index(D_WDOG_CNT)  # index register will be incremented
        self.write(0x0A)  # after every read or write access!
        # read input data from DPRAM
        idata = bytes(self.read() for _ in range(16))
        # read execution control flags from DPRAM
        flags = self.read()
        # copy sensor bit of slave 1 to bit 0 of slave 2
        self.odata[1] = idata[0] & 0x10  # mask sensor bit of sl.1
        self.odata[1] = self.odata[1] >> 4  # shift from sl.3 to sl.2
        self.odata[1] = ~self.odata[1] & 0xFF  # bitwise negation
        # write output data to DPRAM
        for value in self.odata:
            self.write(value)
        # print data to screen
        line = f"input data (slave 1) = {idata[0] >> 4:1x} "
        line += f"output data (slave 2)= {self.odata[1] & 0x0F:1x} "
        if not flags & 0x01:  # mask config flag
            line += "config err...\r"
        else:
            line += "config OK... " + "-/\\"[self.which_bar_to_print - 1] + "\r"
            self.which_bar_to_print = self.which_bar_to_print % 3 + 1
        self.printf(line)

    def communicate_for(self, ms: float) -> None:
        end = self.isa.board.now_ms + ms
        while self.isa.board.now_ms < end:
            self.communicate()

    def stop(self, message: str) -> None:
        self.printf(message)
        raise DemoStopped(message)


class DemoStopped(Exception):
    """ansidemo's main() returned early after printing why."""


@pytest.fixture
def installation() -> tuple[Pc2Board, Slave, Slave]:
    sensor = Slave(1, io_code=0x1, id_code=0x1)
    module = Slave(2, io_code=0x8, id_code=0x0)
    return Pc2Board(bus=AsiBus([sensor, module])), sensor, module


def test_ansidemo_copies_the_sensor_to_the_output_module(installation):
    board, sensor, module = installation
    demo = AnsiDemo(IsaBus(board))
    demo.configure()
    assert board.mode == "protected" and board.phase is Phase.NORMAL
    assert board.execution.lps == 0b110 and board.execution.las == 0b110

    sensor.inputs = 0x1
    demo.communicate_for(20)
    assert module.outputs == 0x1
    # the sample prints the ODI byte it wrote, which is inverted: e is output bit 0 on
    assert demo.screen[-1].startswith("input data (slave 1) = 1 output data (slave 2)= e config OK")
    sensor.inputs = 0x0
    demo.communicate_for(20)
    assert module.outputs == 0x0
    assert demo.screen[-1].startswith("input data (slave 1) = 0 output data (slave 2)= f config OK")
    assert board.dpram[d.WATCHDOG_ENABLE] == 1  # fed in time: still running


def test_ansidemo_shows_a_configuration_error(installation):
    board, sensor, _ = installation
    demo = AnsiDemo(IsaBus(board))
    demo.configure()
    board.bus.remove(sensor)
    demo.communicate_for(20)
    assert demo.screen[-1].endswith("config err...\r")


def test_ansidemo_stopped_the_watchdog_takes_the_master_offline(installation):
    board, sensor, module = installation
    demo = AnsiDemo(IsaBus(board))
    demo.configure()
    sensor.inputs = 0x1
    demo.communicate_for(20)
    assert module.outputs == 0x1
    board.advance(85)  # the loop stopped: the 100 ms it wrote last run down
    assert board.phase is Phase.NORMAL
    board.advance(20)
    assert board.phase is Phase.OFFLINE and module.outputs == 0
    assert board.dpram[d.WATCHDOG_ENABLE] == 0 and board.dpram[d.WATCHDOG_COUNTER] == 0

