"""A pytest plugin: every ``*.scenario.toml`` is a test (docs/simulation.md).

Installed with asictl (the ``pytest11`` entry point ``asictl``), so ``pytest DIR``
collects the scenarios under DIR next to any Python tests, with pytest's selection
(``-k``), markers (a scenario's ``markers = ["slow"]``), reports and plug-ins such as
pytest-xdist (``-n auto``). A failed scenario shows its lines as ``asictl test`` does:
``blink.scenario.toml:8: at 250 ms: Q 31.0 expected 1, got 0``.

``--asictl-coverage FILE`` writes the IL coverage of the scenarios run (the format by
the suffix or ``--asictl-coverage-format``, as ``asictl test --coverage``) and prints its
one-line summary at the end; with pytest-xdist each worker sends its scenarios'
coverage to the controller with their reports.

Turning it off: ``-p no:asictl`` for one run, ``asictl_scenarios = false`` in the ini
file for a project, or ``collect_ignore_glob`` in a conftest.py for some folders.

The fixture ``asictl_plc`` is a factory of ``asictl.testing.Plc`` (docs/testing.md):
``asictl_plc("prog.asi", cycle_ms=5)``, each one closed after the test.
"""

from __future__ import annotations

from collections.abc import Callable, Generator, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from asictl.diagnostics import DiagnosticError
from asictl.readers.tomlfile import read_toml
from asictl.sim import SUFFIX

if TYPE_CHECKING:
    from asictl.sim.session import Outcome
    from asictl.testing import Plc


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addini("asictl_scenarios", type="bool", default=True,
                  help="collect *.scenario.toml files as tests (asictl)")
    parser.addini("asictl_lib", type="paths", default=[],
                  help="folders where asictl looks for function-block files")
    group = parser.getgroup("asictl", "asictl scenarios")
    group.addoption("--asictl-coverage", metavar="FILE", default=None,
                    help="write the IL coverage of the scenarios run to FILE")
    group.addoption("--asictl-coverage-format", choices=("cobertura", "lcov", "json", "sonarqube"),
                    default=None, help="format of --asictl-coverage (default: by its "
                    "suffix, .json json, .info or .lcov lcov, else cobertura)")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", 'slow: a scenario marked slow (markers = ["slow"])')
    if config.getoption("asictl_coverage", None):
        config.pluginmanager.register(CoverageReport(config), "asictl-coverage")


class CoverageReport:
    """Adds up the coverage the scenarios' reports carry; writes it at the end (on the
    controller only, when pytest-xdist runs workers)."""

    def __init__(self, config: pytest.Config) -> None:
        self.config = config
        self.parts: list[dict[str, Any]] = []

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        data = getattr(report, "asictl_coverage", None)
        if report.when == "call" and data:
            self.parts.append(data)

    def pytest_terminal_summary(self, terminalreporter: Any) -> None:
        if hasattr(self.config, "workerinput"):
            return
        from asictl.observe.coverage import Coverage
        from asictl.sim.coverage import format_for, render, summary

        coverage = Coverage()
        for part in self.parts:
            coverage.merge(Coverage.from_data(part))
        path = str(self.config.getoption("asictl_coverage"))
        text = render(coverage, format_for(path, self.config.getoption("asictl_coverage_format")))
        from asictl.files import write_output

        write_output(Path(path), text, inputs=coverage.files_read())
        terminalreporter.write_line(summary(coverage))
        terminalreporter.write_line(f"asictl coverage written to {path}")


def pytest_collect_file(file_path: Path, parent: pytest.Collector) -> ScenarioFile | None:
    if file_path.name.endswith(SUFFIX) and parent.config.getini("asictl_scenarios"):
        return ScenarioFile.from_parent(parent, path=file_path)
    return None


class ScenarioFailed(Exception):
    """A scenario that failed or could not run; carries its outcome."""

    def __init__(self, outcome: Outcome) -> None:
        super().__init__(outcome.message or outcome.summary)
        self.outcome = outcome


class ScenarioFile(pytest.File):
    def collect(self) -> Iterator[ScenarioItem]:
        item = ScenarioItem.from_parent(self, name=self.path.name[: -len(SUFFIX)])
        for marker in _markers(self.path):
            item.add_marker(marker)
        yield item


def _markers(path: Path) -> list[str]:
    """The scenario's ``markers``, read without simulating (a broken file has none here;
    running it reports what is wrong)."""
    try:
        markers = read_toml(str(path), path.read_text(encoding="utf-8")).data.get("markers", [])
    except (OSError, ValueError, DiagnosticError):
        return []
    return [m for m in markers if isinstance(m, str) and m.isidentifier()] \
        if isinstance(markers, list) else []


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(
    item: pytest.Item, call: pytest.CallInfo[None]
) -> Generator[None, pytest.TestReport, pytest.TestReport]:
    """The scenario's coverage rides on its report (pytest-xdist sends it along)."""
    report = yield
    data = getattr(item, "asictl_coverage", None)
    if data is not None and call.when == "call":
        setattr(report, "asictl_coverage", data)  # noqa: B010 - an attribute of ours
    return report


class ScenarioItem(pytest.Item):
    #: the scenario's coverage as ``Coverage.to_data`` gives it (with --asictl-coverage)
    asictl_coverage: dict[str, Any] | None = None

    def runtest(self) -> None:
        lib = tuple(str(p) for p in self.config.getini("asictl_lib"))
        from asictl.sim.session import run_file  # the simulation loads only to run one

        collect = bool(self.config.getoption("asictl_coverage", None))
        outcome = run_file(str(self.path), lib, collect)
        if outcome.coverage is not None:
            self.asictl_coverage = outcome.coverage.to_data()
        if outcome.status != "PASS":
            raise ScenarioFailed(outcome)

    def repr_failure(self, excinfo: pytest.ExceptionInfo[BaseException],
                     style: Any = None) -> str:
        if isinstance(excinfo.value, ScenarioFailed):
            outcome = excinfo.value.outcome
            if outcome.status == "ERROR":
                return "\n".join(filter(None, [outcome.stderr.rstrip(), outcome.message]))
            return "\n".join([*outcome.events, outcome.summary])
        return str(super().repr_failure(excinfo))

    def reportinfo(self) -> tuple[Path, int | None, str]:
        return self.path, None, f"scenario {self.path.name}"


@pytest.fixture
def asictl_plc(request: pytest.FixtureRequest) -> Iterator[Callable[..., Plc]]:
    """``asictl_plc(path, cycle_ms=5, slaves=None, symbols=None)``: ``Plc.load`` with
    the ini file's ``asictl_lib``; a relative path is found beside the test file first,
    then from the current directory. Every ``Plc`` made is closed after the test."""
    from asictl.testing import Plc  # the simulation loads only for a test that asks

    lib = tuple(str(p) for p in request.config.getini("asictl_lib"))
    made: list[Plc] = []

    def make(path: str | Path, **options: Any) -> Plc:
        where = Path(path)
        beside = request.path.parent / where
        if not where.is_absolute() and beside.exists():
            where = beside
        options.setdefault("lib", lib)
        plc = Plc.load(where, **options)
        made.append(plc)
        return plc

    yield make
    for plc in made:
        plc.close()
