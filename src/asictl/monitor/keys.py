"""Every key of the monitor in words: what the help screen (``?``, F1) lists.

One table, so that the help, the bindings and docs/commissioning.md cannot drift apart:
``tests/monitor/test_monitor_layout.py`` holds the bindings to ``bound`` and the docs'
key table to ``label``. No Textual here: the table is data.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Key:
    """One row of the help: the keys as a user types them, and what they do."""

    #: as the help and the docs write the keys ("F5", "0 1 2 3", "arrows")
    label: str
    what: str
    #: Textual's names of the keys (what the bindings name)
    bound: tuple[str, ...]
    #: the views or boards where it works ("" everywhere)
    where: str = ""


KEYS: tuple[Key, ...] = (
    Key("? F1", "this help (Esc, q or ? closes it)", ("question_mark", "f1")),
    Key("q F10", "quit", ("q", "f10")),
    Key("F", "force OPERAND=VALUE or NAME=VALUE (I, Q, F, FY): held every cycle whatever "
        "the program writes, until released; forced slaves magenta, FORCE n on top",
        ("F",), "emulated board"),
    Key("R", "release a force (OPERAND or NAME; all: every force)", ("R",), "emulated board"),
    Key("v", "the program view: the source with each line's values in the latest cycle; "
        "v again: the slaves", ("v",)),
    Key("d", "the data view: hi-flags, control flags, timers, counters, flag bytes "
        "F0..F127 (beside the slaves on a wide terminal); d again: the slaves", ("d",)),
    Key("w", "the watch view: a chosen list of operands and names, each in binary, "
        "decimal and hex, forced ones marked; w again: the slaves", ("w",)),
    Key("arrows", "select a slave (the grid's rows: up and down)", ("left", "right", "up",
        "down"), "slave and data views"),
    Key("up down", "select a row", ("up", "down"), "watch view"),
    Key("+", "add operands or names to the watch list (comma-separated)", ("plus",),
        "watch view"),
    Key("-", "remove the selected row from the watch list", ("minus",), "watch view"),
    Key("=", "write once OPERAND=VALUE (the selected row's operand filled in): flags, "
        "outputs (program stopped), an emulated slave's inputs", ("equals_sign",),
        "watch view"),
    Key("up down PgUp PgDn", "scroll a line, a page", ("up", "down", "pageup", "pagedown"),
        "program view"),
    Key("n", "the next file (the main file, then each function block)", ("n",), "program view"),
    Key("x", "the values in hex / in decimal", ("x",), "program view"),
    Key("0 1 2 3", "toggle that input bit of the selected slave (emulated cable)",
        ("0", "1", "2", "3")),
    Key("o", "write the selected slave's outputs (program stopped)", ("o",)),
    Key("f", "write a flag byte (FY 10=0x12) or bit (F 10.0=1)", ("f",)),
    Key("P", "write the selected slave's parameter (0..15)", ("P",)),
    Key("h", "set the hi-flags: offline / online, data-exchange / no-data-exchange, "
        "auto-address / no-auto-address", ("h",)),
    Key("s", "start / stop the control program (the start flag)", ("s",)),
    Key("b", "press the set button (emulated board)", ("b",)),
    Key("p", "plug a slave in at the selected address (emulated cable)", ("p",),
        "slave and data views"),
    Key("u", "unplug the selected slave (emulated cable)", ("u",), "slave and data views"),
    Key("a", "change the selected slave's address", ("a",), "slave and data views"),
    Key("m", "switch protected / configuration mode", ("m",), "slave and data views"),
    Key("F5", "store the actual parameters (PI to PP)", ("f5",), "slave and data views"),
    Key("F6", "store the actual configuration (LDS, CDI to LPS, PCD)", ("f6",),
        "slave and data views"),
    Key("F9", "read everything again (the program image too)", ("f9",)),
    Key("[ ]", "the gateway's mode / set key, a short press", ("left_square_bracket",
        "right_square_bracket"), "a board 'asictl gateway serve' serves"),
    Key("{ } |", "the mode / set / both keys held 6 s", ("left_curly_bracket",
        "right_curly_bracket", "vertical_line"), "a board 'asictl gateway serve' serves"),
    Key("Esc", "cancel an entry", ("escape",)),
)

