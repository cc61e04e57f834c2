"""'Did you mean ...?': the closest known word to a misspelt one.

Sections, options, instructions, directives and commands all suggest the same way, so a
user learns one kind of hint.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def closest(word: str, choices: Iterable[str], *, cutoff: float = 0.7) -> str | None:
    """The choice most like ``word`` (case and underscores aside), if one is like enough."""
    by_form = {_form(c): c for c in choices}
    found = difflib.get_close_matches(_form(word), list(by_form), n=1, cutoff=cutoff)
    return by_form[found[0]] if found else None


def did_you_mean(word: str, choices: Iterable[str], *, quote: str = "'",
                 cutoff: float = 0.7) -> str:
    """``"; did you mean 'x'?"`` for the closest choice, or nothing."""
    found = closest(word, choices, cutoff=cutoff)
    return f"; did you mean {quote}{found}{quote}?" if found else ""


def _form(word: str) -> str:
    return word.casefold().replace("_", "").replace("-", "")
