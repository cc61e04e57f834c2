"""``serve --opcua`` and ``gateway serve --opcua`` against asyncua's own client: browsing,
reading a flag the program sets, subscriptions, refused and accepted writes, logins, and
a client that sends garbage."""

from __future__ import annotations

import asyncio
import json
import os
import re
import socket
import subprocess
import sys
from contextlib import AbstractContextManager
from pathlib import Path

import pytest
from asyncua import Client, ua
from asyncua.common.node import Node
from asyncua.common.subscription import DataChangeNotif
from click.testing import CliRunner
from served_live import served_live

from asictl.cli import main

PROGRAM = """\
[SETUP]
1: iiii, 0

[PROGRAM]
        L   KB 42
        T   FY 12
***
        A   T 0             ; timer 0 running?
        JC  = end
        N
        L   KT 500
        S   T 0
end:    BE
"""
NAMESPACE = "urn:asictl:board"


def asictl(state: Path, *args: str, code: int = 0) -> subprocess.CompletedProcess[str]:
    result = subprocess.run(
        [sys.executable, "-m", "asictl", *args], capture_output=True, text=True, timeout=60,
        env={**os.environ, "ASICTL_STATE_DIR": str(state)},
    )
    assert result.returncode == code, (args, result.stdout, result.stderr)
    return result


def served(
    state: Path, *command: str, env: dict[str, str] | None = None,
) -> AbstractContextManager[str]:
    """``asictl COMMAND... --opcua 127.0.0.1:0`` in its own process; yields the URL."""
    return served_live(
        state, [*command, "--opcua", "127.0.0.1:0"],
        r"OPC UA server for board 300h at (opc\.tcp://\S+)", env=env,
        also="serving" if command[0] == "gateway" else None,
    )


@pytest.fixture
def state(tmp_path: Path) -> Path:
    tmp_path.chmod(0o700)
    (tmp_path / "flag.asi").write_text(PROGRAM)
    asictl(tmp_path, "download", str(tmp_path / "flag.asi"), "--start")
    return tmp_path


def node(client: Client, ns: int, name: str) -> Node:
    return client.get_node(ua.NodeId(name, ns))


def test_a_client_browses_reads_the_flag_subscribes_and_may_not_write(state: Path):
    async def session(url: str) -> None:
        async with Client(url) as client:
            ns = await client.get_namespace_index(NAMESPACE)
            names = {(await child.read_browse_name()).Name
                     for child in await client.nodes.objects.get_children()}
            assert {"Master", "Slaves", "Flags", "Timers", "Counters"} <= names
            assert await node(client, ns, "FY 12").read_value() == 42
            assert [await node(client, ns, f"F 12.{b}").read_value() for b in range(8)] == [
                bool(42 >> b & 1) for b in range(8)
            ]
            assert await node(client, ns, "Master.ControlState").read_value() == "running"
            assert await node(client, ns, "Master.Phase").read_value() == "normal operation"
            assert await node(client, ns, "Slave.1.Lists").read_value() == ["LPS", "LDS", "LAS"]
            assert await node(client, ns, "Slave.1.IoCode").read_value() == 0
            assert await node(client, ns, "T 0.Running").read_value() is True
            assert 0 <= await node(client, ns, "T 0").read_value() <= 500
            assert await node(client, ns, "Symbol.answer").read_value() == 42

            heard: list[int] = []
            changed = asyncio.Event()

            class Handler:
                def datachange_notification(self, _node: object, value: int,
                                            _data: DataChangeNotif) -> None:
                    heard.append(value)
                    if value == 7:
                        changed.set()

            subscription = await client.create_subscription(50, Handler())
            await subscription.subscribe_data_change(node(client, ns, "FY 13"))
            await asyncio.get_running_loop().run_in_executor(
                None, lambda: asictl(state, "write", "FY 13=7"))
            await asyncio.wait_for(changed.wait(), 20)
            assert heard[0] == 0 and heard[-1] == 7

            with pytest.raises(ua.UaStatusCodeError) as refused:
                await node(client, ns, "FY 14").write_value(ua.Variant(5, ua.VariantType.Byte))
            assert refused.value.code == ua.StatusCodes.BadUserAccessDenied
            master = node(client, ns, "Master")
            methods = [(await m.read_browse_name()).Name for m in await master.get_methods()]
            assert methods == []

    (state / "flag.symbols.toml").write_text('answer = "FY 12"\n')
    with served(state, "serve", "--opcua-symbols", str(state / "flag.symbols.toml")) as url:
        asyncio.run(session(url))
        port = int(re.search(r":(\d+)/", url).group(1))  # type: ignore[union-attr]
        for garbage in (os.urandom(4096), b"HELF\xff\xff\xff\x7f" + bytes(64), b"\x00" * 3):
            with socket.create_connection(("127.0.0.1", port), timeout=5) as hostile:
                hostile.sendall(garbage)

        async def still_there() -> None:
            async with Client(url) as client:
                ns = await client.get_namespace_index(NAMESPACE)
                assert await node(client, ns, "FY 12").read_value() == 42

        asyncio.run(still_there())
    assert json.loads(asictl(state, "status", "--json").stdout)["flags"][14] == 0


def test_gateway_serve_writable_with_a_login(state: Path):
    async def session(url: str) -> None:
        with pytest.raises(ua.UaStatusCodeError):  # anonymous: refused
            async with Client(url) as client:
                pass
        client = Client(url)
        client.set_user("hmi")
        client.set_password("secret")
        async with client:
            ns = await client.get_namespace_index(NAMESPACE)
            assert await node(client, ns, "FY 12").read_value() == 42
            assert await node(client, ns, "Symbol.answer").read_value() == 42  # the board's
            await node(client, ns, "FY 13").write_value(ua.Variant(0x5A, ua.VariantType.Byte))
            await node(client, ns, "F 14.3").write_value(ua.Variant(True, ua.VariantType.Boolean))
            await node(client, ns, "Slave.1.Inputs").write_value(
                ua.Variant(0b1010, ua.VariantType.Byte))
            with pytest.raises(ua.UaStatusCodeError) as refused:  # no slave 2 on the cable
                await node(client, ns, "Slave.2.Inputs").write_value(
                    ua.Variant(1, ua.VariantType.Byte))
            assert refused.value.code == ua.StatusCodes.BadNotWritable
            with pytest.raises(ua.UaStatusCodeError) as refused:
                await node(client, ns, "FY 13").write_value(ua.Variant(1, ua.VariantType.Int32))
            assert refused.value.code == ua.StatusCodes.BadTypeMismatch
            await node(client, ns, "Master").call_method(ua.NodeId("Master.Stop", ns))

    # the symbol table beside the program goes onto the board with it, and from there
    # into the address space without --opcua-symbols
    (state / "flag.symbols.toml").write_text('answer = "FY 12"\n')
    asictl(state, "download", str(state / "flag.asi"), "--start")
    env = {"ASICTL_OPCUA_PASSWORD": "secret"}
    with served(state, "gateway", "serve", "--tcp", "127.0.0.1:0", "--opcua-writable",
                "--opcua-user", "hmi", env=env) as url:
        asyncio.run(session(url))
        status = json.loads(asictl(state, "status", "--json").stdout)
        assert status["flags"][13:15] == [0x5A, 0x08]
        assert status["start_flag"] is False and status["control_state"] != "running"
        assert status["slaves"]["1"]["inputs"] == 0b1010


def test_refusals_before_serving(tmp_path: Path):
    runner = CliRunner()
    cases = [
        (["serve", "--opcua", "0.0.0.0:4840"], "anonymous OPC UA clients are served on a "
         "loopback address only"),
        (["serve", "--opcua-writable"], "--opcua-writable without --opcua HOST:PORT"),
        (["serve", "--opcua", "127.0.0.1:4840", "--opcua-user", "hmi"],
         "--opcua-user hmi: set its password in $ASICTL_OPCUA_PASSWORD"),
        (["gateway", "serve", "--opcua", "4840"], "--opcua '4840': expected HOST:PORT"),
    ]
    for args, message in cases:
        result = runner.invoke(main, [*args, "--state-dir", str(tmp_path)],
                               env={"ASICTL_OPCUA_PASSWORD": ""})
        assert result.exit_code == 2, (args, result.output)
        assert message in result.stderr, (args, result.stderr)


def test_without_the_extra_the_hint_names_what_to_install(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setitem(sys.modules, "asictl.opcua.server", None)  # as if asyncua were absent
    result = CliRunner().invoke(main, ["serve", "--opcua", "127.0.0.1:4840", "--state-dir",
                                       str(tmp_path)])
    assert result.exit_code == 2
    assert "--opcua needs the 'opcua' extra" in result.stderr
    assert "pip install 'asyncua>=2.1,<3'" in result.stderr
