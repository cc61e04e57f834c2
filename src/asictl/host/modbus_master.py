"""``Master`` for an AS-i/Modbus gateway, over its transport (host/transports/modbus.py).

The gateway shows less than a PC2 board's DPRAM: no control state, stop reason, program
status or cycle times. Its status is read from its registers and function 65, the state
derived from the AS-i Control flags (1009), the ec-flags and the image's magic in the
EEPROM, as the PC2 reports them, and the rest reported as not available.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from asictl.host.commissioning import Commissioning, ModbusCommissioning
from asictl.host.master import JSON, emulated_board
from asictl.host.status import (
    MasterStatus,
    derived_control_state,
    gateway_panel,
    panel_fields,
    program_info,
    slave_data,
    slave_fields,
    state_fields,
    state_summary,
)
from asictl.host.transports.gateway_pdus import (
    INFO_NAME,
    INFO_SOFTWARE,
    INFO_VERSION,
    INFO_VERSION_ID,
)
from asictl.host.transports.modbus import ModbusTransport, data_nibbles, slave_list
from asictl.image.eeprom import MAGIC
from asictl.platform import gateway as g
from asictl.platform.master import SLAVES, ControlFlag
from asictl.platform.pc2 import ControlState, StopReason


@dataclass(frozen=True)
class ModbusMaster:
    """``Master`` through a gateway: no DPRAM, and no emulated-only actions (an emulated
    gateway's board has them through its PC2 port, ``--port``)."""

    transport: ModbusTransport
    #: the front panel of the gateway, where asictl serves it here (``served_panel``):
    #: the display is then the panel's own, else worked out from the registers
    panel: Callable[[], dict[str, Any] | None] | None = None

    driver = None
    action = None
    quick_status = None
    created = False

    @property
    def name(self) -> str:
        return f"{self.transport.name} unit {self.transport.unit}"

    def summary(self) -> str:
        return control_summary(self.transport)

    def status(self) -> MasterStatus:
        status = read_status(self.transport)
        view = self.panel() if self.panel is not None else None
        return status if view is None else replace(status, **panel_fields(view))

    def tools(self) -> Commissioning:
        return ModbusCommissioning(self.transport)

    def emulated(self, name: str, **args: JSON) -> JSON:
        return emulated_board(self).run(name, args)

    def settle(self) -> None:
        """The gateway's master runs on by itself."""




# --- status -----------------------------------------------------------------------------


def _control_state(
    transport: ModbusTransport, flags: int
) -> tuple[ControlState, StopReason | None]:
    """The gateway shows no control state or stop reason: derived as the PC2 reports them
    from 1009's flags, the ec-flags (608) and the image's magic in the EEPROM."""
    if flags & ControlFlag.CONTROL_ACTIVE:
        return ControlState.RUNNING, StopReason.NONE
    program = transport.read_eeprom(0, len(MAGIC)) == MAGIC
    ec = transport.read_registers(g.EC_FLAGS, 1)[0] & 0xFF
    return derived_control_state(program, flags, ec)


def control_summary(transport: ModbusTransport) -> str:
    """What the control program does, and why not, as the PC2 path says it."""
    return state_summary(*_control_state(transport, transport.control_flags()))


def read_data(transport: ModbusTransport, *, flags: bool = True
              ) -> tuple[bytes, bytes, list[int]]:
    """Each slave's input and output data (one value a slave, 0..31) and the flag bytes
    (empty without ``flags``): what ``asictl record`` samples, in three requests where a
    status takes many."""
    inputs = data_nibbles(transport.read_registers(g.INPUTS_MIRROR + g.INPUT_DATA, 8))
    outputs = data_nibbles(transport.read_registers(g.OUTPUT_DATA, 8))
    memory = [r & 0xFF for r in transport.read_registers(g.MEMORY_BYTES, 128)] if flags else []
    return inputs, outputs, memory


def read_status(transport: ModbusTransport) -> MasterStatus:
    """The status screen's fields from the gateway's registers and function 65.

    The gateway shows no control state, stop reason, program status or cycle times: the
    state is derived from control_active and the rest is reported as not available.
    """
    ec = transport.read_registers(g.EC_FLAGS, 1)[0] & 0xFF
    lps = slave_list(transport.read_registers(g.LPS, 2))
    las = slave_list(transport.read_registers(g.LAS, 2))
    lds = slave_list(transport.read_registers(g.LDS, 2))
    pcd = [g.swap_profile(r) for r in transport.read_registers(g.PCD, SLAVES)]
    cdi = [g.swap_profile(r) for r in transport.read_registers(g.CDI, SLAVES)]
    flags = transport.control_flags()
    name = " ".join(
        text for text in (transport.master_info(INFO_NAME), transport.master_info(INFO_VERSION))
        if text
    )
    software = transport.master_info(INFO_SOFTWARE)
    program = program_info(transport)
    state, reason = derived_control_state(program.present, flags, ec)
    slaves = slave_data(
        {"LPS": lps, "LDS": lds, "LAS": las},
        inputs=data_nibbles(transport.read_registers(g.INPUTS_MIRROR + g.INPUT_DATA, 8)),
        outputs=data_nibbles(transport.read_registers(g.OUTPUT_DATA, 8)),
        pcd=bytes(pcd), cdi=bytes(cdi),
        pp=bytes(r & 0xF for r in transport.read_registers(g.PP, SLAVES)),
        pi=bytes(r & 0xF for r in transport.read_registers(g.PI, SLAVES)),
    )
    return MasterStatus(
        port=f"Modbus {transport.name} unit {transport.unit}",
        master_name=name,
        version_id=transport.master_info(INFO_VERSION_ID),
        installed_software=software,
        **state_fields(ec, flags),
        **slave_fields(lps, lds, las, bytes(pcd), bytes(cdi), ec=ec),
        control_state=state.name.lower(),
        stop_reason=(
            "cycle time-out, program fault or waiting for the set button" if reason is None
            else None if reason is StopReason.NONE else reason.name.lower().replace("_", " ")
        ),
        program_status="not shown by the gateway",
        cycle_time_ms=0.0,
        max_cycle_time_ms=0.0,
        cycle_times_known=False,
        program=program,
        slaves=slaves,
        hi_flags=transport.read_registers(g.HI_FLAGS, 1)[0] & 0x07,
        flags=[r & 0xFF for r in transport.read_registers(g.MEMORY_BYTES, 128)],
        **gateway_panel(ec, software),
    )
