"""Whatever bytes a file holds, ``asictl check`` answers with diagnostics, never a traceback."""

from __future__ import annotations

from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from manual_examples import EXAMPLES

from asictl.cli import main

WORDS = [
    "[PROGRAM]", "[SETUP]", "[DECL]", "[GATING]", "[OPTIONS]", "[ASM]", "[RAW]", "[END]",
    "A", "AN", "O", "ON", "=", "S", "R", "N", "L", "T", "I", "Q", "F", "FY", "FW", "KT",
    "KB", "KP", "JU", "JC", "FB", "BE", "BEC", "***", "x:", "x", "4.0", "31.3", "999", "0Ah",
    "BYTE", "TIMER", "T20", "and", "or", "not", ";", "\n", "\r\n", ":", ",", "\x1a", "ä",
]


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.one_of(
        st.binary(max_size=300),
        st.lists(st.sampled_from(WORDS), max_size=60).map(lambda w: " ".join(w).encode()),
        st.tuples(st.sampled_from(sorted(EXAMPLES)), st.integers(0, 400), st.binary(max_size=3))
        .map(lambda t: _mutate(EXAMPLES[t[0]].encode(), t[1], t[2])),
    )
)
def test_check_never_prints_a_traceback(data: bytes):
    result = CliRunner().invoke(main, ["check", "-"], input=data)
    assert result.exit_code in (0, 1), result.output
    assert "Traceback" not in result.output
    assert "internal error" not in result.output


def _mutate(text: bytes, position: int, insert: bytes) -> bytes:
    position %= len(text) + 1
    return text[:position] + insert + text[position + 1 :]
