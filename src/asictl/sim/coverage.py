"""Coverage reports: json (asictl's own, docs/testing.md), Cobertura XML, lcov and
SonarQube's generic coverage XML.

CI systems show Cobertura (GitLab's ``coverage_report``, Codecov), lcov (Codecov,
Coveralls, genhtml) and the generic XML (SonarQube) on the source, so all name each
program by its path relative to the current folder. None has a kind for conditions:
they carry them as branches, two per bit operand (read as 0, read as 1), beside the two
of each JC or BEC (taken, not taken); the json report keeps the three kinds apart.
"""

from __future__ import annotations

import json
import os
import time
from collections import defaultdict
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path, PurePath
from typing import Any
from xml.etree import ElementTree

from asictl import __version__
from asictl.observe.coverage import Coverage

FORMATS = ("cobertura", "lcov", "json", "sonarqube")
#: Format by file suffix, for ``--coverage FILE`` without ``--coverage-format``.
_BY_SUFFIX = {".json": "json", ".info": "lcov", ".lcov": "lcov", ".xml": "cobertura"}


def format_for(path: str, given: str | None) -> str:
    """The format asked for, else the one the file's suffix names (else Cobertura)."""
    return given or _BY_SUFFIX.get(PurePath(path).suffix.lower(), "cobertura")


def percent(covered: int, counted: int) -> float:
    """Covered share in percent; nothing to count is all of it."""
    return 100.0 * covered / counted if counted else 100.0


def summary(coverage: Coverage) -> str:
    """``coverage: lines 93% (112/120), branches 80% (8/10), conditions 75% (30/40)``;
    the percentages rounded down (99.5 % is not 100 %), ``n/a`` where there is nothing
    to count (a program without a jump has no branches: not 100 % of them)."""
    parts = [
        f"{kind} {covered * 100 // counted}% ({covered}/{counted})" if counted
        else f"{kind} n/a"
        for kind, (covered, counted) in coverage.totals().items()
    ]
    return "coverage: " + ", ".join(parts)


def missing(coverage: Coverage, names: Mapping[str, Mapping[str, str]]) -> list[str]:
    """Each outcome never seen, as coverage.py's term-missing lists them, by file and
    line: ``main.asi:15 never ran``, ``main.asi:10 branch never taken``, ``main.asi:9:9
    I 1.1 (Stop) never 1``. ``names``: the resolved path of a program -> its operands'
    names (a function block's file has none)."""
    rows: list[tuple[str, int, int, str]] = []
    for file, kinds in _by_file(coverage).items():
        shown = _relative(file)
        named = names.get(str(Path(file).resolve()), {})
        rows += [(shown, line, 0, f"{shown}:{line} never ran")
                 for line, hits in kinds.lines if not hits]
        for line, taken, not_taken in kinds.branches:
            rows += [(shown, line, 0, f"{shown}:{line} branch never {what}")
                     for what, count in (("taken", taken), ("not taken", not_taken))
                     if not count]
        for line, column, operand, zero, one in kinds.conditions:
            name = f" ({named[operand]})" if operand in named else ""
            rows += [(shown, line, column,
                      f"{shown}:{line}:{column} {operand}{name} never {value}")
                     for value, count in ((0, zero), (1, one)) if not count]
    return [text for *_, text in sorted(rows)]


def _relative(path: str) -> str:
    """``path`` from the current folder, with forward slashes (as CI systems match it)."""
    try:
        shown = os.path.relpath(path)
    except ValueError:  # another drive
        shown = path
    return PurePath(shown).as_posix()


@dataclass
class _File:
    """One file's rows, each sorted by line."""

    #: (line, hits)
    lines: list[tuple[int, int]] = field(default_factory=list)
    #: (line, taken, not taken)
    branches: list[tuple[int, int, int]] = field(default_factory=list)
    #: (line, column, operand, read as 0, read as 1)
    conditions: list[tuple[int, int, str, int, int]] = field(default_factory=list)

    def outcomes(self) -> dict[int, list[int]]:
        """line -> the counts of each of its outcomes (a branch's two, or two for each
        bit operand by column)."""
        found: dict[int, list[int]] = defaultdict(list)
        for line, taken, not_taken in self.branches:
            found[line] += [taken, not_taken]
        for line, _, _, zero, one in self.conditions:
            found[line] += [zero, one]
        return dict(found)


def _by_file(coverage: Coverage) -> dict[str, _File]:
    files: dict[str, _File] = defaultdict(_File)
    for (file, line), hits in coverage.lines.items():
        files[file].lines.append((line, hits))
    for (file, line), (taken, not_taken) in coverage.branches.items():
        files[file].branches.append((line, taken, not_taken))
    for (file, line, column, operand), (zero, one) in coverage.conditions.items():
        files[file].conditions.append((line, column, operand, zero, one))
    for rows in files.values():
        rows.lines.sort()
        rows.branches.sort()
        rows.conditions.sort()
    return dict(sorted(files.items()))


def to_json(coverage: Coverage) -> str:
    files = {}
    for file, kinds in _by_file(coverage).items():
        files[_relative(file)] = {
            "lines": [{"line": line, "hits": hits} for line, hits in kinds.lines],
            "branches": [{"line": line, "taken": taken, "not_taken": not_taken}
                         for line, taken, not_taken in kinds.branches],
            "conditions": [{"line": line, "column": column, "operand": operand,
                            "zero": zero, "one": one}
                           for line, column, operand, zero, one in kinds.conditions],
        }
    totals = {
        kind: {"covered": covered, "total": counted, "percent": round(percent(covered, counted), 2)}
        for kind, (covered, counted) in coverage.totals().items()
    }
    report = {"format": "asictl-coverage", "version": 1, "totals": totals, "files": files}
    return json.dumps(report, indent=2) + "\n"


def from_json(report: Mapping[str, Any]) -> Coverage:
    """The coverage a json report (``to_json``) holds, its files named as the report
    names them: what ``asictl report merge`` adds up over the shards of a run. The
    totals are left out: they follow from the rest. Raises KeyError, TypeError or
    ValueError for a document of another shape."""
    coverage = Coverage()
    for file, kinds in report["files"].items():
        for row in kinds["lines"]:
            coverage.lines[(str(file), int(row["line"]))] = int(row["hits"])
        for row in kinds["branches"]:
            coverage.branches[(str(file), int(row["line"]))] = [int(row["taken"]),
                                                                int(row["not_taken"])]
        for row in kinds["conditions"]:
            key = (str(file), int(row["line"]), int(row["column"]), str(row["operand"]))
            coverage.conditions[key] = [int(row["zero"]), int(row["one"])]
    return coverage


def to_lcov(coverage: Coverage) -> str:
    """The lcov tracefile: per file DA (line hits), BRDA (outcomes), LF/LH, BRF/BRH."""
    out = ["TN:"]
    for file, kinds in _by_file(coverage).items():
        out.append(f"SF:{_relative(file)}")
        hits = dict(kinds.lines)
        found = hit = 0
        for line, counts in sorted(kinds.outcomes().items()):
            ran = hits.get(line, 0) > 0
            for block, pair in enumerate(zip(counts[::2], counts[1::2], strict=True)):
                for branch, count in enumerate(pair):
                    # '-': the line never ran, so neither outcome could happen
                    out.append(f"BRDA:{line},{block},{branch},{count if ran else '-'}")
                    found += 1
                    hit += count > 0
        if found:
            out += [f"BRF:{found}", f"BRH:{hit}"]
        out += [f"DA:{line},{count}" for line, count in kinds.lines]
        out += [f"LF:{len(hits)}", f"LH:{sum(1 for c in hits.values() if c)}", "end_of_record"]
    return "\n".join(out) + "\n"


def _rate(covered: int, counted: int) -> str:
    return f"{covered / counted:.4g}" if counted else "1"


def to_cobertura(coverage: Coverage) -> str:
    """Cobertura XML as coverage.py writes it: a package per folder, a class per file."""
    files = _by_file(coverage)
    totals = coverage.totals()
    lines_hit, lines_all = totals["lines"]
    outcomes_hit = totals["branches"][0] + totals["conditions"][0]
    outcomes_all = totals["branches"][1] + totals["conditions"][1]
    root = ElementTree.Element("coverage", {
        "version": f"asictl {__version__}", "timestamp": str(int(time.time() * 1000)),
        "lines-valid": str(lines_all), "lines-covered": str(lines_hit),
        "line-rate": _rate(lines_hit, lines_all), "branches-valid": str(outcomes_all),
        "branches-covered": str(outcomes_hit), "branch-rate": _rate(outcomes_hit, outcomes_all),
        "complexity": "0",
    })
    sources = ElementTree.SubElement(root, "sources")
    ElementTree.SubElement(sources, "source").text = os.getcwd()
    packages = ElementTree.SubElement(root, "packages")
    by_folder: dict[str, list[str]] = defaultdict(list)
    for file in files:
        by_folder[PurePath(_relative(file)).parent.as_posix()].append(file)
    for folder, members in sorted(by_folder.items()):
        package = ElementTree.SubElement(packages, "package", {"name": folder, "complexity": "0"})
        classes = ElementTree.SubElement(package, "classes")
        package_counts = [0, 0, 0, 0]
        for file in members:
            kinds = files[file]
            counts = _class(classes, _relative(file), kinds)
            package_counts = [a + b for a, b in zip(package_counts, counts, strict=True)]
        package.set("line-rate", _rate(*package_counts[:2]))
        package.set("branch-rate", _rate(*package_counts[2:]))
    ElementTree.indent(root)
    return ElementTree.tostring(root, encoding="unicode", xml_declaration=True) + "\n"


def _class(classes: ElementTree.Element, name: str, kinds: _File) -> list[int]:
    """One file's class element; returns its lines hit and counted, outcomes hit and
    counted."""
    element = ElementTree.SubElement(classes, "class", {
        "name": PurePath(name).name, "filename": name, "complexity": "0",
    })
    ElementTree.SubElement(element, "methods")
    lines = ElementTree.SubElement(element, "lines")
    outcomes = kinds.outcomes()
    lines_hit = outcomes_hit = outcomes_all = 0
    for line, hits in kinds.lines:
        attributes = {"number": str(line), "hits": str(hits), "branch": "false"}
        lines_hit += bool(hits)
        counts = outcomes.get(line)
        if counts:
            covered = sum(1 for c in counts if c)
            share = covered * 100 // len(counts)
            attributes.update(branch="true",
                              **{"condition-coverage": f"{share}% ({covered}/{len(counts)})"})
            outcomes_hit += covered
            outcomes_all += len(counts)
        ElementTree.SubElement(lines, "line", attributes)
    element.set("line-rate", _rate(lines_hit, len(kinds.lines)))
    element.set("branch-rate", _rate(outcomes_hit, outcomes_all))
    return [lines_hit, len(kinds.lines), outcomes_hit, outcomes_all]


def to_sonarqube(coverage: Coverage) -> str:
    """SonarQube's generic coverage (``sonar.coverageReportPaths``): per line whether it
    ran, and its outcomes (branches and conditions) to cover and covered."""
    root = ElementTree.Element("coverage", version="1")
    for file, kinds in _by_file(coverage).items():
        element = ElementTree.SubElement(root, "file", path=_relative(file))
        outcomes = kinds.outcomes()
        for line, hits in kinds.lines:
            attributes = {"lineNumber": str(line), "covered": "true" if hits else "false"}
            counts = outcomes.get(line)
            if counts:
                attributes["branchesToCover"] = str(len(counts))
                attributes["coveredBranches"] = str(sum(1 for c in counts if c))
            ElementTree.SubElement(element, "lineToCover", attributes)
    ElementTree.indent(root)
    return ElementTree.tostring(root, encoding="unicode", xml_declaration=True) + "\n"


def render(coverage: Coverage, fmt: str) -> str:
    if fmt == "json":
        return to_json(coverage)
    if fmt == "lcov":
        return to_lcov(coverage)
    if fmt == "sonarqube":
        return to_sonarqube(coverage)
    return to_cobertura(coverage)
