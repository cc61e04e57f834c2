"""The Structured Text export as PLCopen TC6 XML (version 2.01), for CODESYS and other
IEC 61131-3 tools that import it (docs/migrate.md).

The same POUs as ``--to st``, each with its variables as ``interface`` and its code as an
ST ``body``; the global variables in a configuration's resource, with a cyclic task that
runs the program every 10 ms. Built with the standard library's ElementTree: the names
of the program's symbols are the ``name`` attributes.
"""

from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ET
from datetime import datetime
from pathlib import Path

from asictl import __version__
from asictl.errors import UserError
from asictl.export.st import Pou, StProgram, Var

NAMESPACE = "http://www.plcopen.org/xml/tc6_0201"
#: Where --check finds the TC6 schema (tc6_xml_v201.xsd, from plcopen.org: asictl may
#: not ship it)
SCHEMA_VARIABLE = "ASICTL_TC6_XSD"
XHTML = "http://www.w3.org/1999/xhtml"
_ARRAY = re.compile(r"ARRAY\[(\d+)\.\.(\d+)\] OF (\w+)\Z")
_ELEMENTARY = {"BOOL", "BYTE", "WORD", "DWORD", "INT", "DINT", "TIME"}


def _tag(name: str) -> str:
    return f"{{{NAMESPACE}}}{name}"


def _sub(parent: ET.Element, tag: str, **attributes: str) -> ET.Element:
    return ET.SubElement(parent, _tag(tag), attributes)


def _type(parent: ET.Element, spelled: str) -> None:
    """A ``type`` element for an ST type: elementary, ARRAY[a..b] OF T, or a block's."""
    holder = _sub(parent, "type")
    array = _ARRAY.match(spelled)
    if array is not None:
        element = _sub(holder, "array")
        _sub(element, "dimension", lower=array[1], upper=array[2])
        _sub(_sub(element, "baseType"), array[3])
    elif spelled in _ELEMENTARY:
        _sub(holder, spelled)
    else:
        _sub(holder, "derived", name=spelled)


def _variables(parent: ET.Element, kind: str, variables: tuple[Var, ...] | list[Var]) -> None:
    if not variables:
        return
    holder = _sub(parent, kind)
    for var in variables:
        attributes = {"name": var.name}
        if var.address:
            attributes["address"] = var.address
        element = _sub(holder, "variable", **attributes)
        _type(element, var.type)
        if var.comment:
            _text(_sub(element, "documentation"), var.comment)


def _text(parent: ET.Element, text: str) -> None:
    """A formattedText: one XHTML paragraph."""
    ET.SubElement(parent, f"{{{XHTML}}}p").text = text


def _pou(parent: ET.Element, pou: Pou) -> None:
    kind = "program" if pou.kind == "PROGRAM" else "functionBlock"
    element = _sub(parent, "pou", name=pou.name, pouType=kind)
    interface = _sub(element, "interface")
    _variables(interface, "localVars", pou.local)
    _text(_sub(_sub(element, "body"), "ST"), pou.body())
    _text(_sub(element, "documentation"), pou.title)


def plcopen_xml(program: StProgram, *, now: datetime | None = None) -> str:
    """The TC6 XML document of a Structured Text export."""
    ET.register_namespace("", NAMESPACE)
    ET.register_namespace("xhtml", XHTML)
    stamp = (now or datetime.now()).replace(microsecond=0).isoformat()
    project = ET.Element(_tag("project"))
    _sub(project, "fileHeader", companyName="asictl", productName="asictl",
         productVersion=__version__, creationDateTime=stamp,
         contentDescription=f"{program.name}, exported from AS-i Control IL")
    header = _sub(project, "contentHeader", name=program.name)
    coordinates = _sub(header, "coordinateInfo")
    for language in ("fbd", "ld", "sfc"):
        _sub(_sub(coordinates, language), "scaling", x="1", y="1")
    types = _sub(project, "types")
    _sub(types, "dataTypes")
    pous = _sub(types, "pous")
    for pou in program.pous:
        _pou(pous, pou)
    configurations = _sub(_sub(project, "instances"), "configurations")
    configuration = _sub(configurations, "configuration", name="Config")
    resource = _sub(configuration, "resource", name="Resource")
    task = _sub(resource, "task", name="Cycle", interval="T#10ms", priority="1")
    main = program.pous[-1]
    _sub(task, "pouInstance", name=f"{main.name}_instance", typeName=main.name)
    _variables(resource, "globalVars", program.globals)
    if program.unfinished:
        _text(_sub(project, "documentation"),
              f"{len(program.unfinished)} thing(s) to finish by hand: search for TODO")
    ET.indent(project)
    return ET.tostring(project, encoding="unicode", xml_declaration=True) + "\n"


def validate(text: str, schema: str | None = None) -> str | None:
    """Validate a TC6 document against the TC6 XML schema (``schema``, else
    ``ASICTL_TC6_XSD``) with lxml: None when valid, else the first complaint."""
    path = schema or os.environ.get(SCHEMA_VARIABLE)
    if not path:
        raise UserError(f"no TC6 schema to validate against: download tc6_xml_v201.xsd from "
                        f"plcopen.org and set {SCHEMA_VARIABLE} to it")
    try:
        from lxml import etree  # type: ignore[import-untyped, import-not-found, unused-ignore]
    except ImportError:
        raise UserError("validating PLCopen XML needs lxml: pip install lxml") from None
    try:
        checker = etree.XMLSchema(etree.parse(Path(path)))
    except (OSError, etree.XMLSyntaxError, etree.XMLSchemaParseError) as exc:
        raise UserError(f"{path}: not a usable XML schema: {exc}") from None
    document = etree.fromstring(text.encode("utf-8"))
    if checker.validate(document):
        return None
    return str(checker.error_log.last_error)
