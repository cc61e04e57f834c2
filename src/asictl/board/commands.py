"""The host commands of the PC2 (manual 7.3): the code in 1F0h, parameters around it.

The board runs a pending command at its next firmware pass (the start of an AS-i cycle)
and answers in the command byte with 00h (done) or FFh (refused); results go to ``data``
(1F1h) or the program buffer (310h). Each command is a function of the master's parts:
the execution control for the AS-i master functions, AS-i Control and the EEPROM for the
program, the DPRAM for parameters and results, and the images for what the master
rewrites after a change. The board itself is needed for two things only (``Board``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from asictl.board.control import AsiControl
from asictl.board.dpram import Dpram
from asictl.board.emc import EmcTest
from asictl.board.execution import ExecutionControl
from asictl.board.images import MasterImages
from asictl.board.services import ENTRY_POINTS
from asictl.platform import pc2 as d
from asictl.platform.master import EEPROM_SIZE, ControlFlag
from asictl.platform.pc2 import Command, Status, nibbles

#: Command 53 from FF00h: the firmware's function-block entry points, 2 bytes each, LE.
ENTRY_TABLE = b"".join(a.to_bytes(2, "little") for a in ENTRY_POINTS.values())


class Board(Protocol):
    """What command 50's reset bit needs of the board around the master."""

    def reload_program(self) -> bool:
        """Load the program from the EEPROM again; False if there is no valid one."""
        ...

    def safe_outputs(self) -> None:
        """Outputs 0 until the host writes the ODI again."""
        ...


class HostCommands:
    """Runs the command codes the host writes to 1F0h."""

    def __init__(
        self,
        board: Board,
        dpram: Dpram,
        execution: ExecutionControl,
        control: AsiControl,
        eeprom: bytearray,
        images: MasterImages,
    ) -> None:
        self._board = board
        self._dpram = dpram
        self._ram = dpram.ram
        self._ec = execution
        self._control = control
        self._eeprom = eeprom
        self._images = images
        self._handlers: dict[int, Callable[[], bool]] = {
            Command.SET_PERMANENT_PARAMETER: self._set_permanent_parameter,
            Command.WRITE_PARAMETER: self._write_parameter,
            Command.STORE_ACTUAL_PARAMETER: self._store_actual_parameter,
            Command.SET_PERMANENT_CONFIGURATION: self._set_permanent_configuration,
            Command.STORE_ACTUAL_CONFIGURATION: self._store_actual_configuration,
            Command.SET_LPS: self._set_lps,
            Command.SET_OPERATION_MODE: self._set_operation_mode,
            Command.CHANGE_SLAVE_ADDRESS: self._change_slave_address,
            Command.EXECUTE_COMMAND: self._execute_command,
            Command.WRITE_CONTROL_FLAGS: self._write_control_flags,
            Command.GET_STATUS: self._get_status,
            Command.DOWNLOAD: self._download,
            Command.UPLOAD: self._upload,
            Command.WRITE_COMM_MEMORY: self._write_comm_memory,
            Command.READ_COMM_MEMORY: self._read_comm_memory,
            Command.READ_CLEAR_LCS: self._read_clear_lcs,
            Command.READ_CLEAR_ERROR_COUNTERS: self._read_clear_error_counters,
            Command.SET_LOS: self._set_los,
            Command.UPDATE_DPRAM: self._update_dpram,
            Command.READ_TELEGRAM_COUNTERS: self._read_telegram_counters,
            Command.EMC_TEST_MODE: self._emc_test_mode,
        }

    def run(self, code: int) -> bool:
        """Run command ``code``; False if it is refused (unknown codes are)."""
        handler = self._handlers.get(code)
        return handler is not None and handler()

    # --- parameters and results -------------------------------------------------

    def _param_data(self) -> int:
        return self._ram[d.DATA]

    def _param_address(self) -> int:
        return self._ram[d.ADDRESS]

    def _block(self, limit: int) -> range | None:
        """Command 52/53's block: ``data`` bytes from ``address``; None if invalid."""
        size = self._ram[d.DATA]
        start = self._ram[d.ADDRESS] | self._ram[d.ADDRESS_EXT] << 8
        if not 1 <= size <= d.PROGRAM_BUFFER_SIZE or start + size > limit:
            return None
        return range(start, start + size)

    def _image(self, address: int, size: int) -> bytes:
        return self._dpram.image(address, size)

    # --- AS-i master ------------------------------------------------------------

    def _set_permanent_parameter(self) -> bool:
        self._ec.set_permanent_parameters(nibbles(self._image(d.PP, d.IMAGE_SIZE)))
        self._images.write_settings()
        return True

    def _write_parameter(self) -> bool:
        address = self._param_address()
        if address >= 32:
            return False
        answer = self._ec.write_parameter(address, self._param_data())
        self._images.write_settings()
        if answer is None:
            return False
        self._ram[d.DATA] = answer
        return True

    def _store_actual_parameter(self) -> bool:
        self._ec.store_actual_parameters()
        self._images.write_settings()
        return True

    def _set_permanent_configuration(self) -> bool:
        done = self._ec.set_permanent_configuration(self._image(d.PCD, d.CONFIG_SIZE))
        self._images.write_settings()
        return done

    def _store_actual_configuration(self) -> bool:
        done = self._ec.store_actual_configuration()
        self._images.write_settings()
        return done

    def _set_lps(self) -> bool:
        lps = int.from_bytes(self._image(d.LPS, d.LIST_SIZE), "little")
        done = self._ec.set_lps(lps)
        self._images.write_settings()
        return done

    def _set_operation_mode(self) -> bool:
        return self._ec.set_operation_mode(self._param_data() != 0)

    def _change_slave_address(self) -> bool:
        status = self._ec.change_slave_address(self._param_address(), self._param_data())
        self._ram[d.DATA] = status
        return status is Status.OK

    def _execute_command(self) -> bool:
        address = self._param_address()
        answer = self._ec.execute_command(address, self._param_data()) if address < 32 else None
        if answer is None:
            return False
        self._ram[d.DATA] = answer
        return True

    # --- AS-i Control -------------------------------------------------------------

    def _write_control_flags(self) -> bool:
        value = self._ram[d.CONTROL_FLAGS]
        self._control.write_flags(value)
        loaded = True
        if value & ControlFlag.RESET:
            loaded = self._board.reload_program()
            self._board.safe_outputs()
        self._images.write_control_flags()
        self._images.write_status()
        return loaded

    def _get_status(self) -> bool:
        self._images.write_control_flags()
        self._images.write_cycle_times()
        return True

    def _download(self) -> bool:
        block = self._block(EEPROM_SIZE)
        if block is None:
            return False
        self._eeprom[block.start : block.stop] = self._image(d.PROGRAM_BUFFER, len(block))
        return True

    def _upload(self) -> bool:
        start = self._ram[d.ADDRESS] | self._ram[d.ADDRESS_EXT] << 8
        source: bytes | bytearray
        if start >= d.ENTRY_TABLE_ADDRESS:
            block = self._block(d.ENTRY_TABLE_ADDRESS + d.ENTRY_TABLE_SIZE)
            source, offset = ENTRY_TABLE, d.ENTRY_TABLE_ADDRESS
        else:  # sliced in place: no copy of the 16 KB EEPROM for each 240-byte block
            block = self._block(EEPROM_SIZE)
            source, offset = self._eeprom, 0
        if block is None:
            return False
        self._dpram.put(d.PROGRAM_BUFFER, source[block.start - offset : block.stop - offset])
        return True

    def _comm_block(self) -> range | None:
        """54/56: ``data`` bytes at ``address`` of the communication memory (no extension)."""
        size, start = self._param_data(), self._param_address()
        if not 1 <= size <= d.PROGRAM_BUFFER_SIZE or start + size > d.COMM_MEMORY_SIZE:
            return None
        return range(d.COMM_MEMORY + start, d.COMM_MEMORY + start + size)

    def _write_comm_memory(self) -> bool:
        block = self._comm_block()
        if block is None:
            return False
        self._dpram.put(block.start, self._image(d.PROGRAM_BUFFER, len(block)))
        return True

    def _read_comm_memory(self) -> bool:
        block = self._comm_block()
        if block is None:
            return False
        self._dpram.put(d.PROGRAM_BUFFER, self._image(block.start, len(block)))
        return True

    # --- diagnostics --------------------------------------------------------------

    def _read_clear_lcs(self) -> bool:
        self._dpram.put(d.PROGRAM_BUFFER, self._ec.read_clear_lcs().to_bytes(4, "little"))
        return True

    def _read_clear_error_counters(self) -> bool:
        self._dpram.put(d.PROGRAM_BUFFER, self._ec.read_clear_error_counters())
        return True

    def _set_los(self) -> bool:
        self._ec.set_los(int.from_bytes(self._image(d.LOS, d.LIST_SIZE), "little"))
        self._images.write_settings()
        return True

    def _update_dpram(self) -> bool:
        """128: everything the master owns written again (not the watchdog, not the ODI)."""
        images = self._images
        images.write_identity()
        images.write_config_ok_delay()
        images.write_lists()
        images.write_settings()
        images.write_control_flags()
        images.write_cycle_times()
        return True

    def _read_telegram_counters(self) -> bool:
        counts = self._ec.read_clear_telegram_counters()
        self._dpram.put(
            d.PROGRAM_BUFFER, b"".join(min(n, 0xFFFF).to_bytes(2, "little") for n in counts)
        )
        return True

    def _emc_test_mode(self) -> bool:
        """130: the EMC test's counters to buffer bytes 8-11, and its new parameters from
        bytes 0-5 (board/emc.py; an empty slave list ends the mode)."""
        test = EmcTest.from_buffer(self._image(d.PROGRAM_BUFFER, d.EMC_PARAMETERS_SIZE))
        self._dpram.put(d.PROGRAM_BUFFER + d.EMC_COUNTERS, self._ec.emc_test(test))
        return True
