"""Time the language server as an editor meets it: ``asictl lsp`` in a process of its own,
spoken to over stdio by the test suite's client (tests/lsp/lsp_client.py).

- diagnostics: from didOpen of a document of 100 KB and of 1 MB (statements with
  comments, one operand out of range in every ten lines) to its publishDiagnostics;
- a hover on a small file sent half a second after a 1 MB document changed, while that
  is checked, then one on the changed document (which waits for its new analysis);
- 300 open documents: from the first didOpen to the last one's diagnostics, then a hover
  on one right after a change to another;
- a line of 400,000 characters: hover at its start and at its end, completion at its end.

Each figure is the wall time the client waits and, for the diagnostics, the CPU time
(user + system) the server spent meanwhile, which hardly depends on what else the
machine runs. ``--src`` runs another checkout's server (``--src /path/to/old/src``) to
compare versions. Usage:

    python3 benchmarks/bench_lsp.py [--src SRC] [--sizes 100 1024] [--skip-big]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "tests" / "lsp")]

import lsp_client  # noqa: E402 - after the path is set
from bench_check import cpu_seconds  # noqa: E402
from lsp_client import LspClient  # noqa: E402

SMALL = "[SETUP]\n1: iiii, 0\n2: oooo, 0\n[PROGRAM]\n A I 1.0\n = Q 2.1\n"


def program(size: int) -> str:
    """About ``size`` characters; every tenth line an operand out of range."""
    line = " A I 1.0            ; a comment that makes the line longer"
    body = [line if n % 10 else " L KB 999" for n in range(size // (len(line) + 1))]
    return "\n".join(["[SETUP]", "1: iiii, 0", "[PROGRAM]", *body, " BE", ""])


def started(folder: Path) -> LspClient:
    client = LspClient(folder)
    client.request("initialize", {"processId": None, "capabilities": {}})
    client.notify("initialized")
    return client


def open_doc(client: LspClient, uri: str, text: str) -> None:
    client.notify("textDocument/didOpen", {"textDocument": {
        "uri": uri, "languageId": "asi", "version": 1, "text": text}})


def hover(client: LspClient, uri: str, line: int, character: int) -> float:
    start = time.perf_counter()
    client.request("textDocument/hover", {"textDocument": {"uri": uri},
                                          "position": {"line": line, "character": character}})
    return time.perf_counter() - start


def diagnostics(folder: Path, size: int) -> tuple[float, float, int]:
    client = started(folder)
    try:
        uri = (folder / f"d{size}.asi").as_uri()
        before, start = cpu_seconds(client.process.pid), time.perf_counter()
        open_doc(client, uri, program(size))
        found = client.diagnostics(uri, until=bool)
        return time.perf_counter() - start, cpu_seconds(client.process.pid) - before, len(found)
    finally:
        client.close()


def hover_while_checking(folder: Path) -> tuple[float, float]:
    client = started(folder)
    try:
        small, big = (folder / "small.asi").as_uri(), (folder / "big.asi").as_uri()
        open_doc(client, small, SMALL)
        open_doc(client, big, SMALL)
        client.diagnostics(big)
        client.notify("textDocument/didChange", {
            "textDocument": {"uri": big, "version": 2},
            "contentChanges": [{"text": program(1 << 20)}]})
        time.sleep(0.5)
        return hover(client, small, 4, 3), hover(client, big, 4, 3)
    finally:
        client.close()


def many_documents(folder: Path, count: int) -> tuple[float, float]:
    client = started(folder)
    try:
        uris = [(folder / f"p{n}.asi").as_uri() for n in range(count)]
        start = time.perf_counter()
        for n, uri in enumerate(uris):
            open_doc(client, uri, SMALL.replace("Q 2.1", f"Q 2.{n % 4}"))
        client.diagnostics(uris[-1])
        opened = time.perf_counter() - start
        client.notify("textDocument/didChange", {
            "textDocument": {"uri": uris[0], "version": 2},
            "contentChanges": [{"text": SMALL.replace("I 1.0", "I 1.1")}]})
        return opened, hover(client, uris[count // 2], 4, 3)
    finally:
        client.close()


def long_line(folder: Path, length: int) -> dict[str, float]:
    client = started(folder)
    try:
        uri = (folder / "long.asi").as_uri()
        line = " A I 1.0 ; " + "x" * length
        open_doc(client, uri, f"[SETUP]\n1: iiii, 0\n[PROGRAM]\n{line}\n")
        client.diagnostics(uri)
        times = {"hover at its start": hover(client, uri, 3, 4),
                 "hover at its end": hover(client, uri, 3, len(line))}
        start = time.perf_counter()
        client.request("textDocument/completion", {
            "textDocument": {"uri": uri}, "position": {"line": 3, "character": len(line)}})
        times["completion at its end"] = time.perf_counter() - start
        return times
    finally:
        client.close()


def report(name: str, value: str) -> None:
    print(f"{name}: {value}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--src", type=Path, default=ROOT / "src",
                        help="the asictl sources whose server is run")
    parser.add_argument("--sizes", type=int, nargs="*", default=[100, 1024],
                        help="document sizes in KB")
    parser.add_argument("--skip-big", action="store_true",
                        help="leave out the hover during a 1 MB check")
    args = parser.parse_args()
    lsp_client.SRC = args.src.resolve()
    lsp_client.TIMEOUT = 600.0
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for size in args.sizes:
            wall, used, count = diagnostics(folder, size * 1024)
            report(f"diagnostics, {size} KB ({count} of them)",
                   f"{wall:.2f} s (server CPU {used:.2f} s)")
        if not args.skip_big:
            beside, inside = hover_while_checking(folder)
            report("hover on a small file while 1 MB is checked", f"{beside:.3f} s")
            report("then a hover on the 1 MB file (its new text analysed)", f"{inside:.2f} s")
        opened, waited = many_documents(folder, 300)
        report("300 documents opened, all diagnostics", f"{opened:.2f} s")
        report("then a hover right after a change", f"{waited:.3f} s")
        for name, value in long_line(folder, 400_000).items():
            report(f"line of 400,000 characters, {name}", f"{value:.3f} s")


if __name__ == "__main__":
    main()
