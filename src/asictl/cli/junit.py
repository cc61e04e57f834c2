"""JUnit XML, the test report CI systems show: written by ``asictl test --junit`` and
read back by ``asictl report merge``, so both put a suite together the same way."""

from __future__ import annotations

from xml.etree import ElementTree

#: The root element asictl writes, and the only one ``report merge`` reads.
SUITE = "testsuite"


def suite(cases: list[ElementTree.Element]) -> str:
    """The document of one suite holding ``cases`` (``testcase`` elements, each with a
    ``failure`` or ``error`` child if it did not pass), counted from the cases
    themselves so that a merged suite counts as one run would."""
    root = ElementTree.Element(
        SUITE, name="asictl", tests=str(len(cases)),
        failures=str(sum(1 for c in cases if c.find("failure") is not None)),
        errors=str(sum(1 for c in cases if c.find("error") is not None)),
    )
    root.extend(cases)
    ElementTree.indent(root)
    return ElementTree.tostring(root, encoding="unicode", xml_declaration=True) + "\n"

