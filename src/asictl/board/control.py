"""AS-i Control: when the control program runs, stops and starts again.

The rules (PC2 manual 10.2.6, the gateway manual's register 1009, il-semantics.md): the
program runs while the start flag is set, a program is loaded, the master is in normal
operation, and the configuration is OK (or ``ignore_config_errors`` is set). A stop the
master's state caused restarts by itself once the state permits again, unless the
"wait for set button" bit (the manual's inverted auto_start) is set: then it waits for
the set button or a new start by the host. A cycle time-out always waits: the program
would only loop again. docs/master.md has the table of states and reasons.
"""

from __future__ import annotations

from asictl.board.services import ENTRY_POINTS
from asictl.image.eeprom import ImageError, ProgramImage, image_length
from asictl.mcs51.bus import Bus
from asictl.platform.master import CONTROL_FLAGS_NONVOLATILE, MACHINE_CYCLE_US, ControlFlag
from asictl.platform.pc2 import FLAGS, FLAGS_SIZE, ControlState, ProgramStatus, StopReason
from asictl.runtime import contract
from asictl.runtime.firmware import FirmwareServices
from asictl.runtime.runner import ProgramRunner

# Plain ints: the run/stop check happens every AS-i cycle, IntFlag arithmetic is slow.
_START = int(ControlFlag.START)
_IGNORE_CONFIG_ERRORS = int(ControlFlag.IGNORE_CONFIG_ERRORS)

_MESSAGES = {
    StopReason.NONE: "running",
    StopReason.NOT_STARTED: "start flag not set",
    StopReason.NO_PROGRAM: "no program loaded",
    StopReason.NOT_NORMAL_OPERATION: "AS-i master not in normal operation",
    StopReason.CONFIG_ERROR: "AS-i configuration error",
    StopReason.CYCLE_TIMEOUT: "program cycle time-out",
    StopReason.PROGRAM_FAULT: "program fault",
}
#: Stops that wait for the set button or a new start whatever the flags: running the
#: program again would only do the same.
_HALTING = (StopReason.CYCLE_TIMEOUT, StopReason.PROGRAM_FAULT)


class AsiControl:
    """The control program's state on one master: loaded program, flags, run/stop."""

    def __init__(self, xdata: Bus, firmware: FirmwareServices, flags: int) -> None:
        self._xdata = xdata
        self._firmware = firmware
        self.flags = int(flags & CONTROL_FLAGS_NONVOLATILE)
        self.runner: ProgramRunner | None = None
        self.image: ProgramImage | None = None
        self.program_status = ProgramStatus.NOT_LOADED
        #: what was wrong with the EEPROM contents at the last load
        self.load_error = ""
        self.running = False
        self.halted = False
        self.reason = StopReason.NO_PROGRAM
        #: the time-out's or the fault's own message, when that was the reason
        self.detail = ""
        #: program cycle times in microseconds: the last one and the maximum since loading
        self.previous_us = 0.0
        self.maximum_us = 0.0

    @property
    def state(self) -> ControlState:
        if self.running:
            return ControlState.RUNNING
        if self.halted:
            return ControlState.HALTED
        if self.runner is None or not self.flags & ControlFlag.START:
            return ControlState.IDLE
        return ControlState.WAITING

    @property
    def message(self) -> str:
        """Why the program is not running, for people."""
        text = _MESSAGES[self.reason]
        if self.reason is StopReason.NO_PROGRAM and self.load_error:
            text += f" ({self.load_error})"
        if self.detail and self.reason in _HALTING:
            text += f": {self.detail}"
        if self.halted:
            text += "; waiting for the set button or a new start"
        return text

    def flags_byte(self) -> int:
        """The AS-i Control flags as the DPRAM image shows them (reset reads back 0)."""
        return self.flags | (ControlFlag.CONTROL_ACTIVE if self.running else 0)

    def load(self, eeprom: bytes) -> bool:
        """reset_bit: copy the program from the EEPROM; False if there is none or it is bad."""
        self.stop(StopReason.NO_PROGRAM)
        self.halted = False
        self.runner, self.image, self.load_error = None, None, ""
        self.previous_us = self.maximum_us = 0.0
        length = image_length(eeprom)
        if not length:
            self.program_status = ProgramStatus.NOT_LOADED
            self.load_error = "the EEPROM holds no program image"
        else:
            try:
                self.image, self.runner = self._runner(eeprom[:length])
            except ImageError as exc:
                self.program_status = ProgramStatus.BAD_IMAGE
                self.load_error = str(exc)
            else:
                self.program_status = ProgramStatus.LOADED
        if self.runner is not None:
            self.runner.reset()
        else:
            self._xdata.ram[FLAGS : FLAGS + FLAGS_SIZE] = bytes(FLAGS_SIZE)  # erased all the same
        return self.runner is not None

    def _runner(self, data: bytes) -> tuple[ProgramImage, ProgramRunner]:
        """The image in ``data`` made ready to run; ``ImageError`` if it cannot be.

        ``from_bytes`` holds the image to the runtime contract, and the firmware to its
        own entry table. Whatever else fails while setting the program up is still the
        image's fault as far as the master can tell: a power-up must never fail, or a
        board holding such an image could not be used again.
        """
        image = ProgramImage.from_bytes(data)
        program = image.loaded_program()
        try:
            contract.check(program, ENTRY_POINTS)
        except contract.ContractError as exc:
            raise ImageError(f"image not linked for this master: {exc}") from None
        try:
            runner = ProgramRunner(program, firmware=self._firmware, xdata=self._xdata)
        except Exception as exc:  # any failure here is the image's
            raise ImageError(f"the firmware cannot load the image: {exc!r}") from None
        return image, runner

    def write_flags(self, value: int) -> None:
        """Command 50's flags (reset is the caller's); setting start is a new start."""
        self.flags = int(value & CONTROL_FLAGS_NONVOLATILE)
        if value & ControlFlag.START:
            self.halted = False

    def press_set_button(self) -> None:
        self.halted = False

    def blocker(self, *, normal: bool, config_ok: bool) -> StopReason:
        """What keeps the program from running now (``NONE``: nothing)."""
        if self.runner is None:
            return StopReason.NO_PROGRAM
        if not self.flags & _START:
            return StopReason.NOT_STARTED
        if self.halted:
            return self.reason
        if not normal:
            return StopReason.NOT_NORMAL_OPERATION
        if not config_ok and not self.flags & _IGNORE_CONFIG_ERRORS:
            return StopReason.CONFIG_ERROR
        return StopReason.NONE

    def start(self) -> None:
        self.running, self.reason, self.detail = True, StopReason.NONE, ""

    def stop(self, reason: StopReason, detail: str = "") -> None:
        """Stop for ``reason``; a stop the master caused may have to wait for the button."""
        was_running = self.running
        self.running, self.reason, self.detail = False, reason, detail
        if reason in _HALTING or (
            was_running
            and reason in (StopReason.NOT_NORMAL_OPERATION, StopReason.CONFIG_ERROR)
            and self.flags & ControlFlag.WAIT_FOR_SET_BUTTON
        ):
            self.halted = True

    def record_cycle(self, machine_cycles: int) -> float:
        """Note a program cycle's duration; returns it in microseconds."""
        duration = machine_cycles * MACHINE_CYCLE_US
        self.previous_us = duration
        if duration > self.maximum_us:  # not max(): a builtin's call, every program cycle
            self.maximum_us = duration
        return duration
