"""Writing scenario files: the one writer behind every scenario asictl makes.

``asictl record`` (a running master's changes), ``asictl prove`` (counterexamples and
witnesses) and ``asictl diff`` (the scenario that tells two programs apart) all write
scenarios. They share this layout and TOML's quoting (``readers.tomlfile``), so what
one writes reads back like what another writes, and ``sim.scenario`` reads all of
them. Times are written as ``at_ms`` numbers, to the microsecond.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from asictl.readers.tomlfile import toml_string
from asictl.sim.scenario import SlaveSpec

#: A value to set or expect: a number, or a number already spelt as TOML (``0b0101``).
Value = int | str


class ScenarioWriter:
    """A scenario's text, built top to bottom: comments, ``program``, ``[master]``,
    then the steps in time order."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    def comment(self, text: str) -> None:
        """Comment lines; a control character TOML refuses in a comment (or Ctrl-Z,
        which ends a DOS text) is shown escaped."""
        self.lines += [f"# {_visible(line)}".rstrip() for line in text.splitlines()]

    def program(self, path: str) -> None:
        self.lines.append(f"program = {toml_string(path)}")

    def master(self, cycle_ms: float, slaves: Sequence[SlaveSpec] | None = None,
               first_tick_ms: float | None = None) -> None:
        self.lines += ["", "[master]", f"cycle_ms = {cycle_ms:g}"]
        if first_tick_ms is not None:
            self.lines.append(f"first_tick_ms = {first_tick_ms:g}")
        if slaves is not None:
            listed = ", ".join(
                f'{s.address} = "{s.io_code:X}h,{s.id_code:X}h,{s.parameter:X}h"'
                for s in slaves)
            self.lines.append(f"slaves = {{ {listed} }}")

    def step(self, at_ms: float, *, set: Mapping[str, Value] | None = None,
             expect: Mapping[str, Value] | None = None, within_ms: float | None = None
             ) -> None:
        """A ``[[step]]`` at ``at_ms``; ``within_ms`` is the tolerance of its ``expect``."""
        self.lines += ["", "[[step]]", f"at_ms = {_ms(at_ms)}"]
        if set:
            self.lines.append(f"set = {_table(set)}")
        if expect:
            self.lines.append(f"expect = {_table(expect)}")
            if within_ms is not None:
                self.lines.append(f"within_ms = {within_ms:g}")

    def text(self) -> str:
        return "\n".join(self.lines) + "\n"

    def drain(self) -> str:
        """The text so far, forgotten here: a long scenario (a recording of hours) is
        written out piece by piece; the pieces joined are what ``text`` would be."""
        text = self.text() if self.lines else ""
        self.lines.clear()
        return text


def _visible(line: str) -> str:
    return "".join(f"\\x{ord(c):02x}" if (ord(c) < 0x20 and c != "\t") or ord(c) == 0x7F
                   else c for c in line)


def _table(values: Mapping[str, Value]) -> str:
    return "{ " + ", ".join(f"{toml_string(k)} = {v}" for k, v in values.items()) + " }"


def _ms(value: float) -> str:
    """Milliseconds to the microsecond, without trailing zeros (``:g`` would round
    2000.001 to 2000)."""
    return f"{value:.3f}".rstrip("0").rstrip(".")
