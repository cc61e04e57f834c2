"""What the adapter needs from whatever it debugs, in the protocol's terms but no wire
format: a launched simulation and an attached live board answer the same questions."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

from asictl.runtime.line_map import SourceLine


@dataclass(frozen=True)
class Wanted:
    """A breakpoint as the editor sets it."""

    line: int
    condition: str = ""
    hit_condition: str = ""


@dataclass(frozen=True)
class Placed:
    """Where a wanted breakpoint went: its line with code (a comment line's breakpoint
    moves to the next line with code), or why it could not be placed."""

    number: int | None
    line: int | None = None
    message: str = ""

    @property
    def verified(self) -> bool:
        return self.number is not None


@dataclass(frozen=True)
class Stop:
    """Why the program stopped: a protocol ``stopped`` reason (``breakpoint``, ``step``,
    ``pause``, ``entry``, ``exception``), or ``end`` when the session is over."""

    reason: str
    description: str = ""
    text: str = ""
    breakpoints: tuple[int, ...] = ()
    #: for ``end``: 0 passed, 1 an expectation failed or the program stopped
    exit_code: int = 0


@dataclass(frozen=True)
class Frame:
    """One level of the call stack: a line of the main program or of a block."""

    name: str
    line: SourceLine | None


@dataclass(frozen=True)
class Variable:
    name: str
    value: str
    kind: str = ""
    #: setVariable may write it (an input or a flag)
    settable: bool = False


@dataclass(frozen=True)
class Scope:
    name: str
    variables: list[Variable] = field(default_factory=list)


#: How a resumed program runs: to a breakpoint, one line (into blocks), one line over
#: block calls, out of a block, to the first line of the next program cycle.
HOW = ("continue", "stepIn", "next", "stepOut", "stepCycle")


class Target(Protocol):
    #: source base name (as the line map names files) -> the file
    files: dict[str, Path]
    #: base name -> text, for the files the editor cannot open (an image's own source)
    sources: dict[str, str]

    def set_breakpoints(self, file: str, wanted: list[Wanted]) -> list[Placed]: ...

    def resume(self, how: str) -> Stop:
        """Run as ``how`` (one of ``HOW``) says until the program stops; blocks."""
        ...

    def interrupt(self) -> None:
        """Stop the running program at its next line (from another thread)."""
        ...

    def frames(self) -> list[Frame]:
        """The stack where the program stopped, innermost first."""
        ...

    def scopes(self) -> list[Scope]: ...

    def evaluate(self, text: str) -> str:
        """An operand, symbol or register as the program sees it now; in the console,
        any of the debugger's commands that do not run the program."""
        ...

    def assign(self, name: str, value: str) -> str:
        """Set an input or flag; the value now shown."""
        ...

    def close(self) -> None: ...
