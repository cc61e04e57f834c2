"""The monitor's screen (Textual): ASI_MON's monitor and editor modes and ASI_VIS at once.

Top: the master, its phase and mode, the control program and cycle times. Then the 31
slaves (and slave 0) with their input and output nibbles and list letters, the selected
slave's details, and the panel: hi-flags, timers and counters, the flag bytes F0..F127.
Bottom: the event log and the keys. How these stand depends on the terminal's size
(``layout_for``): the panel beside the grid, under it, or (80 x 24) in a view of its own
(``d``); the grid takes the most compact form that fits (``grid_form``), so every slave
is always on the screen. ``?`` and F1 list every key (``monitor.keys``).
The screen refreshes ``REFRESH_S`` apart;
reading the master happens in a worker thread, so a slow or vanished master never
freezes the screen (it is shown as gone, and found again when it returns).

Where the emulated gateway serves the board, the right side starts with its front panel
(the display, blinking or not, and the seven LEDs) and ``[`` ``]`` press its mode and set
keys, ``{`` ``}`` hold them 6 s, ``|`` holds both 6 s; the press goes on in the gateway
while the screen refreshes, so what the display does meanwhile is seen.

``v`` swaps the middle for the program view (``monitor.program``): the program's
source with each line's values from the latest cycle, scrolled with the arrows and
PgUp/PgDn, ``n`` jumping to the next file (the function blocks follow the main file).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, ClassVar

from rich.console import Group
from rich.table import Table
from rich.text import Text
from textual import events
from textual.app import App, ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Horizontal, Vertical, VerticalScroll
from textual.geometry import Size
from textual.screen import ModalScreen
from textual.widgets import Footer, Input, RichLog, Static

from asictl.diagnostics import printable
from asictl.errors import UserError
from asictl.host.commissioning import Change, check_address, image_changes, write_flags
from asictl.host.cycle_units import cycle_text
from asictl.host.emulated.actions import parse_address, parse_number, parse_profile
from asictl.host.force_list import Entry, forced_values
from asictl.host.forcing import force, unforce
from asictl.host.listing import Listing, listing_of
from asictl.host.master import Master
from asictl.host.status import (
    MasterStatus,
    SlaveData,
    StoredProgram,
    flag_rows,
    forced_text,
    hi_flag_text,
    profile_text,
    status_events,
    stop_text,
    symbol_text,
    timer_text,
)
from asictl.host.symbols import Names
from asictl.host.watch import Watched, watch_list
from asictl.il import ast
from asictl.il.ast import OperandKind
from asictl.monitor.keys import KEYS
from asictl.monitor.program import heading, render_rows
from asictl.monitor.source import MonitorSource, Snapshot, toggle_start
from asictl.observe.online import CycleLines
from asictl.observe.operands import Assignment, Operand, parse_assignment, parse_operand
from asictl.platform.display import DIGITS, LEDS, Display
from asictl.platform.master import IO_CODE_BITS, SLAVES
from asictl.platform.pc2 import HiFlag

#: Seconds between two refreshes.
REFRESH_S = 0.25
_LIST_LETTERS = {"LPS": "P", "LDS": "D", "LAS": "A", "LCS": "C", "LOS": "O"}
#: The screen's layouts, by the terminal's size (``layout_for``).
LAYOUTS = ("wide", "medium", "narrow")
#: The grid's forms, the most compact first: slaves a row, and whether a slave's list
#: letters stand beside its data (one line a row) or under it (two).
GRID_FORMS = ((8, True), (8, False), (4, True), (4, False), (2, True), (2, False))
_CELL = {True: len(" 0 0000/0000 PDACO"), False: len(" 0 0000/0000")}
_GAP = {True: 2, False: 1}
_LEGEND = "lists: P projected D detected A active C corrupted O offline"


def layout_for(width: int, height: int) -> str:
    """``wide``: the panel beside the grid and the slave's details (170 columns and
    more); ``medium``: the grid across, the panel and the details under it (110 x 34 and
    more); ``narrow`` (down to 80 x 24): the grid and the details, the panel in the data
    view (``d``)."""
    if width >= 170 and height >= 30:
        return "wide"
    if width >= 110 and height >= 34:
        return "medium"
    return "narrow"


def grid_form(width: int) -> tuple[int, bool]:
    """The most compact form of the grid that fits ``width`` columns: every slave 0..31
    is always on the screen."""
    for columns, beside in GRID_FORMS:
        if columns * (_CELL[beside] + _GAP[beside]) - _GAP[beside] <= width:
            return columns, beside
    return GRID_FORMS[-1]

Action = Callable[[Master], str | None]
#: Keys of the slave view only: the program view keeps those that change what the
#: program sees (inputs, outputs, flags, start and stop, the set button).
_SLAVE_VIEW_ONLY = frozenset({
    "move", "unplug", "toggle_mode", "store_parameters", "store_configuration",
})


def _lists(slave: SlaveData | None) -> str:
    if slave is None:
        return "     "
    return "".join(
        _LIST_LETTERS[name] if name in slave.lists else "." for name in _LIST_LETTERS
    )


class MonitorApp(App[None]):
    """The live view of one master; every key acts through ``MonitorSource``."""

    TITLE = "asictl monitor"
    CSS = """
    Screen { overflow: hidden; }
    #top { height: auto; max-height: 6; padding: 0 1; background: $boost; }
    #middle { height: auto; }
    #middle.program { height: 3fr; }
    #middle.gone { text-opacity: 50%; }
    #slaves, #left, #lower { height: auto; }
    #grid { height: auto; padding: 0 1; }
    #lower { border-top: solid $primary; }
    #detail { width: 1fr; height: auto; padding: 0 1; }
    #right, #under { width: 62; height: auto; padding: 0 1; display: none; }
    #right { border-left: solid $primary; }
    #under { border-left: solid $primary; }
    #program, #data, #watch { height: auto; padding: 0 1; display: none; }
    #program { height: 1fr; }
    #middle.program #slaves, #middle.data #slaves, #middle.watch #slaves { display: none; }
    #middle.program #program, #middle.data #data, #middle.watch #watch { display: block; }
    Screen.wide #right, Screen.medium #under { display: block; }
    #log { height: 1fr; min-height: 2; border-top: solid $primary; }
    #prompt { dock: bottom; display: none; }
    #prompt.visible { display: block; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("question_mark", "help", "Help", key_display="?"),
        Binding("f1", "help", "Help", show=False),
        Binding("q", "quit", "Quit"),
        Binding("f10", "quit", "Quit", show=False),
        Binding("v", "show('program')", "Program view"),
        Binding("v", "show('slaves')", "Slave view"),
        Binding("d", "show('data')", "Data view"),
        Binding("d", "show('slaves')", "Slave view"),
        Binding("w", "show('watch')", "Watch view"),
        Binding("w", "show('slaves')", "Slave view"),
        Binding("left", "move(-1)", "Select", show=False, priority=True),
        Binding("right", "move(1)", "Select", show=False, priority=True),
        Binding("up", "move(-1, True)", "Select", show=False, priority=True),
        Binding("down", "move(1, True)", "Select", show=False, priority=True),
        Binding("up", "scroll(-1)", "Scroll", show=False, priority=True),
        Binding("down", "scroll(1)", "Scroll", show=False, priority=True),
        Binding("up", "watch_row(-1)", "Row", show=False, priority=True),
        Binding("down", "watch_row(1)", "Row", show=False, priority=True),
        Binding("pageup", "page(-1)", "Scroll", show=False, priority=True),
        Binding("pagedown", "page(1)", "Scroll", key_display="↑↓ PgUp PgDn", priority=True),
        Binding("n", "next_file", "Next file"),
        Binding("x", "hex", "Hex/decimal"),
        Binding("plus", "prompt('watch')", "Add"),
        Binding("minus", "unwatch", "Remove"),
        Binding("equals_sign", "prompt('write')", "Write once"),
        Binding("0", "toggle_input(0)", "0-3 Input bit"),
        Binding("1", "toggle_input(1)", "Input bit 1", show=False),
        Binding("2", "toggle_input(2)", "Input bit 2", show=False),
        Binding("3", "toggle_input(3)", "Input bit 3", show=False),
        Binding("o", "prompt('output')", "Outputs"),
        Binding("f", "prompt('flag')", "Flags"),
        Binding("F", "prompt('force')", "Force"),
        Binding("R", "prompt('release')", "Release"),
        Binding("P", "prompt('parameter')", "Parameter"),
        Binding("h", "prompt('hiflags')", "Hi-flags"),
        Binding("s", "start_stop", "Start/stop"),
        Binding("b", "set_button", "Set button"),
        Binding("p", "prompt('plug')", "Plug"),
        Binding("u", "unplug", "Unplug"),
        Binding("a", "prompt('address')", "Address"),
        Binding("m", "toggle_mode", "Mode"),
        Binding("f5", "store_parameters", "Store PP"),
        Binding("f6", "store_configuration", "Store config"),
        Binding("f9", "reload", "Reload"),
        Binding("left_square_bracket", "key('mode', 0.2)", "mode key"),
        Binding("right_square_bracket", "key('set', 0.2)", "set key"),
        Binding("left_curly_bracket", "key('mode', 6)", "mode 6 s"),
        Binding("right_curly_bracket", "key('set', 6)", "set 6 s"),
        Binding("vertical_line", "key('both', 6)", "both 6 s"),
        Binding("escape", "cancel_prompt", "Cancel", show=False),
    ]
    #: what each prompt asks for
    PROMPTS: ClassVar[dict[str, str]] = {
        "output": "outputs of the selected slave (program stopped): 0b1000, 8h or 8",
        "flag": "flag byte or bit: 'FY 10=0x12' or 'F 10.0=1'",
        "plug": "plug in at the selected address: profile such as iiio,1 or Bh,0",
        "address": "new address for the selected slave",
        "parameter": "parameter for the selected slave: 0..15 (10, Ah, 0b1010)",
        "force": "force OPERAND=VALUE or NAME=VALUE, held every cycle: 'Q 17.0=1', "
                 "'I 4.0=0', 'FY 12=0x55'",
        "release": "release OPERAND or NAME ('all': every force)",
        "hiflags": "hi-flags: offline or online, data-exchange or no-data-exchange, "
                   "auto-address or no-auto-address",
        "watch": "operands, names or conditions to watch, comma-separated: 'F 10.0, Motor, "
                 "Q 2.0 and not I 1.2'",
        "write": "write once OPERAND=VALUE or NAME=VALUE: flags, outputs (program "
                 "stopped), inputs of an emulated slave",
    }

    def __init__(self, source: MonitorSource) -> None:
        super().__init__()
        self.source = source
        self.selected = 1
        self.status: MasterStatus | None = None
        #: why the master is gone (None: it answered the latest refresh); ``status`` is
        #: then the last one seen, at ``seen_at``
        self.error: str | None = None
        self.seen_at = 0.0
        self.emulated = False
        #: who keeps an emulated board running, and when this monitor took it over
        self.served_by: str | None = None
        self.took_over: float | None = None
        #: refreshes shown so far (tests and the refresh-rate benchmark read it)
        self.refreshes = 0
        #: "slaves" or "program": what the middle of the screen shows
        self.view = "slaves"
        #: the program view: the stored image, its listing, the first row shown
        self.program: StoredProgram | None = None
        self.listing = Listing()
        self.program_top = 0
        #: the view of this listing has been placed once (on its first instruction)
        self._placed = False
        self.lines: CycleLines | None = None
        self.lines_note: str | None = None
        self._refreshing = False
        self._program_rows = 1
        self._prompting: str | None = None
        self._shown: dict[str, Any] = {}
        #: the grid's slaves a row, as last drawn (up and down move by a row)
        self.columns = 8
        #: which of ``LAYOUTS`` the screen has
        self.layout_name = "wide"
        #: the program view's values in hex (``x``)
        self.hex_values = False
        #: the watch view's list and its selected row
        self.watched: list[Watched] = []
        self.watch_row = 0

    # ------------------------------------------------------------------ layout

    def compose(self) -> ComposeResult:
        yield Static(id="top")
        with Vertical(id="middle"):
            with Horizontal(id="slaves"):
                with Vertical(id="left"):
                    yield Static(id="grid")
                    with Horizontal(id="lower"):
                        yield Static(id="detail")
                        yield Static(id="under")  # the panel, under the grid (medium)
                yield Static(id="right")  # the panel, beside (wide)
            yield Static(id="data")
            yield Static(id="watch")
            yield Static(id="program")
        yield RichLog(id="log", max_lines=500, wrap=True)
        yield Input(id="prompt", select_on_focus=False)
        yield Footer()

    def on_mount(self) -> None:
        self.query_one("#log", RichLog).can_focus = False  # the arrows select slaves
        self._fit(self.size)
        self.source.notify = lambda text: self.call_from_thread(self.log_event, text)
        self.refresh_now()
        self.set_interval(REFRESH_S, self.refresh_now)

    def on_resize(self, event: events.Resize) -> None:
        self._fit(event.size)

    def _fit(self, size: Size) -> None:
        """The layout for the terminal's size (``layout_for``) as the screen's class."""
        wanted = layout_for(size.width, size.height)
        for name in LAYOUTS:
            self.screen.set_class(name == wanted, name)
        self.layout_name = wanted
        if self.status is not None:
            self._shown.clear()
            self._paint()

    def action_help(self) -> None:
        if not isinstance(self.screen, HelpScreen):
            self.push_screen(HelpScreen())

    # ------------------------------------------------------------------ refreshing

    def refresh_now(self) -> None:
        if self._refreshing:
            return
        self._refreshing = True
        self.run_worker(self._read, thread=True, group="refresh")

    def _read(self) -> None:
        snapshot = self.source.snapshot()
        self.call_from_thread(self._show, snapshot)

    def _show(self, snapshot: Snapshot) -> None:
        self._refreshing = False
        if not self.is_running:  # a refresh that ends while the screen closes
            return
        old = None if self.error else self.status
        was_error, self.error = self.error, snapshot.error
        if snapshot.status is not None:  # while gone: the last status seen, marked gone
            self.status, self.seen_at = snapshot.status, time.time()
            self.emulated = snapshot.emulated
        self.served_by, self.took_over = snapshot.served_by, snapshot.took_over
        for event in snapshot.events:
            self.log_event(event, style="bold yellow" if event.startswith("took over") else "")
        if snapshot.program is not None and snapshot.program is not self.program:
            self.program = snapshot.program
            listing = listing_of(snapshot.program)
            # the same lines read again keep the place; another program is placed anew
            self._placed = self._placed and listing.lines == self.listing.lines
            self.listing = listing
        self.lines, self.lines_note = snapshot.lines, snapshot.lines_note
        if snapshot.error and snapshot.error != was_error:
            self.log_event(f"master gone: {snapshot.error}", style="bold red")
        elif not snapshot.error and was_error:
            self.log_event("master found again")
        if (old is None) != (snapshot.status is None) or (
            old is not None and snapshot.status is not None
            and old.panel != snapshot.status.panel
        ):
            self.refresh_bindings()  # the panel's keys come and go with the gateway
        if old is not None and snapshot.status is not None:
            for event in status_events(old, snapshot.status):
                if self.emulated and event.startswith("configuration error"):
                    event += " (an emulated cable: 'asictl bus match' plugs in the [SETUP])"
                self.log_event(event)
        self.refreshes += 1
        self._paint()

    def _set(self, widget: str, content: Text | str) -> None:
        """Update a widget only when its content changed: no flicker, little work."""
        key = content.copy() if isinstance(content, Text) else content  # styles count too
        if self._shown.get(widget) != key:
            self._shown[widget] = key
            self.query_one(f"#{widget}", Static).update(content)

    def _paint(self) -> None:
        status = self.status
        if status is None:
            self._set("top", Text(f"master gone: {printable(str(self.error))}", style="bold red"))
            return
        self.query_one("#middle").set_class(self.error is not None, "gone")
        self._set("top", _top(
            status, gone=self.error, seen_at=self.seen_at, served_by=self.served_by,
            took_over=self.took_over,
        ))
        if self.view == "program":
            self._set("program", self._program_view(status))
            return
        if self.view == "data":
            self._set("data", _right(status))
            return
        if self.view == "watch":
            self._set("watch", _watch_view(status, self.watched, self.watch_row))
            return
        width = self.query_one("#grid", Static).content_size.width or self.size.width - 2
        grid, self.columns = _grid(status, self.selected, width)
        self._set("grid", grid)
        self._set("detail", _detail(status, self.selected))
        if self.layout_name != "narrow":
            self._set("right" if self.layout_name == "wide" else "under", _right(status))

    # ------------------------------------------------------------------ program view

    def _program_view(self, status: MasterStatus) -> Text:
        """Title and notes, the column titles, and the rows that fit, from ``program_top``."""
        size = self.query_one("#program", Static).content_size
        width = max(size.width, 60)
        text = Text()
        files = self.listing.files
        text.append("program view", style="bold")
        if files:
            text.append(f"  {files[0]}" + (f" (+ {', '.join(files[1:])})" if files[1:] else ""))
        lines = self.lines
        if lines is not None and lines.master_ms is not None:
            text.append(f"   latest cycle at master time {lines.master_ms:.1f} ms")
        slave = self._slave(self.selected)
        if slave is not None:
            text.append(
                f"   slave {self.selected}: in {slave.inputs:04b} out {slave.outputs:04b}",
                style="dim",
            )
        notes = [self.listing.note, self.lines_note or ""]
        stopped = stop_text(status)
        if stopped:
            notes.append(f"control program {status.control_state} ({stopped})")
        elif lines is not None:
            notes.append(lines.note)
        for note in filter(None, notes):
            text.append("\n" + note, style="yellow")
        text.append("\n")
        text.append_text(heading(self.listing, width, hex_values=self.hex_values))
        visible = max(1, size.height - text.plain.count("\n") - 1)
        self._program_rows = visible
        if not self._placed and self.listing.lines:
            # a comment header taller than the view would hide the program: open on its
            # first instruction (the top, when that shows anyway)
            first = next((i for i, line in enumerate(self.listing.lines) if line.code), 0)
            self.program_top, self._placed = (first if first >= visible else 0), True
        self.program_top = max(0, min(self.program_top, len(self.listing.lines) - visible))
        rows = render_rows(
            self.listing, lines, top=self.program_top, height=visible, width=width,
            stop_line=status.stop_line, hex_values=self.hex_values,
            names={operand: name for name, operand in status.symbols.items()},
        )
        if rows:
            text.append("\n")
            text.append_text(rows)
        return text

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        """Keys by view: arrows select a slave or scroll the program; ``v`` says where it
        goes."""
        program = self.view == "program"
        if action == "show":
            return parameters[0] != self.view
        if action == "key":  # the front panel's keys, where a gateway serves the board
            return self.status is not None and self.status.panel == "gateway"
        if action in ("scroll", "page", "next_file", "hex"):
            return program
        watch = self.view == "watch"
        if action in ("watch_row", "unwatch") or parameters in (("watch",), ("write",)):
            return watch
        if action == "move" and watch:
            return False
        if action in _SLAVE_VIEW_ONLY or parameters in (("plug",), ("address",)):
            return not program
        return True

    def action_show(self, view: str) -> None:
        self.view = view
        middle = self.query_one("#middle")
        middle.set_class(view == "program", "program")
        middle.set_class(view == "data", "data")
        middle.set_class(view == "watch", "watch")
        self.source.watch_lines = view == "program"
        self.refresh_bindings()
        if self.status is not None:
            self._paint()
        self.refresh_now()

    def _scroll_to(self, top: int) -> None:
        self.program_top = max(0, top)
        if self.status is not None:
            self._paint()

    def action_scroll(self, step: int) -> None:
        self._scroll_to(self.program_top + step)

    def action_page(self, pages: int) -> None:
        self._scroll_to(self.program_top + pages * max(1, self._program_rows - 1))

    def action_hex(self) -> None:
        """x: the program view's values in hex, or in decimal again."""
        self.hex_values = not self.hex_values
        if self.status is not None:
            self._paint()

    def action_watch_row(self, step: int) -> None:
        if self.watched:
            self.watch_row = (self.watch_row + step) % len(self.watched)
            if self.status is not None:
                self._paint()

    def action_unwatch(self) -> None:
        """-: the selected row leaves the watch list."""
        if self.watched:
            gone = self.watched.pop(self.watch_row)
            self.watch_row = max(0, min(self.watch_row, len(self.watched) - 1))
            self.log_event(f"no longer watching {gone.label}")
            if self.status is not None:
                self._paint()

    def _watch_add(self, found: list[Watched]) -> None:
        texts = {w.text for w in self.watched}
        self.watched += [w for w in found if w.text not in texts]
        if self.status is not None:
            self._paint()

    def action_next_file(self) -> None:
        """The next file's header at the top (after the last, the first again)."""
        later = [row for row in self.listing.headers() if row > self.program_top]
        last_page = self.program_top >= len(self.listing.lines) - self._program_rows
        self._scroll_to(later[0] if later and not last_page else 0)

    def log_event(self, text: str, style: str = "") -> None:
        stamp = time.strftime("%H:%M:%S ")
        line = Text(stamp, style="dim") + Text(printable(text), style=style)  # a board's text
        self.query_one("#log", RichLog).write(line)

    def _refused(self, what: str) -> bool:
        """A key that would act on the master, while it is gone: refused, and said so."""
        if self.error is None:
            return False
        self.log_event(f"{what}: refused, the master is gone ({self.error})", style="red")
        return True

    # ------------------------------------------------------------------ actions

    def _act(self, what: str, action: Action) -> None:
        """Run ``action`` in a worker; its outcome goes to the event log."""
        if self._refused(what):
            return

        def work() -> None:
            message = self.source.run(what, action)
            self.call_from_thread(self._acted, message)

        self.run_worker(work, thread=True, group="actions")

    def _acted(self, message: str) -> None:
        self.log_event(message)
        self.refresh_now()

    def action_move(self, step: int, rows: bool = False) -> None:
        """Select the next slave (``rows``: the one a grid row up or down)."""
        if self._prompting is not None:
            return
        self.selected = (self.selected + step * (self.columns if rows else 1)) % SLAVES
        if self.status is not None:
            self._paint()

    def _emulated_only(self, what: str) -> bool:
        if self._refused(what):
            return False
        if not self.emulated:
            self.log_event(f"{what}: only an emulated board's cable can be changed from here")
        return self.emulated

    def action_toggle_input(self, bit: int) -> None:
        if not self._emulated_only("input bit"):
            return
        address = self.selected
        current = self._slave(address)
        value = 0 if current is None else current.inputs >> bit & 1
        self._act(
            f"I {address}.{bit}={1 - value}",
            lambda m: _inputs(m, address, 1 << bit, (1 - value) << bit),
        )

    def action_start_stop(self) -> None:
        self._act("start/stop", toggle_start)

    def action_set_button(self) -> None:
        if self._emulated_only("set button"):
            self._act("set button pressed", lambda m: m.emulated("set_button") and None)

    def action_unplug(self) -> None:
        if not self._emulated_only("unplug"):
            return
        address = self.selected
        self._act(f"unplugged slave {address}", lambda m: m.emulated("unplug", address=address)
                  and None)

    def action_toggle_mode(self) -> None:
        configuration = self.status is not None and self.status.mode == "protected"
        wanted = "configuration" if configuration else "protected"

        def switch(master: Master) -> str:
            master.tools().set_mode(configuration=configuration)
            return f"switched to {wanted} mode"

        self._act(f"mode {wanted}", switch)

    def action_store_parameters(self) -> None:
        self._act("F5 store actual parameters: done", lambda m: m.tools().store_parameters())

    def action_store_configuration(self) -> None:
        self._act(
            "F6 store actual configuration: done", lambda m: m.tools().store_configuration()
        )

    def action_key(self, key: str, seconds: float) -> None:
        """The gateway's mode or set key (or both) held ``seconds``: the press goes on in
        the gateway while the screen refreshes, so the display is seen to change."""
        keys = ["mode", "set"] if key == "both" else [key]
        what = f"{' and '.join(keys)} key{'s' if len(keys) > 1 else ''} held {seconds:g} s"

        def press(master: Master) -> str:
            view = master.emulated("press", keys=keys, hold_ms=seconds * 1000, wait=False)
            return f"{what}: display {Display.from_json(view['display']).shown()}"

        self._act(what, press)

    def action_reload(self) -> None:
        self.source.reload_program()
        self.log_event("F9: reading everything again")
        self.refresh_now()

    # ------------------------------------------------------------------ prompts

    def action_prompt(self, kind: str) -> None:
        if self._refused(kind) or (kind in ("plug",) and not self._emulated_only("plug")):
            return
        self._prompting = kind
        prompt = self.query_one("#prompt", Input)
        prompt.placeholder = self.PROMPTS[kind]
        prompt.value = ""  # the placeholder shows both forms: 'FY 10=0x12' and 'F 10.0=1'
        selected = self.watched[self.watch_row] if self.watched else None
        if (self.view == "watch" and selected is not None and selected.operand is not None
                and kind in ("force", "release", "write")):
            row = selected.text  # the selected row's operand (a condition has none)
            prompt.value = row if kind == "release" else f"{row}="
        prompt.cursor_position = len(prompt.value)
        prompt.add_class("visible")
        prompt.focus()

    def action_cancel_prompt(self) -> None:
        self._close_prompt()

    def _close_prompt(self) -> None:
        self._prompting = None
        prompt = self.query_one("#prompt", Input)
        prompt.remove_class("visible")
        prompt.value = ""
        self.set_focus(None)

    def on_input_submitted(self, event: Input.Submitted) -> None:
        kind, text = self._prompting, event.value.strip()
        self._close_prompt()
        if kind is None or not text:
            return
        try:
            self._submit(kind, text)
        except UserError as exc:
            self.log_event(f"{kind}: {exc}")

    def _submit(self, kind: str, text: str) -> None:
        address = self.selected
        if kind == "output":
            check_address(address, zero=False)
            value = parse_number(text, "output value", 15)
            self._act(
                f"Q {address}={value:04b}",
                lambda m: m.tools().write_outputs({address: (0xF, value)}),
            )
        elif kind == "flag":
            changes = _flag(text)
            self._act(f"{text}: written", lambda m: write_flags(m.tools(), changes))
        elif kind == "plug":
            io_code, id_code = parse_profile(text)
            self._act(
                f"plugged in slave {address} ({IO_CODE_BITS[io_code]},{id_code:X})",
                lambda m: m.emulated("plug", address=address, io_code=io_code, id_code=id_code)
                and None,
            )
        elif kind == "address":
            new = parse_address(text)
            self._act(
                f"slave {address} now has address {new}",
                lambda m: m.tools().change_address(address, new),
            )
        elif kind == "parameter":
            check_address(address, zero=False)
            value = parse_number(text, "parameter", 15)

            def parameter(master: Master) -> str:
                answer = master.tools().write_parameter(address, value)
                return f"slave {address} got parameter {value:X}h, answered {answer:X}h"

            self._act(f"parameter {value:X}h to slave {address}", parameter)
        elif kind == "force":
            self._act(f"force {text}", lambda m: _forced(
                force(m, [Names(m).assignment(text, example="Q 17.0=1")]), f"forced {text}"))
        elif kind == "release":
            self._act(f"release {text}", lambda m: _released(m, text))
        elif kind == "hiflags":
            wanted = _hi_flags(text)
            self._act(f"hi-flags {text}", lambda m: _set_hi_flags(m, wanted))
        elif kind == "watch":
            items = [item.strip() for item in text.split(",") if item.strip()]

            def add(master: Master) -> str:
                found = watch_list(Names(master), items)
                self.call_from_thread(self._watch_add, found)
                return f"watching {', '.join(w.label for w in found)}"

            self._act(f"watch {text}", add)
        elif kind == "write":
            self._act(f"write {text}", lambda m: _write_once(
                m, Names(m).assignment(text, example="F 10.0=1")))

    def _slave(self, address: int) -> SlaveData | None:
        return None if self.status is None else self.status.slaves.get(str(address))


class HelpScreen(ModalScreen[None]):
    """``?`` and F1: every key of the monitor (``monitor.keys``), over the screen."""

    DEFAULT_CSS = """
    HelpScreen { align: center middle; }
    #help { width: 100%; max-width: 110; height: 100%; max-height: 44;
            border: round $primary; background: $surface; padding: 0 1; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("escape", "dismiss", "Close"),
        Binding("q", "dismiss", "Close", show=False),
        Binding("question_mark", "dismiss", "Close", show=False),
        Binding("f1", "dismiss", "Close", show=False),
    ]

    def compose(self) -> ComposeResult:
        table = Table.grid(padding=(0, 2))
        table.add_column(style="bold cyan", no_wrap=True)
        table.add_column()
        for key in KEYS:
            what = Text(key.what)
            if key.where:
                what.append(f"  ({key.where})", style="dim")
            table.add_row(Text(key.label), what)
        text = Group(
            Text("asictl monitor: the keys   (Esc, q or ? closes this help)\n", style="bold"),
            table,
            Text(
                "\nThe grid: each slave's input/output bits and its lists (P projected, "
                "D detected, A active, C corrupted, O offline); green active, yellow not "
                "active, red a configuration error, magenta forced. FORCE n on top: that "
                "many operands are forced."
            ),
        )
        with VerticalScroll(id="help"):
            yield Static(text)


# --------------------------------------------------------------------------- helpers


def _inputs(master: Master, address: int, mask: int, bits: int) -> None:
    master.emulated("inputs", changes=[[address, mask, bits]])


def _forced(entries: list[Entry], what: str) -> str:
    return f"{what}: FORCE {len(forced_values(entries))}"


def _released(master: Master, text: str) -> str:
    """R: release one operand or name, or 'all'."""
    if text.lower() == "all":
        released, left = unforce(master, None)
    else:
        released, left = unforce(master, [(Names(master).operand(text), text)])
    return _forced(left, f"released {text} ({released} released)")


#: The hi-flags prompt's words (as 'asictl hiflags' names them): the bit, and whether
#: the word sets it.
_HI_WORDS = {
    "offline": (HiFlag.OFFLINE, True), "online": (HiFlag.OFFLINE, False),
    "data-exchange": (HiFlag.DATA_EXCHANGE_OFF, False),
    "no-data-exchange": (HiFlag.DATA_EXCHANGE_OFF, True),
    "auto-address": (HiFlag.AUTO_ADDRESS_OFF, False),
    "no-auto-address": (HiFlag.AUTO_ADDRESS_OFF, True),
}


def _hi_flags(text: str) -> dict[HiFlag, bool]:
    """'offline no-auto-address' (commas or blanks, '--' allowed): bit -> set."""
    wanted = {}
    for word in text.replace(",", " ").split():
        entry = _HI_WORDS.get(word.lower().removeprefix("--"))
        if entry is None:
            raise UserError(f"'{word}': the hi-flags are {', '.join(_HI_WORDS)}")
        wanted[entry[0]] = entry[1]
    return wanted


def _set_hi_flags(master: Master, wanted: dict[HiFlag, bool]) -> str:
    tools = master.tools()
    flags = tools.read_hi_flags()
    for bit, on in wanted.items():
        flags = flags | bit if on else flags & ~bit
    tools.write_hi_flags(flags)
    return f"hi-flags {flags:02X}h: {hi_flag_text(flags)}"


def _write_once(master: Master, assignment: Assignment) -> str:
    """=: an operand written once: flags, outputs (program stopped), an emulated slave's
    inputs; the program may change it again in its next cycle (a force holds it)."""
    kind = assignment.operand.node.kind
    changes = image_changes(assignment)
    if kind in (OperandKind.F, OperandKind.FY):
        write_flags(master.tools(), changes)
    elif kind in (OperandKind.Q, OperandKind.QB):
        master.tools().write_outputs({n: (mask, bits) for n, mask, bits in changes})
    elif kind in (OperandKind.I, OperandKind.IB):
        master.emulated("inputs", changes=[list(change) for change in changes])
    else:
        raise UserError(f"'{assignment.written}' cannot be written: flags, outputs and "
                        "inputs can")
    return f"{assignment.written}: written"


def _flag(text: str) -> list[Change]:
    """'FY 10=0x12' or 'F 10.0=1': the flag changes."""
    try:
        assignment = parse_assignment(text, example="FY 10=0x12")
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if assignment.operand.node.kind not in (OperandKind.F, OperandKind.FY):
        raise UserError(f"'{assignment.written}' is no flag: 'FY 10=0x12' or 'F 10.0=1'")
    return image_changes(assignment)


def _top(
    status: MasterStatus, *, gone: str | None, seen_at: float = 0.0,
    served_by: str | None = None, took_over: float | None = None,
) -> Text:
    s = status
    text = Text()
    if gone:
        seen = time.strftime("%H:%M:%S", time.localtime(seen_at))
        text.append(f"MASTER GONE: {gone}", style="bold white on red")
        text.append(f"\nlast seen at {seen} (as below); keys that act on it are refused\n",
                    style="bold red")
    as_it_was = len(text)
    text.append(f"{s.master_name}  at {s.port}", style="bold")
    if took_over is not None:
        since = time.strftime("%H:%M:%S", time.localtime(took_over))
        text.append(f"   took over at {since}: served by this monitor", style="bold yellow")
    elif served_by:
        text.append(f"   served by {served_by}", style="dim")
    text.append("\n")
    text.append(f"{s.phase}, {s.mode} mode, ")
    text.append(
        "config ok" if s.config_ok else "CONFIGURATION ERROR",
        style="green" if s.config_ok else "bold red",
    )
    if s.held:  # a debugger holds the master still
        text.append(f"   control program {s.held}", style="bold yellow")
    else:
        text.append(f"   control program {s.control_state}")
        if stopped := stop_text(s):
            text.append(f" ({stopped})", style="yellow")
    if s.forced:  # the FORCE lamp
        text.append("   ")
        text.append(f" FORCE {len(s.forced)} ", style="bold white on magenta")
    text.append(f"\ncycle {cycle_text(s.cycle_time_ms, s.max_cycle_time_ms)}   ")
    text.append(f"program {s.program.identity or s.program.problem or 'none'}")
    if gone:
        text.stylize("dim", as_it_was)
    return text


def _grid(status: MasterStatus, selected: int, width: int) -> tuple[Text, int]:
    """Slaves 0..31 with their input/output bits and list letters, in the most compact
    form that fits ``width`` (``grid_form``); the text and its slaves a row."""
    columns, beside = grid_form(width)
    problems = set(status.missing) | set(status.unexpected)
    problems |= {w.slave for w in status.wrong_profile}
    forced = _forced_slaves(status)
    head = "slave in/out " + (_LEGEND if len(_LEGEND) + 13 <= width else "lists PDACO (? explains)")
    lines = [Text(head, style="dim")]
    gap = " " * _GAP[beside]
    for row in range(0, SLAVES, columns):
        line, letters = Text(), Text(style="dim")
        for address in range(row, row + columns):
            slave = status.slaves.get(str(address))
            style = "dim"
            if slave is not None:
                style = "green" if "LAS" in slave.lists else "yellow"
            if address in problems:
                style = "bold red"
            if address in forced:
                style = "bold magenta"
            if address == selected:
                style += " reverse"
            data = "----/----" if slave is None else f"{slave.inputs:04b}/{slave.outputs:04b}"
            if address > row:
                line.append(gap)
                letters.append(gap)
            line.append(f"{address:>2} {data}", style=style)
            if beside:
                line.append(f" {_lists(slave)}", style="dim")
            letters.append(f"   {_lists(slave)}    ")
        lines.append(line)
        if not beside:
            lines.append(letters)
    text = Text("\n").join(lines)
    return text, columns


def _detail(status: MasterStatus, selected: int) -> Text:
    slave = status.slaves.get(str(selected))
    text = Text(f"slave {selected}", style="bold")
    if slave is None:
        text.append("  in no list (not projected, not detected)")
        return text
    text.append(f"   lists {' '.join(slave.lists) or '(none)'}\n")
    text.append(f"inputs  {slave.inputs:04b}   outputs {slave.outputs:04b}\n")
    text.append(
        f"PCD {profile_text(slave.pcd)} ({IO_CODE_BITS[slave.pcd & 0xF]})   "
        f"CDI {profile_text(slave.cdi)} ({IO_CODE_BITS[slave.cdi & 0xF]})\n"
    )
    text.append(f"PP {slave.pp:X}h   PI {slave.pi:X}h   errors "
                + ("-" if slave.errors is None else str(slave.errors)))
    forced = [str(f) for f in status.forced or [] if _slave_of(f.operand) == selected]
    if forced:
        text.append("\nforced  " + ", ".join(forced), style="bold magenta")
    names = [f"{name} = {operand}" for name, operand in status.symbols.items()
             if _slave_of(operand) == selected]
    if names:
        text.append("\nnames   " + ", ".join(names), style="cyan")
    return text


def _slave_of(operand: str) -> int | None:
    """The slave an input or output operand's text names ('I 4.0', 'Q 17'), else None."""
    try:
        node = parse_operand(operand).node
    except ValueError:
        return None
    return node.address if node.kind in (OperandKind.I, OperandKind.Q) else None


def _forced_slaves(status: MasterStatus) -> set[int]:
    return {n for f in status.forced or [] if (n := _slave_of(f.operand)) is not None}


#: The LEDs' colours on the gateway's front.
_LED_STYLE = {"config_err": "bold red", "prj_mode": "bold yellow", "prg_enable": "bold yellow"}


def _panel(status: MasterStatus) -> Text:
    """The gateway's front: the display and its seven LEDs (lit: a filled dot)."""
    text = Text()
    source = "gateway panel" if status.panel == "gateway" else "gateway (from its flags)"
    display = status.display
    text.append(f"{source}  ", style="bold")
    text.append(f" {display.text or ' ' * DIGITS} ", style="reverse blink" if display.blinking
                else "reverse")
    text.append(f"  {display.meaning}" + (", blinking" if display.blinking else ""))
    if status.keys_locked:
        text.append("  keys locked", style="bold red")
    for row, (name, label) in enumerate(LEDS.items()):
        lit = bool(status.leds and status.leds.get(name))
        text.append("\n" if row in (0, 4) else "  ")
        text.append("● " if lit else "○ ", style=_LED_STYLE.get(name, "bold green") if lit
                    else "dim")
        text.append(label, style="" if lit else "dim")
    text.append("\n\n")
    return text


def _right(status: MasterStatus) -> Text:
    s = status
    flags = [name for name in ("start_flag", "ignore_config_errors", "wait_for_set_button",
                               "map_counters", "control_active") if getattr(s, name)]
    panel = _panel(s) if s.leds is not None else Text()
    lines = [
        f"ec-flags {s.ec_flags:02X}h"
        + ("" if s.leds is not None else f"  display {s.display.shown()}"),
        f"hi-flags {s.hi_flags:02X}h {hi_flag_text(s.hi_flags)}",
        f"control flags {s.control_flags:02X}h {' '.join(flags) or '(none)'}",
        *timer_text(s),
        *forced_text(s),
        *symbol_text(s),
        "",
        "flag bytes F0..F127",
        *flag_rows(s.flags),
    ]
    return panel + Text("\n".join(lines))


#: The whole a bit of these kinds is forced with: its slave's data bits, its flag byte.
_WHOLE = {
    OperandKind.I: (OperandKind.I, ast.Width.NIBBLE),
    OperandKind.Q: (OperandKind.Q, ast.Width.NIBBLE),
    OperandKind.F: (OperandKind.FY, ast.Width.BYTE),
}


def _held(operand: Operand, forced: set[str]) -> bool:
    """The operand is forced: itself, or the slave or flag byte its bit is in (``Q 17``
    holds ``Q 17.3``, ``FY 10`` holds ``F 10.0``)."""
    node = operand.node
    if str(operand) in forced:
        return True
    whole = _WHOLE.get(node.kind)
    if whole is None or node.bit < 0:
        return False
    return str(ast.Operand(whole[0], node.address, -1, whole[1])) in forced


def _watch_view(status: MasterStatus, watched: list[Watched], selected: int) -> Text:
    """The watch list: each operand (and its name) or condition in binary, decimal and
    hex, forced ones marked."""
    text = Text("watch view", style="bold")
    text.append("   + add  - remove  = write once  F force  R release  (the selected row)\n",
                style="dim")
    if not watched:
        text.append("nothing watched yet: + adds operands or names ('F 10.0, FY 11, Motor')",
                    style="yellow")
        return text
    width = max(len(w.label) for w in watched) + 2
    text.append(f"{'operand':<{width}}{'binary':>18}{'decimal':>9}{'hex':>7}\n", style="bold")
    forced = {f.operand for f in status.forced or []}
    for row, entry in enumerate(watched):
        try:
            value: int | None = entry.value(status)
        except UserError:
            value = None
        held = entry.operand is not None and _held(entry.operand, forced)
        style = "reverse" if row == selected else ""
        if value is None:
            cells = f"{'n/a':>18}{'':>9}{'':>7}"
        else:
            cells = f"{value:>18b}{value:>9}{value:>6X}h"
        text.append(f"{entry.label:<{width}}{cells}", style=style)
        if held:
            text.append("  FORCED", style="bold magenta")
        text.append("\n")
    text.rstrip()
    return text
