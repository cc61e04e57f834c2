"""Thousands of diagnostics: rendered in linear time, capped per file in text output.

A file with 40,000 errors once took 14 s to check (render_text split the whole text
again for every diagnostic, and the parser's error recovery had lark count the lines
before each resumption again). Time is not asserted here (benchmarks/
bench_diagnostics.py measures it); the work done is: each text is split once, and the
parser's line counter reads each character a bounded number of times.
"""

from __future__ import annotations

import json

import lark.lexer
import pytest
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st

from asictl.cli import main
from asictl.diagnostics import (
    EXCERPT_WIDTH,
    TEXT_LIMIT,
    Diagnostic,
    Severity,
    Span,
    render_text,
)
from asictl.il.parser import parse_text


class CountingText(str):
    """A source text that counts how often it is split into lines."""

    splits = 0

    def split(self, *args, **kwargs):  # type: ignore[override]
        CountingText.splits += 1
        return super().split(*args, **kwargs)


def test_render_text_splits_each_source_once():
    CountingText.splits = 0
    text = CountingText("x\n" * 1000)
    diagnostics = [Diagnostic(Severity.ERROR, "E1", "e", Span("f.asi", n, 1)) for n in
                   range(1, 1001)]
    render_text(diagnostics, {"f.asi": text}, limit=0)
    assert CountingText.splits == 1


def test_parser_error_recovery_counts_lines_in_linear_work(monkeypatch: pytest.MonkeyPatch):
    fed = [0]
    original = lark.lexer.LineCounter.feed

    def counting_feed(self, token, test_newline=True):
        fed[0] += len(token)
        return original(self, token, test_newline)

    monkeypatch.setattr(lark.lexer.LineCounter, "feed", counting_feed)
    text = "[PROGRAM]\n" + "x\n" * 2000
    _, diagnostics = parse_text(text, "f.asi")
    assert len(diagnostics) == 2000
    # each character is lexed by the failing attempt, the clean re-parse and the resume
    assert fed[0] <= 4 * len(text), fed[0]


def test_parser_reports_the_right_line_after_thousands_of_errors():
    _, diagnostics = parse_text("[PROGRAM]\n" + "x\n" * 3000 + "  L KB\n", "f.asi")
    assert [d.span.line for d in diagnostics] == list(range(2, 3003))


def errors(count: int) -> str:
    return "[PROGRAM]\n" + "x\n" * count


def test_check_shows_the_first_200_per_file_and_counts_the_rest(tmp_path, runner: CliRunner):
    (tmp_path / "a.asi").write_text(errors(250))
    (tmp_path / "b.asi").write_text(errors(3))
    result = runner.invoke(main, ["check", str(tmp_path / "a.asi"), str(tmp_path / "b.asi")])
    assert result.exit_code == 1
    lines = result.stderr.splitlines()
    a_errors = [line for line in lines if line.startswith(f"{tmp_path / 'a.asi'}:")
                and ": error:" in line]
    assert len(a_errors) == TEXT_LIMIT == 200
    assert f"{tmp_path / 'a.asi'}: 50 more diagnostics not shown (only the first 200 are)" \
        in lines
    assert sum(": error:" in line and "b.asi" in line for line in lines) == 3
    assert lines[-1] == "checked 2 files: 253 errors, 0 warnings"


def test_max_diagnostics_0_shows_all_and_json_always_has_all(tmp_path, runner: CliRunner):
    (tmp_path / "a.asi").write_text(errors(250))
    result = runner.invoke(main, ["check", "--max-diagnostics", "0", str(tmp_path / "a.asi")])
    assert sum(": error:" in line for line in result.stderr.splitlines()) == 250
    assert "not shown" not in result.stderr
    result = runner.invoke(main, ["check", "--max-diagnostics", "5", str(tmp_path / "a.asi")])
    assert sum(": error:" in line for line in result.stderr.splitlines()) == 5
    result = runner.invoke(main, ["check", "--format", "json", str(tmp_path / "a.asi")])
    assert len(json.loads(result.stdout)) == 250


def test_check_help_documents_the_cap(runner: CliRunner):
    assert "--max-diagnostics" in runner.invoke(main, ["check", "--help"]).output


def test_a_huge_source_line_is_shown_as_a_window_around_the_column():
    line = "a" * 100_000 + "X" + "b" * 100_000
    d = Diagnostic(Severity.ERROR, "E1", "e", Span("f", 1, 100_001))
    _, excerpt, caret = render_text([d], {"f": line}).splitlines()
    assert len(excerpt) < EXCERPT_WIDTH + 10
    assert excerpt[caret.index("^")] == "X"


# ----- properties ------------------------------------------------------------------------

diagnostic_lists = st.lists(
    st.tuples(st.sampled_from(["a.asi", "b.asi", "c.asi"]), st.integers(1, 5),
              st.integers(1, 400), st.integers(1, 5)),
    max_size=60,
)


@given(diagnostic_lists, st.integers(0, 10))
def test_every_file_shows_min_limit_and_counts_what_it_leaves_out(items, limit):
    diagnostics = [Diagnostic(Severity.ERROR, "E1", "m", Span(f, line, col, length))
                   for f, line, col, length in items]
    out = render_text(diagnostics, {}, limit=limit).splitlines()
    for name in ("a.asi", "b.asi", "c.asi"):
        total = sum(f == name for f, *_ in items)
        shown = sum(line.startswith(f"{name}:") and ": error:" in line for line in out)
        assert shown == (min(total, limit) if limit else total)
        more = [line for line in out if line.startswith(f"{name}: ") and "not shown" in line]
        if limit and total > limit:
            assert more == [f"{name}: {total - limit} more diagnostic"
                            f"{'' if total - limit == 1 else 's'} not shown "
                            f"(only the first {limit} are)"]
        else:
            assert more == []


@given(st.text(alphabet="ab\tX ", max_size=1000), st.integers(1, 1100), st.integers(1, 50))
def test_the_caret_points_at_the_same_character_however_long_the_line(line, column, length):
    d = Diagnostic(Severity.ERROR, "E1", "e", Span("f", 1, column, length))
    rendered = render_text([d], {"f": line}).splitlines()
    original = line.expandtabs(1).rstrip()
    if len(rendered) == 1:
        pytest.fail("a line that exists always gets an excerpt")
    _, excerpt, caret = rendered
    assert len(excerpt) <= 2 + EXCERPT_WIDTH + 6
    at = caret.index("^")
    if column <= len(original):
        assert excerpt[at] == original[column - 1]
    assert len(caret) <= max(len(excerpt), at + 1)
