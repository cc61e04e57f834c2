"""The part of a document a tool draws, between two markers: rewritten, or checked.

The tools that keep a table or a reference in docs/ up to date (tools/architecture.py,
tools/commands_doc.py) leave the rest of the page as written by hand; with ``--check``
they change nothing and fail when the page differs from what they would write.
"""

from __future__ import annotations

from pathlib import Path


def redraw(doc: Path, begin: str, end: str, drawn: str, argv: list[str], tool: str) -> int:
    """Put ``drawn`` between the markers ``begin`` and ``end`` (both kept) of ``doc``, or
    with ``--check`` in ``argv`` exit status 1 if that would change it; ``tool`` is the
    command that redraws it, named in the message."""
    text = doc.read_text(encoding="utf-8")
    head, sep, rest = text.partition(begin)
    _, sep2, tail = rest.partition(end)
    if not sep or not sep2:
        print(f"{doc}: the markers {begin!r} and {end!r} are missing")
        return 1
    new = head + begin + "\n" + drawn + end + tail
    if "--check" in argv:
        if new != text:
            print(f"{doc} is out of date: run {tool}")
            return 1
        return 0
    doc.write_text(new, encoding="utf-8")
    return 0
