"""``asictl export --to plcopen``: the Structured Text export as PLCopen TC6 XML 2.01.

The TC6 schema (tc6_xml_v201.xsd) is PLCopen's and is not shipped here: with a copy
named by ``ASICTL_TC6_XSD`` every demo is validated against it (lxml); without one, the
document's structure is checked element by element with the standard library.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from datetime import datetime
from pathlib import Path

import pytest

from asictl.build import build_file
from asictl.errors import UserError
from asictl.export.plcopen import NAMESPACE, SCHEMA_VARIABLE, plcopen_xml, validate
from asictl.export.st import export_st
from asictl.observe.symbols import SymbolTable

DEMOS = Path(__file__).parents[2] / "demos"
SCHEMA = os.environ.get(SCHEMA_VARIABLE)
N = {"p": NAMESPACE, "x": "http://www.w3.org/1999/xhtml"}


def _xml(name: str, symbols: SymbolTable | None = None) -> str:
    program = build_file(DEMOS / name).program
    assert program is not None
    return plcopen_xml(export_st(name, program, symbols), now=datetime(2026, 1, 2, 3, 4, 5))


needs_schema = pytest.mark.skipif(SCHEMA is None and not os.environ.get("CI"),
                                  reason=f"needs a copy of tc6_xml_v201.xsd in ${SCHEMA_VARIABLE}")


@needs_schema
def test_every_demo_is_valid_against_the_tc6_schema() -> None:
    pytest.importorskip("lxml")
    complaints = {path.name: validate(_xml(path.name)) for path in sorted(DEMOS.glob("*.asi"))}
    assert complaints == dict.fromkeys(complaints)


@needs_schema
def test_a_document_the_schema_refuses_is_reported() -> None:
    pytest.importorskip("lxml")
    text = _xml("logic.asi").replace('pouType="program"', 'pouType="routine"')
    assert "routine" in (validate(text) or "")


def test_the_document_holds_the_pous_their_st_and_the_globals() -> None:
    root = ET.fromstring(_xml("fb.asi", SymbolTable("s", {"lamp": ("Lamp", "Q 2.0")})))
    assert root.tag == f"{{{NAMESPACE}}}project"
    assert root.find("p:fileHeader", N).get("creationDateTime") == "2026-01-02T03:04:05"
    pous = root.findall("p:types/p:pous/p:pou", N)
    assert [(p.get("name"), p.get("pouType")) for p in pous] == [
        ("Latch", "functionBlock"), ("Count3", "functionBlock"), ("fb", "program")]
    body = pous[-1].find("p:body/p:ST/x:p", N).text
    assert "IL_FB_Latch();" in body and "Lamp := IL_RLO;" in body
    globals_ = root.find("p:instances/p:configurations/p:configuration/p:resource/p:globalVars",
                         N)
    lamp = globals_.find("p:variable[@name='Lamp']", N)
    assert lamp.get("address") == "%QX1.0"
    assert lamp.find("p:type/p:BOOL", N) is not None
    i2 = globals_.find("p:variable[@name='IL_I2']/p:type/p:array", N)
    assert i2.find("p:dimension", N).attrib == {"lower": "0", "upper": "15"}
    instance = globals_.find("p:variable[@name='IL_FB_Latch']/p:type/p:derived", N)
    assert instance.get("name") == "Latch"
    task = root.find(".//p:task", N)
    assert task.find("p:pouInstance", N).get("typeName") == "fb"


def test_validating_without_a_schema_says_where_to_get_one(monkeypatch) -> None:
    monkeypatch.delenv(SCHEMA_VARIABLE, raising=False)
    with pytest.raises(UserError, match=r"tc6_xml_v201\.xsd"):
        validate(_xml("logic.asi"))
