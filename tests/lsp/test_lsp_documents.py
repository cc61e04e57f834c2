"""The store of open buffers: a change drops only the analyses that read the changed
file, an analysis of texts that changed meanwhile is not kept, and lone surrogates are
replaced without moving anything."""

from __future__ import annotations

from pathlib import Path

from asictl.lsp.documents import Documents, clean

MAIN = "[DECL]\nLatch FB latch.fb\n[PROGRAM]\n JU FB Latch\n BE\n"
BLOCK = "[PROGRAM]\n A F 20.0\n = F 20.1\n"


def test_a_change_drops_only_the_analyses_that_read_the_file(tmp_path: Path):
    documents = Documents()
    a, b = str(tmp_path / "a.asi"), str(tmp_path / "b.asi")
    documents.open(a, "[PROGRAM]\n A F 1.0\n")
    documents.open(b, "[PROGRAM]\n A F 2.0\n")
    first_a, first_b = documents.analyse(a), documents.analyse(b)
    assert documents.cached(a) is first_a and documents.cached(b) is first_b
    documents.change(a, "[PROGRAM]\n A F 1.1\n")
    assert documents.cached(a) is None
    assert documents.cached(b) is first_b
    assert documents.analyse(a) is not first_a
    assert documents.is_current(first_b) and not documents.is_current(first_a)


def test_a_block_change_drops_its_main_programs_analysis(tmp_path: Path):
    documents = Documents()
    main, block = str(tmp_path / "main.asi"), str(tmp_path / "latch.fb")
    documents.open(main, MAIN)
    documents.open(block, BLOCK)
    analysis = documents.analyse(block)
    assert analysis.main == main and block in analysis.files
    documents.change(block, BLOCK.replace("F 20.1", "F 20.2"))
    assert documents.cached(main) is None
    assert documents.analyse(block).main == main


def test_opening_a_missing_block_drops_the_analysis_that_looked_for_it(tmp_path: Path):
    documents = Documents()
    main, block = str(tmp_path / "main.asi"), str(tmp_path / "latch.fb")
    documents.open(main, MAIN)
    missing = documents.analyse(main)
    assert any(d.is_error for d in missing.result.diagnostics)
    documents.open(block, BLOCK)
    assert documents.cached(main) is None
    assert not any(d.is_error for d in documents.analyse(main).result.diagnostics)


def test_an_analysis_of_texts_changed_meanwhile_is_not_kept(tmp_path: Path):
    documents = Documents()
    a = str(tmp_path / "a.asi")
    documents.open(a, "[PROGRAM]\n A F 1.0\n")
    view = documents.view()  # a check begins with these texts...
    documents.change(a, "[PROGRAM]\n A F 1.1\n")  # ...the editor changes one
    stale = view.analyse(a)
    assert "F 1.0" in stale.text(a)
    assert not documents.is_current(stale)
    assert documents.cached(a) is None
    assert "F 1.1" in documents.analyse(a).text(a)


def test_lone_surrogates_become_one_replacement_character_each():
    assert clean("A\ud800B\udfffC\U0001d11e") == "A\ufffdB\ufffdC\U0001d11e"
    documents = Documents()
    documents.open("/s.asi", "[PROGRAM]\n A F 1.0 ; \ud83d\n")
    assert documents.lines("/s.asi")[1] == " A F 1.0 ; \ufffd"
    documents.analyse("/s.asi").text("/s.asi").encode("utf-8")  # encodes: no surrogate
