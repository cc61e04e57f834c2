"""The AS-i cable and the slaves on it, as the emulated master sees them.

Tests, scenarios and the board all act on one ``AsiBus``: plugging slaves in and out,
setting their inputs, reading the outputs the master sent, failing the AS-i power. The
master is event-driven for speed, so every change a slave or the bus undergoes bumps a
version counter: ``topology`` for what the master's detection must look at again
(slaves, addresses, profiles, power, lost telegrams), ``input_version`` for the sensor
data only. The master compares the counters once per AS-i cycle instead of polling 32
addresses.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

from asictl.platform.master import DEFAULT_PARAMETER, SLAVES

#: How a slave's address programming can fail (the PC2's status bytes 05-07, the gateway's
#: display codes 92 and 93): "delete", the slave refuses Delete_Address, so it cannot be
#: set to address 0 and keeps its address (05); "set", the new address cannot be set (the
#: slave is left at address 0; 06); "store", the slave takes it but cannot store it, so a
#: power-up brings back the address it had (07).
ADDRESS_FAULTS = ("", "delete", "set", "store")


class BusError(ValueError):
    """A slave or bus operation that does not make sense (bad address, unknown slave)."""


def _nibble(value: int, what: str) -> int:
    if not 0 <= value <= 0xF:
        raise BusError(f"{what} must be 0..15, not {value}")
    return value


def _address(value: int) -> int:
    if not 0 <= value < SLAVES:
        raise BusError(f"AS-i address must be 0..31, not {value}")
    return value


class Slave:
    """One AS-i slave: a permanent address, a profile, four data bits each way, a parameter.

    The address is the one stored in the slave's own EEPROM; 0 is a new slave. With
    ``parameter_echo`` (the usual slave) the answer to a parameter call is the parameter
    itself; otherwise it is ``parameter_response``. ``address_fault`` (``ADDRESS_FAULTS``)
    makes it fail address programming as a worn-out slave EEPROM does.
    """

    def __init__(
        self,
        address: int = 0,
        io_code: int = 0,
        id_code: int = 0xF,
        inputs: int = 0,
        parameter_echo: bool = True,
        parameter_response: int = 0,
        *,
        name: str = "",
        address_fault: str = "",
    ) -> None:
        self._address = _address(address)
        #: the address in the slave's own EEPROM, which a power-up brings back
        self._stored_address = self._address
        if address_fault not in ADDRESS_FAULTS:
            raise BusError(
                f"address fault must be one of 'delete', 'set', 'store', not {address_fault!r}"
            )
        self.address_fault = address_fault
        self.io_code = _nibble(io_code, "I/O code")
        self.id_code = _nibble(id_code, "ID code")
        self._inputs = _nibble(inputs, "input data")
        self.parameter_echo = parameter_echo
        self.parameter_response = _nibble(parameter_response, "parameter response")
        self.name = name
        #: the output data the master sent last (0 after power-up, reset or a stop)
        self.outputs = 0
        #: the parameter the master sent last
        self.parameter = DEFAULT_PARAMETER
        #: telegrams still to be lost (no valid answer), see ``lose_telegrams``
        self.lost_telegrams = 0
        self.bus: AsiBus | None = None

    def __repr__(self) -> str:
        label = f" {self.name!r}" if self.name else ""
        return (
            f"<Slave{label} address {self._address} io {self.io_code:X}h "
            f"id {self.id_code:X}h inputs {self._inputs:X}h outputs {self.outputs:X}h>"
        )

    @property
    def profile(self) -> int:
        """The PC2 configuration byte: ID code in the high nibble, I/O code in the low."""
        return self.id_code << 4 | self.io_code

    @property
    def address(self) -> int:
        return self._address

    @address.setter
    def address(self, value: int) -> None:
        self._address = self._stored_address = _address(value)
        self._touch()

    def program_address(self, value: int) -> bool:
        """Address programming by the master (Change_Slave_Address): False when the
        slave's ``address_fault`` spoils it (see ``ADDRESS_FAULTS``). A slave with an
        address of its own is first deleted (set to 0), then given the new one."""
        if self.address_fault == "delete" and self.address != 0:
            return False  # Delete_Address refused: the slave keeps its address
        if self.address_fault == "set":
            self.address = 0  # the old address was deleted; the new one did not take
            return False
        if self.address_fault == "store":
            self._address = _address(value)
            self._touch()
            return False
        self.address = value
        return True

    @property
    def inputs(self) -> int:
        """The sensor data the slave answers a data call with."""
        return self._inputs

    @inputs.setter
    def inputs(self, value: int) -> None:
        value = _nibble(value, "input data")
        if value != self._inputs:
            self._inputs = value
            if self.bus is not None:
                self.bus.input_version += 1

    def lose_telegrams(self, count: int) -> None:
        """Make the next ``count`` data telegrams fail (a loose contact, interference)."""
        if count < 0:
            raise BusError(f"telegram count must not be negative, not {count}")
        self.lost_telegrams += count
        self._touch()

    def receive_parameter(self, parameter: int) -> int:
        """A parameter call: keep it and answer."""
        self.parameter = parameter & 0xF
        return self.parameter if self.parameter_echo else self.parameter_response

    def command(self, information: int) -> int | None:
        """An AS-i command call (Execute_Command); ``None``: the slave does not answer.

        Only the calls every slave implements are modelled: read I/O configuration (10h),
        read ID code (11h), reset slave (1Ch, answered with 6), read status (1Eh, 0).
        """
        if information == 0x10:
            return self.io_code
        if information == 0x11:
            return self.id_code
        if information == 0x1C:
            self.power_up()
            return 0x6
        if information == 0x1E:
            return 0x0
        return None

    def power_up(self) -> None:
        """What a slave does on power-up or reset: outputs off, default parameter, the
        address from its own EEPROM."""
        self.outputs = 0
        self.parameter = DEFAULT_PARAMETER
        if self._address != self._stored_address:
            self._address = self._stored_address
            self._touch()

    def to_dict(self) -> dict[str, Any]:
        data: dict[str, Any] = {
            "address": self._stored_address,
            "io_code": self.io_code,
            "id_code": self.id_code,
            "inputs": self._inputs,
        }
        if not self.parameter_echo:
            data["parameter_echo"] = False
            data["parameter_response"] = self.parameter_response
        if self.name:
            data["name"] = self.name
        if self.address_fault:
            data["address_fault"] = self.address_fault
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Slave:
        if not isinstance(data, dict):
            raise BusError(f"a slave must be described by an object, not {data!r}")
        unknown = set(data) - {
            "address", "io_code", "id_code", "inputs", "parameter_echo",
            "parameter_response", "name", "address_fault",
        }
        if unknown:
            raise BusError(f"unknown slave fields: {', '.join(sorted(unknown))}")
        try:
            return cls(
                _int(data, "address", 0),
                _int(data, "io_code", 0),
                _int(data, "id_code", 0xF),
                _int(data, "inputs", 0),
                bool(data.get("parameter_echo", True)),
                _int(data, "parameter_response", 0),
                name=str(data.get("name", "")),
                address_fault=str(data.get("address_fault", "")),
            )
        except TypeError as exc:
            raise BusError(f"bad slave description {data!r}: {exc}") from None

    def _touch(self) -> None:
        if self.bus is not None:
            self.bus.topology += 1


def _int(data: dict[str, Any], key: str, default: int) -> int:
    value = data.get(key, default)
    if not isinstance(value, int) or isinstance(value, bool):
        raise BusError(f"slave field {key!r} must be an integer, not {value!r}")
    return value


class AsiBus:
    """The AS-i cable: the slaves plugged into it and the AS-i power supply."""

    def __init__(self, slaves: list[Slave] | None = None) -> None:
        self._slaves: list[Slave] = []
        self._powered = True
        #: bumped on every change the master's detection must see
        self.topology = 0
        #: bumped whenever a slave's input data changes
        self.input_version = 0
        for slave in slaves or ():
            self.attach(slave)

    def __iter__(self) -> Iterator[Slave]:
        return iter(tuple(self._slaves))

    def __len__(self) -> int:
        return len(self._slaves)

    @property
    def slaves(self) -> tuple[Slave, ...]:
        return tuple(self._slaves)

    @property
    def powered(self) -> bool:
        return self._powered

    def attach(self, slave: Slave) -> Slave:
        """Plug a slave in; it answers from the next AS-i cycle on."""
        if slave.bus is not None:
            raise BusError(f"{slave!r} is already on a bus; remove it first")
        slave.bus = self
        slave.power_up()
        self._slaves.append(slave)
        self.topology += 1
        return slave

    def remove(self, slave: Slave | int) -> Slave:
        """Unplug a slave (or the one slave at an address)."""
        if isinstance(slave, int):
            slave = self.slave(slave)
        if slave.bus is not self:
            raise BusError(f"{slave!r} is not on this bus")
        self._slaves.remove(slave)
        slave.bus = None
        self.topology += 1
        return slave

    def at(self, address: int) -> list[Slave]:
        """Every slave answering to ``address`` (more than one is a wiring fault)."""
        return [s for s in self._slaves if s.address == address]

    def slave(self, address: int) -> Slave:
        """The one slave at ``address``."""
        found = self.at(_address(address))
        if len(found) != 1:
            raise BusError(f"{len(found) or 'no'} slaves at address {address}, expected one")
        return found[0]

    def set_inputs(self, address: int, value: int) -> None:
        self.slave(address).inputs = value

    def outputs(self, address: int) -> int:
        return self.slave(address).outputs

    def power_fail(self) -> None:
        """AS-i power fails (APF): the slaves stop, the master sees nobody."""
        if self._powered:
            self._powered = False
            for slave in self._slaves:
                slave.power_up()
                slave.lost_telegrams = 0
            self.topology += 1

    def power_restore(self) -> None:
        if not self._powered:
            self._powered = True
            for slave in self._slaves:
                slave.power_up()
            self.topology += 1

    def to_dict(self) -> dict[str, Any]:
        return {"powered": self._powered, "slaves": [s.to_dict() for s in self._slaves]}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> AsiBus:
        if not isinstance(data, dict) or not isinstance(data.get("slaves", []), list):
            raise BusError(f"a bus must be an object with a 'slaves' list, not {data!r}")
        bus = cls([Slave.from_dict(s) for s in data.get("slaves", [])])
        if not data.get("powered", True):
            bus.power_fail()
        return bus
