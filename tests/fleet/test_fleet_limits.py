"""A master's time limit bounds its whole work: a gateway that drips each answer byte by
byte, every byte within the time-out, fails within its own limit while the others go on."""

from __future__ import annotations

import asyncio
import json
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from click.testing import CliRunner
from served_gateway import serve_gateways

from asictl.cli import main

ROOT = Path(__file__).resolve().parents[2]
BLINK = ROOT / "demos" / "blink.asi"
DRIP_S = 0.02  # between two bytes of an answer: well within any time-out


async def _pipe(reader: asyncio.StreamReader, writer: asyncio.StreamWriter, drip: bool) -> None:
    while data := await reader.read(4096):
        for byte in (data[i:i + 1] for i in range(len(data))) if drip else [data]:
            writer.write(byte)
            await writer.drain()
            if drip:
                await asyncio.sleep(DRIP_S)
    writer.close()


@contextmanager
def dripping(port: int) -> Iterator[int]:
    """A proxy on 127.0.0.1 in front of the gateway at ``port``: requests go through at
    once, answers come back a byte at a time."""
    loop = asyncio.new_event_loop()
    ready: list[int] = []
    started = threading.Event()

    async def connection(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        up_reader, up_writer = await asyncio.open_connection("127.0.0.1", port)
        await asyncio.gather(_pipe(reader, up_writer, False), _pipe(up_reader, writer, True),
                             return_exceptions=True)

    async def serve() -> asyncio.Server:
        server = await asyncio.start_server(connection, "127.0.0.1", 0)
        ready.append(server.sockets[0].getsockname()[1])
        started.set()
        return server

    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    server = asyncio.run_coroutine_threadsafe(serve(), loop).result(10)
    started.wait(10)
    try:
        yield ready[0]
    finally:
        loop.call_soon_threadsafe(server.close)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(10)


def test_a_dripping_gateway_fails_within_its_own_limit(tmp_path: Path):
    state = tmp_path / "gateway-board"
    state.mkdir(mode=0o700)
    runner = CliRunner()
    for where in (state, tmp_path / "boards"):
        where.mkdir(mode=0o700, exist_ok=True)
        done = runner.invoke(main, ["download", str(BLINK), "--start", "--state-dir", str(where)])
        assert done.exit_code == 0, done.output
    with serve_gateways([state]) as ports, dripping(ports[0]) as slow:
        inventory = tmp_path / "plant.toml"
        inventory.write_text(
            f'[masters.slow]\nmodbus = "tcp://127.0.0.1:{slow}"\ntimeout = "1s"\n'
            'limit = "2s"\n\n'
            '[masters.pc-1]\nport = "300h"\nstate_dir = "boards"\n'
        )
        result = runner.invoke(main, ["fleet", "backup", str(inventory), "--into",
                                      str(tmp_path / "archive"), "--format", "json"])
    assert result.exit_code == 1, result.output
    report = json.loads(result.stdout)
    slow_row, board_row = report["masters"]
    assert slow_row["result"] == "FAILED" and board_row["result"] == "changed"
    assert slow_row["error"].startswith("not done within its limit of 2 s ("), slow_row
    assert "time limit" in slow_row["error"] or "no valid answer" in slow_row["error"]
    assert 2.0 <= slow_row["seconds"] < 5.0, slow_row  # its limit, and a loaded machine


def test_the_limit_is_a_time_with_its_unit_from_one_second_to_an_hour(tmp_path: Path):
    inventory = tmp_path / "plant.toml"
    for value, message in (('"2h"', "longer than the longest allowed"),
                           ('"500ms"', 'a time from 1s to 1h, such as "30s"'),
                           ("30", 'give a unit: "30s" or "30ms"')):
        inventory.write_text(f'[masters.pc-1]\nport = "300h"\nlimit = {value}\n')
        result = CliRunner().invoke(main, ["fleet", "status", str(inventory)])
        assert result.exit_code == 2 and "error: limit: " in result.stderr, result.output
        assert message in result.stderr and "limit = " in result.stderr
