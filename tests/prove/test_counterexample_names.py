"""Counterexample file names: one per property name, the same in every run, and never
written through a symbolic link planted at the name."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st
from test_prove import RACE

from asictl.cli import main
from asictl.prove.props import Kind, Property
from asictl.prove.session import prove


def _slug(name: str) -> str:
    return Property(name, Kind.NEVER, None, 1).slug  # type: ignore[arg-type]


@given(st.lists(st.text(min_size=1, max_size=12), min_size=2, max_size=6, unique=True))
def test_different_names_never_share_a_slug(names: list[str]):
    slugs = [_slug(name) for name in names]
    assert len(set(slugs)) == len(slugs)
    assert all(s and all(c.isascii() and (c.isalnum() or c == "-") for c in s)
               for s in slugs)


def test_plain_names_keep_their_readable_slug_and_others_are_told_apart():
    assert _slug("never both directions") == "never-both-directions"
    assert _slug("the timer never holds more than 500 ms") == \
        "the-timer-never-holds-more-than-500-ms"
    pairs = [("a.b", "a-b"), ("a b", "a_b"), ("Tür zu", "Tor zu"), ("ÄÖÜ", "日本"),
             ("Stop", "stop")]
    for one, other in pairs:
        assert _slug(one) != _slug(other)
    assert _slug("Tür zu").startswith("t-r-zu-")
    assert _slug("日本").startswith("property-")
    assert _slug("Tür zu") == _slug("Tür zu")  # stable: no counter, no run-dependent part


def _two_props(tmp_path: Path, first: str, second: str) -> Path:
    (tmp_path / "p.asi").write_text(RACE)
    props = tmp_path / "p.props.toml"
    props.write_text("[master]\ncycle_ms = 5\n" + "".join(
        f'[[property]]\nname = "{name}"\nnever = "Q 2.0 and Q 2.1"\n'
        for name in (first, second)))
    return props


@pytest.mark.parametrize(("first", "second"), [
    ("never both!", "never both?"), ("Tür", "Tor"), ("über", "日本")])
def test_two_refuted_properties_keep_two_counterexamples(tmp_path: Path, first: str,
                                                         second: str):
    report = prove(_two_props(tmp_path, first, second), timeout_s=300.0)
    written = [report.written[first], report.written[second]]
    assert written[0] != written[1]
    assert all(path.is_file() and path.parent == tmp_path for path in written)
    assert f"'{first}'" in written[0].read_text(encoding="utf-8")
    assert f"'{second}'" in written[1].read_text(encoding="utf-8")


def test_a_dangling_link_at_the_name_is_refused_and_not_followed(tmp_path: Path, runner):
    props = _two_props(tmp_path, "never both", "never both again")
    elsewhere = tmp_path / "elsewhere.txt"
    link = tmp_path / "p.cex.never-both.scenario.toml"
    os.symlink(elsewhere, link)
    for force in ([], ["--force"]):
        result = runner.invoke(main, ["prove", str(props), "--timeout", "300s", *force])
        assert result.exit_code == 2, result.output
        assert "is a symbolic link" in result.output
        assert not elsewhere.exists() and link.is_symlink()
