"""``asictl report merge``: the reports of a run's shards put together as one run's.

A CI matrix runs ``test``, ``mutate`` or ``prove`` with ``--shard I/N`` in N jobs; each
writes its share of the report, and the merge gives what one run over all files would
have written: the same entries in the same order (by path), the counts and the score
worked out again from them. Each kind is read in the form that loses nothing: JUnit XML
(``test --junit``), asictl's json coverage (``test --coverage FILE.json``, from which
any coverage format can be written), ``mutate --format json`` and ``prove --format
json``. An entry in two inputs means the inputs are not shards of one split: refused.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path, PurePath
from typing import Any
from xml.etree import ElementTree

import click

from asictl.cli import junit
from asictl.cli.mutate import json_report, percent_killed
from asictl.cli.options import below_bar, coverage_fail_under_option, min_score_option
from asictl.errors import ExitCode, UserError
from asictl.files import write_output
from asictl.observe.coverage import Coverage
from asictl.sim.coverage import FORMATS, format_for, from_json, percent, render
from asictl.sim.coverage import summary as coverage_summary
from asictl.source import read_bounded

#: A report larger than this is no shard's report.
MAX_REPORT_BYTES = 256 * 1024 * 1024

#: What each kind is, for messages.
_KINDS = {
    "junit": "JUnit XML (test --junit)",
    "coverage": "json coverage (test --coverage FILE.json)",
    "mutation": "a mutation report (mutate --format json)",
    "proof": "a proof report (prove --format json)",
}


@click.group("report")
def report() -> None:
    """Reports of several runs as one: the shards of a CI matrix (docs/testing.md).

    \b
    Example:
      asictl test demos/blink.scenario.toml demos/jump.scenario.toml --shard 1/2 --junit j1.xml
      asictl test demos/blink.scenario.toml demos/jump.scenario.toml --shard 2/2 --junit j2.xml
      asictl report merge j1.xml j2.xml -o junit.xml
    """


@report.command("merge")
@click.argument("files", nargs=-1, required=True,
                type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              default="-", show_default=True, help="Where to write the merged report.")
@click.option("--coverage-format", type=click.Choice(FORMATS), default=None,
              help="Format of merged coverage (default: by the suffix of --output, as "
              "test --coverage; json on standard output).")
@coverage_fail_under_option
@min_score_option
def merge(files: tuple[Path, ...], output: Path, coverage_format: str | None,
          coverage_fail_under: float | None, min_score: float | None) -> None:
    """Merge FILES, the reports of the shards of one run (--shard I/N), into one.

    FILES are all of one kind: JUnit XML from 'test --junit', json coverage from 'test
    --coverage FILE.json' (written merged in any of test's coverage formats), 'mutate
    --format json' or 'prove --format json'. The result is what one run over every
    shard's files writes, entries in the order of their paths, counts and score worked
    out again; only times differ. Coverage must be json: Cobertura and lcov do not keep
    conditions apart from branches.

    Merged coverage prints test's summary line ('coverage: lines 93% (112/120), ...') on
    standard error; the bars --coverage-fail-under (coverage) and --min-score (mutants)
    belong here, where the whole run is seen, not on each shard.

    Exit status: 0 merged, 1 below --coverage-fail-under or --min-score (the report is
    written all the same), 2 a file is unreadable, of no kind asictl merges, of another
    kind than the first or than the bar given, or names an entry another file names too
    (not shards of one split).

    \b
    Example:
      asictl test demos/blink.scenario.toml demos/jump.scenario.toml --shard 1/2 --coverage c1.json
      asictl test demos/blink.scenario.toml demos/jump.scenario.toml --shard 2/2 --coverage c2.json
      asictl report merge c1.json c2.json -o coverage.xml --coverage-fail-under 80
    """
    for n, path in enumerate(files):
        if path in files[:n]:
            raise UserError(f"{path}: given twice")
    read = [(path, _read(path)) for path in files]
    kinds = {path: _kind(path, document) for path, document in read}
    first = kinds[files[0]]
    for path, kind in kinds.items():
        if kind != first:
            raise UserError(f"{path}: {_KINDS[kind]}, but {files[0]} is {_KINDS[first]}: "
                            "merge reports of one kind at a time")
    documents = [document for _, document in read]
    for bar, option, kind in ((coverage_fail_under, "--coverage-fail-under", "coverage"),
                              (min_score, "--min-score", "mutation")):
        if bar is not None and first != kind:
            raise click.UsageError(f"{option} is a bar for {_KINDS[kind]}; "
                                   f"{files[0]} is {_KINDS[first]}")
    below = False
    if first == "coverage":
        coverage = _coverage(files, documents)
        fmt = (coverage_format or "json" if str(output) == "-"
               else format_for(str(output), coverage_format))
        text = render(coverage, fmt)
        click.echo(coverage_summary(coverage), err=True)
        below = below_bar("line coverage", percent(*coverage.totals()["lines"]),
                          coverage_fail_under, "--coverage-fail-under", 2)
    elif first == "mutation":
        report = _mutation(files, documents)
        text = json.dumps(report, indent=2) + "\n"
        below = below_bar("mutation score", percent_killed(report["killed"], report["counted"]),
                          min_score, "--min-score", 1)
    elif first == "junit":
        text = _junit(files, documents)
    else:
        text = _proof(files, documents)
    write_output(output, text, inputs=files)
    click.get_current_context().exit(int(ExitCode.FAILED if below else ExitCode.OK))


def _read(path: Path) -> Any:
    """The report at ``path``: an XML root element or a JSON value."""
    raw = read_bounded(path, MAX_REPORT_BYTES, "a report")
    text = raw.decode("utf-8", errors="replace")
    if text.lstrip().startswith("<"):
        try:
            return ElementTree.fromstring(raw)
        except ElementTree.ParseError as exc:
            raise UserError(f"{path}: not well-formed XML: {exc}") from None
    try:
        return json.loads(text)
    except ValueError as exc:
        raise UserError(f"{path}: neither XML nor JSON: {exc}") from None
    except RecursionError:
        raise UserError(f"{path}: JSON nested too deeply for a report") from None


def _kind(path: Path, document: Any) -> str:
    if isinstance(document, ElementTree.Element):
        if document.tag == junit.SUITE:
            return "junit"
        if document.tag == "coverage":
            raise UserError(f"{path}: XML coverage cannot be merged exactly: write each "
                            "shard's coverage as json (test --coverage FILE.json)")
        raise UserError(f"{path}: <{document.tag}> is not a report asictl writes")
    if isinstance(document, dict):
        if document.get("format") == "asictl-coverage":
            return "coverage"
        if isinstance(document.get("mutants"), list):
            return "mutation"
        if isinstance(document.get("files"), list):
            return "proof"
    raise UserError(f"{path}: not a report asictl merges; it merges "
                    + ", ".join(_KINDS.values()))


def _once(entries: Sequence[tuple[Path, Any, tuple[str, ...]]]) -> list[Any]:
    """The entries (report file, entry, its name: paths) sorted by name; an entry two
    report files name is refused."""
    seen: dict[tuple[str, ...], Path] = {}
    for file, _, name in entries:
        other = seen.setdefault(name, file)
        if other != file:
            raise UserError(f"{' '.join(name)} is in both {other} and {file}: these are "
                            "not the shards of one split (same N, each I once)")
    return [entry for _, entry, _ in
            sorted(entries, key=lambda e: tuple(PurePath(part) for part in e[2]))]


def _shape(file: Path, what: str) -> UserError:
    return UserError(f"{file}: not {what} as asictl writes it")


def _junit(files: tuple[Path, ...], documents: list[ElementTree.Element]) -> str:
    cases = []
    for file, document in zip(files, documents, strict=True):
        for case in document.findall("testcase"):
            name = case.get("name")
            # a case holds at most a failure or error, text only (the suite is laid
            # out again, recursively)
            if name is None or any(len(child) for child in case):
                raise _shape(file, _KINDS["junit"])
            cases.append((file, case, (name,)))
    return junit.suite(_once(cases))


def _coverage(files: tuple[Path, ...], documents: list[dict[str, Any]]) -> Coverage:
    merged = Coverage()
    for file, document in zip(files, documents, strict=True):
        try:
            merged.merge(from_json(document))
        except (KeyError, TypeError, ValueError, AttributeError):
            raise _shape(file, _KINDS["coverage"]) from None
    return merged


def _mutation(files: tuple[Path, ...], documents: list[dict[str, Any]]) -> dict[str, Any]:
    mutants = []
    for file, document in zip(files, documents, strict=True):
        rows = document["mutants"]
        if not all(isinstance(r, dict) and isinstance(r.get("file"), str)
                   and isinstance(r.get("verdict"), str) for r in rows):
            raise _shape(file, _KINDS["mutation"])
        mutants += [(file, row) for row in rows]
    checked = all(d.get("equivalence_checked") is True for d in documents)
    return json_report(_by_file(mutants), checked)


def _by_file(mutants: list[tuple[Path, dict[str, Any]]]) -> list[dict[str, Any]]:
    """The mutants of each program kept together in their order, the programs in the
    order of their paths; a program in two reports is refused."""
    groups: dict[tuple[Path, str], list[dict[str, Any]]] = {}
    for report_file, row in mutants:
        groups.setdefault((report_file, row["file"]), []).append(row)
    ordered = _once([(report_file, rows, (name,))
                     for (report_file, name), rows in groups.items()])
    return [row for rows in ordered for row in rows]


def _proof(files: tuple[Path, ...], documents: list[dict[str, Any]]) -> str:
    reports = []
    for file, document in zip(files, documents, strict=True):
        for entry in document["files"]:
            if not isinstance(entry, dict) or not isinstance(entry.get("properties"), str):
                raise _shape(file, _KINDS["proof"])
            reports.append((file, entry, (entry["properties"], str(entry.get("program")))))
    return json.dumps({"files": _once(reports)}, indent=2) + "\n"

