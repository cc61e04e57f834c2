"""The gateway's front panel: seven LEDs, the four-digit display and the keys mode and set
(gateway manual 4.1-4.2, 5.1-5.6, chapter 8; docs/modbus.md has every sequence with its
lines).

The panel is part of the gateway's firmware: it looks at the master's execution control
directly and acts through the same host commands the Modbus side uses (``AddressMap``),
so a key does exactly what the equivalent Modbus write does. Time is master time: a key
press is a gesture with a known end (``press(keys, hold_ms)``), and ``tick`` carries out
what becomes due, the long-press actions at five seconds while a key is still held and
the short ones at release. The manual's timings:

- A press of at least ``LONG_MS`` (5 s) is long: "mindestens fünf Sekunden" (lines 256,
  368), "länger als fünf Sekunden" (286, 322, 334, 382), "ca. fünf Sekunden" (1403, 1407,
  1416); whatever is shorter is short ("kurzer Tastendruck", 282). A long action happens
  at 5 s while the key is held, as the manual's own procedure watches for it ("bis die
  angezeigte Adresse blinkt", 1407; "bis die LED prj mode [erlischt]", 1416) and the
  deletion shows "00" before the key is let go (334); a short action happens at release
  ("nach dem Loslassen", 334).
- Configuration mode shows the detected slaves in turn, two a second (``TURN_MS``: "im
  0,5 Sekundentakt", 262; "zwei pro Sekunde", 1341). A set press freezes the turn on the
  address shown when the key went down: that is "der gerade angezeigte Slave" (334).
- Both keys held 5 s open the interface settings (382); there mode and set act at release
  whatever the press's length, as they do on a blinking target (322, 370).
- For ``SELF_TEST_MS`` after a power-up every segment and every LED is lit, the self-test
  ("für ca. eine Sekunde", 222; code 88, 1367); the master starts up meanwhile, and what it
  reached shows when the test ends.

What the manual leaves open is decided here and listed in docs/modbus.md: a message (80,
81, 82, 90-95) stays until the next key press; the display shows 43 from the start of
normal operation until the master's Config_OK delay has run (DPRAM 1FDh), 83 for the time
the master's 8051 takes to copy the image (``COPY_US_PER_BYTE``); the LED ser active is
lit while telegrams for the gateway arrive less than ``SER_ACTIVE_MS`` apart (or the
Modbus watchdog's time, if longer).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from enum import StrEnum
from typing import Any

from asictl.board.board import Pc2Board
from asictl.board.execution import Phase
from asictl.gateway.addressmap import AddressMap
from asictl.platform import display as dc
from asictl.platform import pc2 as d
from asictl.platform.display import Display
from asictl.platform.gateway import SERIAL_CODES, UNITS, Interface
from asictl.platform.master import MACHINE_CYCLE_US, SLAVES, TICK_MS
from asictl.platform.pc2 import Command, EcFlag, HiFlag, Status

LONG_MS = 5000.0
TURN_MS = 500.0
SELF_TEST_MS = 1000.0
#: ser active stays lit this long after a telegram for the gateway (or the watchdog time).
SER_ACTIVE_MS = 1000.0
#: The master's 8051 copying the image from the EEPROM into RAM: a MOVX read, a MOVX
#: write, two DPTR increments and the loop's jump, about 12 machine cycles a byte.
COPY_US_PER_BYTE = 12 * MACHINE_CYCLE_US
#: A press shorter than this is contact bounce, not a press.
MIN_HOLD_MS = 50.0


class Key(StrEnum):
    MODE = "mode"
    SET = "set"


#: Command 20's status byte (PC2 manual 10.2.7) as the display's error code (chapter 8).
_ADDRESS_ERRORS: dict[int, int] = {
    Status.ERROR: dc.ADDRESS_ERROR,
    Status.NO_SLAVE: dc.ADDRESS_ERROR,
    Status.SLAVE_ZERO_PRESENT: dc.TARGET_TAKEN,
    Status.ADDRESS_OCCUPIED: dc.TARGET_TAKEN,
    Status.CANNOT_PROGRAM_ZERO: dc.NOT_SET,
    Status.CANNOT_SET_ADDRESS: dc.NOT_SET,
    Status.CANNOT_STORE_ADDRESS: dc.NOT_STORED,
}


@dataclass
class _Gesture:
    """One operation of the keys: from the first key down to the last key up."""

    #: key -> (down, up) in master time
    keys: dict[Key, tuple[float, float]]
    #: the long action happened (or the keys were locked): nothing more at release
    done: bool = False
    #: the display when the first key went down (what "the shown address" means)
    shown: Display | None = None
    #: a deletion happened: "00" while the key is still held (334)
    zeroed: bool = False

    @property
    def end_ms(self) -> float:
        return max(up for _, up in self.keys.values())

    def long_at(self) -> float | None:
        """When this gesture's long action is due, None if it has none: one key held
        ``LONG_MS``, or both held together ``LONG_MS``."""
        if len(self.keys) == 1:
            ((down, up),) = self.keys.values()
            return down + LONG_MS if up - down >= LONG_MS else None
        downs = [down for down, _ in self.keys.values()]
        ups = [up for _, up in self.keys.values()]
        together = max(downs)
        return together + LONG_MS if min(ups) - together >= LONG_MS else None


@dataclass
class _Selection:
    """What a set press chose, in the mode it was chosen in: a free address (configuration
    mode), a wrong address or the last short-time error (protected mode), a target."""

    kind: str  # "free", "wrong", "transient", "target"
    address: int
    mode: str


@dataclass
class _Menu:
    """The interface settings of 5.6: first the Modbus address, then the serial setting."""

    step: str  # "address" or "serial"
    interface: Interface
    hi_flags: int


class FrontPanel:
    """The front panel of one gateway over its master (see the module's docstring)."""

    def __init__(
        self, board: Pc2Board, addressmap: AddressMap, interface: Interface | None = None
    ) -> None:
        self.board = board
        self.map = addressmap
        #: the Modbus address and serial setting, as the keys set them (5.6)
        self.interface = interface or Interface()
        #: told of every interface setting stored by the keys (the Modbus slave, the
        #: serial line, the state file)
        self.on_interface: list[Callable[[Interface], None]] = []
        self._gesture: _Gesture | None = None
        self._message: int | None = None
        self._selection: _Selection | None = None
        self._menu: _Menu | None = None
        self._last_telegram_ms: float | None = None
        self._power_up_ms = board.power_up_ms

    # ------------------------------------------------------------------ the keys

    def press(self, keys: Iterable[Key | str], hold_ms: float) -> None:
        """Keys go down now and come up after ``hold_ms`` of master time (together with
        a gesture already going on, they form one: both keys)."""
        chosen = {Key(k) for k in keys}
        if not chosen or hold_ms < MIN_HOLD_MS:
            raise ValueError(f"a press needs a key and at least {MIN_HOLD_MS:g} ms")
        self.tick()
        now = self.board.now_ms
        gesture = self._gesture
        if gesture is None:
            self._message = None  # a message stays until the next key press
            gesture = self._gesture = _Gesture({}, shown=self.display())
            if self.map.settings.key_lock:
                self._message = dc.KEYS_LOCKED
                gesture.done = True
        for key in chosen:
            if key not in gesture.keys:
                gesture.keys[key] = (now, now + hold_ms)
        if Key.SET in chosen and not gesture.done and self._menu is None:
            # "wartet es mit einem Neustart auf einen Druck auf die Taste set" (1223)
            self.board.press_set_button()

    @property
    def busy_until_ms(self) -> float | None:
        """When the keys held now come up (None: none is held)."""
        return None if self._gesture is None else self._gesture.end_ms

    def tick(self) -> None:
        """Carry out what is due at the master's time now."""
        self._check_power_up()
        if self._message == dc.KEYS_LOCKED and not self.map.settings.key_lock:
            self._message = None
        gesture = self._gesture
        if gesture is None:
            return
        now = self.board.now_ms
        due = gesture.long_at()
        if not gesture.done and due is not None and now >= due and self._acts_at_once(gesture):
            gesture.done = True
            self._long(gesture)
        if now >= gesture.end_ms:
            self._gesture = None
            if not gesture.done and len(gesture.keys) == 1:
                self._short(next(iter(gesture.keys)), gesture)

    def _acts_at_once(self, gesture: _Gesture) -> bool:
        """In the menu a press acts at release, however long; so does a single key on a
        blinking target (both keys still open the interface settings)."""
        if self._menu is not None:
            return False
        if len(gesture.keys) > 1:
            return True
        selection = self._valid_selection()
        return selection is None or selection.kind != "target"

    def _check_power_up(self) -> None:
        """A restart of the master ends the key lock ("bis zum nächsten Neustart", 1192,
        1363) and whatever the keys were doing."""
        if self.board.power_up_ms != self._power_up_ms:
            self._power_up_ms = self.board.power_up_ms
            self.map.settings.key_lock = False
            self._message = self._selection = None

    # ------------------------------------------------------------------ what keys do

    def _long(self, gesture: _Gesture) -> None:
        keys = set(gesture.keys)
        if keys == {Key.MODE, Key.SET}:
            self._open_menu()
        elif keys == {Key.MODE}:
            if self.board.mode == "protected":
                self._command(Command.SET_OPERATION_MODE, 1)  # 256
            else:
                self._leave_configuration(store=True)  # 286
        elif self.board.mode == "configuration":
            self._set_long_configuration(gesture)
        else:
            self._set_long_protected()

    def _short(self, key: Key, gesture: _Gesture) -> None:
        if self._menu is not None:
            self._menu_key(key)
        elif key is Key.MODE:
            if self.board.mode == "configuration":
                self._leave_configuration(store=False)  # 282
        elif (selection := self._valid_selection()) is not None and selection.kind == "target":
            self._program(selection.address)
        elif self.board.mode == "configuration":
            self._select(self._next_free(gesture))
        else:
            self._step_protected()

    def _leave_configuration(self, *, store: bool) -> None:
        """Mode in configuration mode: protected mode, storing the actual configuration
        for a long press; never with a slave 0 present (292: display 80)."""
        if self.board.execution.lds & 1:
            self._message = dc.LEAVE_REFUSED
            return
        if store and not self._command(Command.STORE_ACTUAL_CONFIGURATION):
            return
        if not self._command(Command.SET_OPERATION_MODE, 0):
            self._message = dc.LEAVE_REFUSED

    def _command(self, code: Command, data: int = 0) -> bool:
        ok, _ = self.map.command(code, data)
        return ok

    def _change_address(self, old: int, new: int) -> bool:
        """Command 20; a failure is shown with its code (chapter 8)."""
        ok, status = self.map.command(Command.CHANGE_SLAVE_ADDRESS, new, old)
        if ok:
            return True
        self._message = _ADDRESS_ERRORS.get(status, dc.ADDRESS_ERROR)
        return False

    def _select(self, address: int | None, kind: str = "free") -> None:
        if address is not None:
            self._selection = _Selection(kind, address, self.board.mode)

    # --- configuration mode (5.4)

    def _next_free(self, gesture: _Gesture) -> int | None:
        """The next free operating address above the one shown (320, 334), round again."""
        shown = gesture.shown.code if gesture.shown is not None else None
        start = shown if shown is not None and shown < SLAVES else 0
        lds = self.board.execution.lds
        free = [a for a in range(1, SLAVES) if not lds >> a & 1]
        return next((a for a in free if a > start), free[0] if free else None)

    def _set_long_configuration(self, gesture: _Gesture) -> None:
        selection = self._valid_selection()
        if selection is not None and selection.kind == "free":
            self._select(selection.address, "target")  # 322: it blinks
            return
        shown = gesture.shown.code if gesture.shown is not None else None
        lds = self.board.execution.lds
        detected = shown is not None and 0 < shown < SLAVES and bool(lds >> shown & 1)
        if detected and shown is not None and self._change_address(shown, 0):
            gesture.zeroed = True  # 334: "00", the slave shown now has address 0

    def _program(self, target: int) -> None:
        """Set on a blinking target: the slave with address 0 gets it (322, 370)."""
        self._selection = None
        ec = self.board.execution
        if self.board.mode == "protected":
            if not ec.errors >> target & 1:
                return  # the error went (auto addressing, the host): nothing to do
            if not ec.lds & 1:
                self._message = dc.NO_SLAVE_ZERO
                return
            if ec.lds >> target & 1:
                projected = ec.lps >> target & 1
                self._message = dc.TARGET_TAKEN if projected else dc.SURPLUS_SLAVE
                return
            if ec.cdi[0] != ec.pcd[target]:
                self._message = dc.WRONG_PROFILE  # 370: must match the projected data
                return
        self._change_address(0, target)

    # --- protected mode (5.3.2, 5.5.2)

    def _protected_entries(self) -> list[tuple[str, int]]:
        """What short set presses step through: the wrong addresses, ascending (304), then
        the last short-time error if it is not one of them (306)."""
        ec = self.board.execution
        entries = [("wrong", a) for a in range(1, SLAVES) if ec.errors >> a & 1]
        last = ec.last_error
        if last is not None and not (last and ec.errors >> last & 1):
            entries.append(("transient", last))
        return entries

    def _step_protected(self) -> None:
        entries = self._protected_entries()
        if not entries:
            return
        selection = self._valid_selection()
        if selection is not None:
            current = (selection.kind, selection.address)
        else:
            order = self.board.execution.error_order
            current = ("wrong", order[0]) if order else ("", -1)
        following = entries.index(current) + 1 if current in entries else 0
        kind, address = entries[following % len(entries)]
        self._select(address, kind)

    def _set_long_protected(self) -> None:
        """368: the wrong address shown becomes the potential target; it blinks."""
        selection = self._valid_selection()
        ec = self.board.execution
        if selection is not None:
            address = selection.address if selection.kind == "wrong" else None
        else:
            address = ec.error_order[0] if ec.error_order else None
        if address is not None and ec.errors >> address & 1:
            self._select(address, "target")

    def _valid_selection(self) -> _Selection | None:
        """The selection, while it still means something (same mode; a wrong address
        still wrong, a free one still free)."""
        s = self._selection
        if s is None or s.mode != self.board.mode:
            self._selection = None
            return None
        ec = self.board.execution
        if (s.kind == "free" and ec.lds >> s.address & 1) or (
            s.kind in ("wrong", "target") and s.mode == "protected"
            and not ec.errors >> s.address & 1
        ) or (s.kind == "transient" and s.address != ec.last_error):
            self._selection = None
            return None
        return s

    # --- the interface settings (5.6)

    def _open_menu(self) -> None:
        """Both keys 5 s: the Modbus address first. Meanwhile Modbus is silent and the AS-i
        circuit in its safe state, the offline phase (410, 1195)."""
        hi = self.board.dpram[d.HI_FLAGS]
        self._menu = _Menu("address", self.interface, hi)
        self.map.driver.write_byte(d.HI_FLAGS, hi | HiFlag.OFFLINE)

    def _menu_key(self, key: Key) -> None:
        menu = self._menu
        assert menu is not None
        now = menu.interface
        if key is Key.SET:  # one more (384), the next code of the table (386)
            if menu.step == "address":
                unit = now.unit + 1 if now.unit < UNITS[-1] else UNITS[0]
                menu.interface = replace(now, unit=unit)
            else:
                index = SERIAL_CODES.index(now.code)
                menu.interface = now.with_code(SERIAL_CODES[(index + 1) % len(SERIAL_CODES)])
            return
        self._store(menu.interface)  # mode: taken and stored in the EEPROM (384, 386)
        if menu.step == "address":
            menu.step = "serial"
            return
        self._menu = None
        self.map.driver.write_byte(d.HI_FLAGS, menu.hi_flags)

    def _store(self, interface: Interface) -> None:
        self.interface = interface
        for listener in self.on_interface:
            listener(interface)

    @property
    def in_menu(self) -> bool:
        return self._menu is not None

    # ------------------------------------------------------------------ what it shows

    def telegram(self) -> None:
        """A Modbus telegram for this gateway was received and executed."""
        self._last_telegram_ms = self.board.now_ms

    def ser_active(self) -> bool:
        if self._menu is not None or self._last_telegram_ms is None:
            return False
        watchdog_ms = self.map.settings.watchdog * TICK_MS
        window = max(SER_ACTIVE_MS, watchdog_ms)
        return self.board.now_ms - self._last_telegram_ms <= window

    def in_self_test(self) -> bool:
        """The first second after a power-up (the end of a reset is one): all lit (222)."""
        board = self.board
        return not board.in_reset and board.now_ms - board.power_up_ms < SELF_TEST_MS

    def leds(self) -> dict[str, bool]:
        if self.in_self_test():
            return dict.fromkeys(dc.LEDS, True)
        ec = EcFlag.OFFLINE_READY if self.board.in_reset else self.board.execution.ec_flags
        return dc.leds(int(ec), ser_active=self.ser_active())

    def display(self) -> Display:
        """The display now, the most urgent thing first: the settings menu, a deletion
        while set is held, a message, the copy of the program, the start-up phases, then
        what the keys selected, then the basic state of the mode (1341, 1343); before all
        of them, in the first second after a power-up, the self-test (222)."""
        if self.in_self_test():
            return Display(dc.SELF_TEST, dc.display_text(dc.SELF_TEST))
        menu = self._menu
        if menu is not None:
            if menu.step == "address":
                return Display(menu.interface.unit, f"Modbus address {menu.interface.unit}")
            code = menu.interface.code
            return Display(code, f"serial setting: {dc.serial_setting_text(code)}")
        if self._gesture is not None and self._gesture.zeroed:
            return Display(0, "the slave shown now has address 0 (let go of set)")
        if self._message is not None:
            return Display(self._message, dc.display_text(self._message))
        board, ec = self.board, self.board.execution
        now = board.now_ms
        copied_ms, size = board.program_copy
        if size and now - copied_ms < size * COPY_US_PER_BYTE / 1000:
            return Display(dc.PROGRAM_COPY, dc.display_text(dc.PROGRAM_COPY))
        phase = Phase.OFFLINE if board.in_reset else ec.phase
        if phase is not Phase.NORMAL:
            code = {Phase.OFFLINE: dc.OFFLINE, Phase.DETECTION: dc.DETECTION,
                    Phase.ACTIVATION: dc.ACTIVATION}[phase]
            return Display(code, dc.display_text(code))
        if now * 1000 - ec.normal_since_us < ec.config_ok_delay * TICK_MS * 1000:
            return Display(dc.NORMAL_START, dc.display_text(dc.NORMAL_START))
        selection = self._valid_selection()
        if selection is not None:
            return _selected(selection)
        if board.mode == "configuration":
            held = self._gesture
            if held is not None and Key.SET in held.keys and held.shown is not None and (
                held.shown.code is not None and held.shown.code < SLAVES
            ):
                return held.shown  # the turn stands still while set is held
            detected = [a for a in range(SLAVES) if ec.lds >> a & 1]
            if not detected:
                return Display(None, "no slave detected")
            address = detected[int(now // TURN_MS) % len(detected)]
            return Display(address, f"slave {address} is detected")
        if ec.error_order:
            first = ec.error_order[0]
            return Display(first, f"slave {first} is wrongly configured (found first)")
        return Display(None, "no configuration error")

    def view(self) -> dict[str, Any]:
        """The panel as JSON: display, LEDs, the keys, the menu."""
        self.tick()
        gesture = self._gesture
        return {
            "display": self.display().to_json(),
            "leds": self.leds(),
            "keys_locked": self.map.settings.key_lock,
            "held": sorted(gesture.keys) if gesture is not None else [],
            "menu": None if self._menu is None else self._menu.step,
            "unit": self.interface.unit,
            "serial": dc.serial_setting_text(self.interface.code),
        }


def _selected(selection: _Selection) -> Display:
    a = selection.address
    if selection.kind == "target":
        return Display(a, f"target address {a}: set programs the slave with address 0 to it",
                       blinking=True)
    if selection.kind == "free":
        return Display(a, f"address {a} is free")
    if selection.kind == "wrong":
        return Display(a, f"slave {a} is wrongly configured")
    if a == 0:
        return Display(dc.POWER_FAIL, dc.display_text(dc.POWER_FAIL))
    return Display(a, f"the last short-time configuration error was at slave {a}")
