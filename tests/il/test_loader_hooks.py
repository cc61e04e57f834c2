"""The loader reads block files through hooks, so an editor can supply unsaved buffers."""

from __future__ import annotations

from pathlib import Path

from asictl.il.checks import check_source
from asictl.source import from_string

MAIN = "[DECL]\nBlk FB blk.fb\n[PROGRAM]\n    JU FB Blk\n"


def test_an_unsaved_buffer_stands_for_a_missing_file(tmp_path: Path):
    main = from_string(str(tmp_path / "main.asi"), MAIN)
    assert [d.code for d in check_source(main).diagnostics] == ["E208"]
    buffers = {tmp_path / "blk.fb": from_string(str(tmp_path / "blk.fb"), "[PROGRAM]\n A I 40.0\n")}
    result = check_source(main, read=buffers.__getitem__, exists=buffers.__contains__)
    assert [(d.code, d.span.file) for d in result.diagnostics if d.span] == [
        ("E201", str(tmp_path / "blk.fb"))
    ]


def test_a_buffer_overrides_the_file_on_disk(tmp_path: Path):
    (tmp_path / "blk.fb").write_text("[PROGRAM]\n    A I 1.0\n")
    main = from_string(str(tmp_path / "main.asi"), MAIN)
    assert check_source(main).diagnostics == []
    edited = {tmp_path / "blk.fb": from_string(str(tmp_path / "blk.fb"), "[PROGRAM]\n A I 1.9\n")}
    result = check_source(
        main, read=lambda p: edited.get(p) or from_string(str(p), p.read_text()),
    )
    assert [d.code for d in result.diagnostics] == ["E201"]
