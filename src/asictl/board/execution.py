"""The AS-i master's execution control: phases, modes, slave lists, configuration check.

This is the part of the master the AS-i master specification defines and the PC2 manual
(sections 6, 7.3 and 10.2) describes from the host's side. It knows nothing of the DPRAM:
the board mirrors its state there and turns host commands into calls of the execution
control functions below (Set_LPS, Change_Slave_Address, ...). docs/master.md states the
rules this module implements; the ones no manual confirms are in docs/verify.md.

Slave lists are 32-bit integers, slave n being bit n, which is also their DPRAM layout
read little-endian. The module works by events: ``step`` does nothing in a settled normal
operation unless the bus or a setting changed, so a simulated hour costs little more than
the control program's own cycles.
"""

from __future__ import annotations

from collections.abc import Iterator
from enum import Enum

from asictl.board.asi import AsiBus, Slave
from asictl.board.emc import EmcTest
from asictl.platform.master import NO_PROFILE, SLAVES, TICK_US
from asictl.platform.pc2 import EcFlag, Status

#: Addresses 1..31: slave 0 (a new slave) is never projected, activated or counted
#: in the configuration check.
OPERATING = 0xFFFFFFFE
#: The error counters saturate here; 255 means overflow (manual 6.2).
COUNTER_LIMIT = 254
COUNTER_OVERFLOW = 255


class Phase(Enum):
    """The execution control's phases (AS-i master specification)."""

    OFFLINE = "offline"
    DETECTION = "detection"
    ACTIVATION = "activation"
    NORMAL = "normal operation"


# Asked every AS-i cycle (``settled``, ``exchange``, ``in_step``): module constants.
_NORMAL = Phase.NORMAL
_SETTLED_PHASES = (Phase.NORMAL, Phase.OFFLINE)


def _changed_bytes(old: bytes, new: bytes | bytearray) -> list[int]:
    return [k for k in range(16) if old[k] != new[k]]


def addresses(mask: int) -> Iterator[int]:
    """The slave addresses in a list, ascending."""
    while mask:
        low = mask & -mask
        yield low.bit_length() - 1
        mask ^= low


class ExecutionControl:
    """One AS-i master's execution control, driven once per AS-i cycle by the board."""

    def __init__(
        self,
        bus: AsiBus,
        *,
        configuration_mode: bool = True,
        lps: int = 0,
        pcd: bytes = bytes([NO_PROFILE]) * SLAVES,
        pp: bytes = bytes([0xF]) * SLAVES,
        los: int = 0,
        config_ok_delay: int = 2,
    ) -> None:
        self.bus = bus
        # non-volatile
        self.configuration_mode = configuration_mode
        self.lps = lps & OPERATING
        self.pcd = bytearray(pcd)
        self.pp = bytearray(p & 0xF for p in pp)
        self.los = los
        #: Config_ok 0->1 delay in 10 ms units (DPRAM 1FDh)
        self.config_ok_delay = config_ok_delay
        # volatile
        self.pi = bytearray(self.pp)
        self.cdi = bytearray([NO_PROFILE]) * SLAVES
        self.lds = 0
        self.las = 0
        self.lcs = 0
        self.error_counters = bytearray(SLAVES)
        #: master requests sent / telegrams lost, for command 129
        self.requests = 0
        self.failures = 0
        self.phase = Phase.OFFLINE
        self.apf = False
        # host interface flags (logical values, not the DPRAM's inverted bits)
        self.data_exchange_active = True
        self.offline = False
        self.auto_address_enable = True
        #: offline because of a configuration error at an address in the LOS (manual 6.3)
        self.los_offline = False
        #: configuration error addresses (LPS/LDS mismatch or wrong profile)
        self.errors = 0
        #: the addresses in ``errors`` in the order they were found (the gateway's display
        #: shows the first, gateway manual line 304)
        self.error_order: list[int] = []
        #: where the latest configuration error appeared, 0 for an AS-i power failure (as
        #: in the LCS); None before any (the gateway's set key shows it, line 306)
        self.last_error: int | None = None
        #: master time normal operation last began at (the gateway's display 43)
        self.normal_since_us = 0
        self.config_ok = False
        self._ok_since: int | None = None
        self.idi = bytearray(16)
        #: the EMC test mode of command 130, while it is on (board/emc.py)
        self.emc: EmcTest | None = None
        #: bumped when ec-flags, LDS, LAS, CDI (the lists the master writes) change
        self.generation = 0
        #: bumped when LPS, PCD, PP, PI, LOS or the host interface flags change
        self.settings_generation = 0
        self._dirty = True
        self._topology = -1
        self._input_version = -1
        self._missed = 0
        self._lossy = False
        self._slaves: dict[int, Slave] = {}
        self._active: list[tuple[int, Slave]] = []
        self._by_address: dict[int, Slave] = {}
        self._sent: bytes | None = None
        self._shown: tuple[int, int, int, bytes] | None = None

    # ------------------------------------------------------------------ views

    @property
    def ec_flags(self) -> int:
        flags = EcFlag(0)
        if self.config_ok:
            flags |= EcFlag.CONFIG_OK
        if self.lds & 1:
            flags |= EcFlag.LDS_0
        if self.auto_address_enable and not self.configuration_mode:
            flags |= EcFlag.AUTO_ADDRESS_ASSIGN
            if self.phase is Phase.NORMAL and self._single_missing() is not None:
                flags |= EcFlag.AUTO_ADDRESS_AVAILABLE
        if self.configuration_mode:
            flags |= EcFlag.CONFIGURATION_ACTIVE
        if self.phase is Phase.NORMAL:
            flags |= EcFlag.NORMAL_OPERATION_ACTIVE
        if self.apf:
            flags |= EcFlag.APF
        if self.phase is Phase.OFFLINE:
            flags |= EcFlag.OFFLINE_READY
        return int(flags)

    @property
    def active_count(self) -> int:
        return len(self._active)

    @property
    def settled(self) -> bool:
        """Nothing to do next cycle unless the bus or a setting changes."""
        return (
            not self._dirty
            and self.bus.topology == self._topology
            and self.phase in _SETTLED_PHASES
            and self._ok_since is None
            and not self._lossy
        )

    # ------------------------------------------------------------------ the cycle

    def step(self, now_us: int) -> None:
        """The execution-control part of one AS-i cycle at master time ``now_us``."""
        if self.settled:
            return
        self._dirty = False
        if self.bus.topology != self._topology:
            # slaves came, went or lost power: what they hold is no longer what was sent
            self._sent = None
            self._input_version = -1
        self._topology = self.bus.topology
        was_normal = self.phase is Phase.NORMAL
        if not self.bus.powered:
            self.apf = True
            self.lcs |= 1
            self.last_error = 0
            self._go_offline()
        elif self.offline or self.los_offline:
            self.apf = False
            self._go_offline()
        else:
            self.apf = False
            self._detect()
            self._advance_phase()
            if self.phase is Phase.NORMAL:
                self._check_configuration()
        if self.phase is Phase.NORMAL and not was_normal:
            self.normal_since_us = now_us
        self._delay_config_ok(now_us)
        visible = self._visible()
        if visible != self._shown:
            self._shown = visible
            self.generation += 1

    def _advance_phase(self) -> None:
        if self.phase is Phase.OFFLINE:
            self.phase = Phase.DETECTION
            self._dirty = True
        elif self.phase is Phase.DETECTION:
            if self.lds:  # stays here until at least one slave answers
                self.phase = Phase.ACTIVATION
            self._dirty = True
        elif self.phase is Phase.ACTIVATION:
            self._activate()
            self.phase = Phase.NORMAL
        else:
            self._activate()  # inclusion and loss of slaves in normal operation

    def _detect(self) -> None:
        by_address: dict[int, list[Slave]] = {}
        for slave in self.bus:
            by_address.setdefault(slave.address, []).append(slave)
        lds = 0
        cdi = bytearray([NO_PROFILE]) * SLAVES
        for address, found in by_address.items():
            # two slaves at one address answer at once: the master reads garbage
            if len(found) == 1 and not self._missed >> address & 1:
                lds |= 1 << address
                cdi[address] = found[0].profile
        if self._missed:
            self._missed = 0
            self._dirty = True  # found again next cycle
        self.lds, self.cdi = lds, cdi
        self._slaves = {a: s[0] for a, s in by_address.items() if lds >> a & 1}

    def _activatable(self) -> int:
        if self.configuration_mode:
            return self.lds & OPERATING
        return self.lds & self.lps & ~self._mismatched()

    def _mismatched(self) -> int:
        mask = 0
        for a in addresses(self.lds & self.lps):
            if self.cdi[a] != self.pcd[a]:
                mask |= 1 << a
        return mask

    def _activate(self) -> None:
        wanted = self._activatable()
        before = dict(self._active)
        active = [(a, self._slaves[a]) for a in addresses(wanted)]
        for a, slave in before.items():
            if dict(active).get(a) is not slave and slave.bus is self.bus:
                slave.outputs = 0  # no more data calls: the slave's watchdog resets it
        for a, slave in active:
            if before.get(a) is not slave:
                slave.receive_parameter(self.pi[a])
        if active != self._active:
            self.las = wanted
            self._active = active
            self._by_address = dict(active)
            self._sent = None
            self._input_version = -1
        self._lossy = any(slave.lost_telegrams for _, slave in active)

    def _check_configuration(self) -> None:
        errors = ((self.lps ^ self.lds) | self._mismatched()) & OPERATING
        if errors != self.errors:
            self._note_errors(errors)
        self.lcs |= self.errors
        if self.configuration_mode:
            return
        if self.errors & self.los:
            self.los_offline = True
            self._go_offline()
            return
        target = self._single_missing()
        if (
            self.auto_address_enable
            and target is not None
            and self.lds & 1
            and self.cdi[0] == self.pcd[target]
        ):
            self._slaves[0].program_address(target)  # found again by the next detection

    def _note_errors(self, errors: int) -> None:
        """The new error set: the order of finding, and the latest to appear."""
        appeared = list(addresses(errors & ~self.errors))
        self.error_order = [a for a in self.error_order if errors >> a & 1] + appeared
        if appeared:
            self.last_error = appeared[-1]
        self.errors = errors

    def _single_missing(self) -> int | None:
        missing = self.lps & ~self.lds & OPERATING
        return missing.bit_length() - 1 if missing and not missing & (missing - 1) else None

    def _delay_config_ok(self, now_us: int) -> None:
        raw = self.phase is Phase.NORMAL and not self.errors
        if not raw:
            self.config_ok, self._ok_since = False, None
        elif not self.config_ok:
            if self._ok_since is None:
                self._ok_since = now_us
            if now_us - self._ok_since >= self.config_ok_delay * TICK_US:
                self.config_ok, self._ok_since = True, None

    def _go_offline(self) -> None:
        if self.phase is not Phase.OFFLINE or self.lds:
            for slave in self.bus:
                slave.outputs = 0
        self.phase = Phase.OFFLINE
        self.lds = self.las = self.errors = 0
        self.error_order = []
        self.cdi = bytearray([NO_PROFILE]) * SLAVES
        self._active, self._slaves, self._by_address = [], {}, {}
        self._sent = None
        self.idi[:] = bytes(16)

    def _visible(self) -> tuple[int, int, int, bytes]:
        return (self.ec_flags, self.lds, self.las, bytes(self.cdi))

    # ------------------------------------------------------------------ data exchange

    def exchange(self, outputs: bytes | bytearray) -> bool:
        """Data calls to the active slaves: send ``outputs``, read the IDI; True if it changed.

        Outputs go out only when they or the LAS changed, inputs are read only when a
        slave's data changed: the slaves keep what they got, so this is what the cycle
        would do anyway.
        """
        if self.phase is not _NORMAL or not self.data_exchange_active:
            return False
        if self.emc is not None:
            self.emc.cycle(self.bus)
            return False
        self.requests += len(self._active) + 1
        if self._lossy:
            self._lose_telegrams()
        sent = self._sent
        if sent != outputs:
            slaves = self._by_address
            for k in range(16) if sent is None else _changed_bytes(sent, outputs):
                for a in (2 * k, 2 * k + 1):
                    if a in slaves:
                        slaves[a].outputs = outputs[k] >> (a & 1) * 4 & 0xF
            self._sent = bytes(outputs)
        if self.bus.input_version == self._input_version:
            return False
        self._input_version = self.bus.input_version
        idi = bytearray(16)
        for a, slave in self._active:
            idi[a >> 1] |= slave.inputs << (a & 1) * 4
        if idi == self.idi:
            return False
        self.idi[:] = idi
        return True

    def _lose_telegrams(self) -> None:
        """A lost telegram is repeated at once; a slave that loses both misses the cycle."""
        for a, slave in self._active:
            tries = min(slave.lost_telegrams, 2)
            if tries:
                slave.lost_telegrams -= tries
                self.failures += tries
                count = self.error_counters[a] + tries
                self.error_counters[a] = COUNTER_OVERFLOW if count > COUNTER_LIMIT else count
                if tries == 2:
                    self._missed |= 1 << a
                    self._dirty = True
        self._lossy = any(slave.lost_telegrams for _, slave in self._active)

    def in_step(self, outputs: bytes | bytearray) -> bool:
        """The slaves hold ``outputs`` and the IDI their inputs: an exchange changes nothing."""
        if self.phase is not _NORMAL or not self.data_exchange_active:
            return True
        if self.emc is not None:
            return self.emc.steady(self.bus)
        return self._sent == outputs and self.bus.input_version == self._input_version

    def count_idle_cycles(self, cycles: int) -> None:
        """Cycles skipped as idle still sent their calls (for command 129)."""
        if self.phase is Phase.NORMAL and self.data_exchange_active:
            if self.emc is not None:
                self.emc.repeat(cycles)
            else:
                self.requests += cycles * (len(self._active) + 1)

    def stop_exchange(self) -> None:
        """Data exchange switched off: the slaves' watchdogs switch their outputs off."""
        for _, slave in self._active:
            slave.outputs = 0
        self._sent = None

    # ------------------------------------------------------------------ host functions

    def set_permanent_parameters(self, pp: bytes | bytearray) -> None:
        if bytes(pp) != bytes(self.pp):
            self.pp[:] = (p & 0xF for p in pp)
            self.settings_generation += 1

    def write_parameter(self, address: int, parameter: int) -> int | None:
        """Write_Parameter: PI takes the value; an active slave answers (else ``None``)."""
        parameter &= 0xF
        if self.pi[address] != parameter:
            self.pi[address] = parameter
            self.settings_generation += 1
        if self.phase is not Phase.NORMAL or not self.las >> address & 1:
            return None
        return self._by_address[address].receive_parameter(parameter)

    def store_actual_parameters(self) -> None:
        self.set_permanent_parameters(self.pi)

    def set_permanent_configuration(self, pcd: bytes) -> bool:
        if not self.configuration_mode:
            return False
        if bytes(pcd) != bytes(self.pcd):
            self.pcd[:] = pcd
            self._changed_setting()
        return True

    def store_actual_configuration(self) -> bool:
        if not self.configuration_mode:
            return False
        pcd = bytearray(self.pcd)
        pcd[1:] = self.cdi[1:]
        self.set_permanent_configuration(bytes(pcd))
        return self.set_lps(self.lds)

    def set_lps(self, lps: int) -> bool:
        if not self.configuration_mode:
            return False
        self.lps = lps & OPERATING
        self._changed_setting()  # also when unchanged: the DPRAM image loses a written bit 0
        return True

    def set_operation_mode(self, configuration: bool) -> bool:
        """Leaving configuration mode is refused while a slave with address 0 is present."""
        if not configuration and self.lds & 1:
            return False
        if configuration != self.configuration_mode:
            self.configuration_mode = configuration
            self._changed_setting()
        return True

    def set_los(self, los: int) -> None:
        """Set_LOS; rewriting it also ends an offline phase the LOS caused (manual 7.3)."""
        self.los = los
        self.los_offline = False
        self._changed_setting()

    def change_slave_address(self, old: int, new: int) -> Status:
        """Change_Slave_Address with the status byte codes of manual 10.2.7."""
        if not (0 <= old < SLAVES and 0 <= new < SLAVES) or self.phase is Phase.OFFLINE:
            return Status.ERROR
        if not self.lds >> old & 1:
            return Status.NO_SLAVE
        if new == old or (new != 0 and self.bus.at(new)):
            return Status.ADDRESS_OCCUPIED
        if old != 0 and self.lds & 1:
            return Status.SLAVE_ZERO_PRESENT
        slave = self._slaves[old]
        if slave.program_address(new):
            return Status.OK
        if old != 0 and slave.address == old:
            return Status.CANNOT_PROGRAM_ZERO  # the first step, deleting the address, failed
        return Status.CANNOT_SET_ADDRESS if slave.address != new else Status.CANNOT_STORE_ADDRESS

    def execute_command(self, address: int, information: int) -> int | None:
        if not 0 <= address < SLAVES or not self.lds >> address & 1:
            return None
        return self._slaves[address].command(information & 0x1F)

    def read_clear_lcs(self) -> int:
        """The LCS since the last read; errors that persist are in it again at once."""
        lcs = self.lcs
        self.lcs = self.errors | (1 if self.apf else 0)
        return lcs

    def read_clear_error_counters(self) -> bytes:
        counters = bytes(self.error_counters)
        self.error_counters[:] = bytes(SLAVES)
        return counters

    def emc_test(self, test: EmcTest | None) -> bytes:
        """Command 130: the counters of the test until now (and cleared), and ``test`` on
        from now (None ends the mode)."""
        report = self.emc.report() if self.emc is not None else bytes(4)
        if test is not None and self.emc is None:
            listed = test.slaves
            for a, slave in self._active:
                if not listed >> a & 1:
                    slave.outputs = 0  # no more data calls: the slave's watchdog
        self.emc = test
        self._sent = None  # the outputs go out again when data exchange returns
        self._input_version = -1
        return report

    def read_clear_telegram_counters(self) -> tuple[int, int]:
        counts = (self.requests, self.failures)
        self.requests = self.failures = 0
        return counts

    def set_host_flags(
        self, *, data_exchange_active: bool, offline: bool, auto_address_enable: bool
    ) -> None:
        """The host interface flags, from the DPRAM or the DataEx/AutoAddr blocks."""
        if not data_exchange_active and self.data_exchange_active:
            self.stop_exchange()
        if (data_exchange_active, offline, auto_address_enable) != (
            self.data_exchange_active, self.offline, self.auto_address_enable
        ):
            self.data_exchange_active = data_exchange_active
            self.offline = offline
            self.auto_address_enable = auto_address_enable
            self._changed_setting()

    def _changed_setting(self) -> None:
        self.settings_generation += 1
        self._dirty = True
