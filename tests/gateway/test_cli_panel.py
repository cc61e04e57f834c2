"""The front panel of a gateway served by ``asictl gateway serve``, driven as a user does:
``gateway press`` and ``gateway panel`` in processes of their own, ``status --json`` for
what the master did, a Modbus client for the key lock (register 1007)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from pymodbus.client import ModbusTcpClient
from pymodbus.exceptions import ModbusIOException
from served_gateway import serve_gateway

from asictl.platform.display import SELF_TEST


class Served:
    def __init__(self, state: Path, modbus_port: int) -> None:
        self.state = state
        self.modbus_port = modbus_port
        self.env = {**os.environ, "ASICTL_STATE_DIR": str(state)}

    def run(self, *args: str, code: int = 0) -> subprocess.CompletedProcess[str]:
        result = subprocess.run(
            [sys.executable, "-m", "asictl", *args], capture_output=True, text=True,
            env=self.env, timeout=60,
        )
        assert result.returncode == code, (args, result.stdout, result.stderr)
        return result

    def status(self) -> dict:
        return json.loads(self.run("status", "--json").stdout)

    def remote_status(self, host: str = "127.0.0.1") -> dict:
        """``status --json`` through the gateway's Modbus TCP, as a client elsewhere."""
        return json.loads(self.run(
            "status", "--modbus", f"tcp://{host}:{self.modbus_port}", "--json"
        ).stdout)

    def press(self, *args: str) -> dict:
        return json.loads(self.run("gateway", "press", *args, "--json").stdout)


def panel_now(served: Served) -> dict:
    return json.loads(served.run("gateway", "panel", "--json").stdout)


@pytest.fixture
def served(tmp_path: Path) -> Iterator[Served]:
    """A served gateway past its power-up display test (88 for the first second of
    master time, which follows the wall clock here): a one-shot command is quick enough
    to land inside it."""
    with serve_gateway(tmp_path) as (port, _):
        gateway = Served(tmp_path, port)
        deadline = time.monotonic() + 30
        while panel_now(gateway)["display"]["code"] == SELF_TEST:
            assert time.monotonic() < deadline, "the display test never ended"
            time.sleep(0.1)
        yield gateway


def test_mode_held_6_s_configures_a_short_press_protects_and_the_lock_stops_both(served):
    served.run("bus", "plug", "5", "iiio,1")
    served.run("gateway", "press", "mode")  # delivered in configuration mode: leave it
    status = served.status()
    assert status["mode"] == "protected" and status["lps"] == []
    assert status["panel"] == "gateway" and status["leds"]["prj_mode"] is False

    panel = served.press("mode", "--hold", "6s")
    assert panel["leds"]["prj_mode"] is True
    status = served.status()
    assert status["mode"] == "configuration" and status["leds"]["prj_mode"] is True
    assert status["display"]["code"] == 5  # the detected slave, as configuration mode shows

    served.run("gateway", "press", "mode")
    status = served.status()
    assert status["mode"] == "protected"
    assert status["lps"] == [], "a short press does not store the configuration"
    assert status["display"] == {
        "code": 5, "text": "  05", "blinking": False,
        "meaning": "slave 5 is wrongly configured (found first)",
    }

    client = ModbusTcpClient("127.0.0.1", port=served.modbus_port, timeout=2, retries=0)
    assert client.connect()
    assert not client.write_register(1007, 1, device_id=1).isError()
    client.close()
    panel = served.press("mode", "--hold", "6s")
    assert panel["display"]["code"] == 82 and panel["keys_locked"] is True
    status = served.status()
    assert status["mode"] == "protected" and status["display"]["code"] == 82
    assert status["keys_locked"] is True and status["lps"] == []
    text = served.run("status").stdout
    assert "display  82 (the keys are locked" in text
    assert "keys     locked (Modbus register 1007)" in text
    remote = served.remote_status()
    assert remote["panel"] == "gateway" and remote["keys_locked"] is True
    assert remote["leds"]["ser_active"] is True, "the client itself talks to the gateway"
    assert remote["leds"]["prj_mode"] is False
    assert remote["display"] == panel_now(served)["display"]
    assert remote["display"]["code"] == 82, "the panel's display, not one worked out"


def test_a_slave_0_when_leaving_configuration_mode_by_key_gives_80(served):
    served.run("bus", "plug", "0", "iiio,1")
    panel = served.press("mode")
    assert panel["display"]["code"] == 80
    status = served.status()
    assert status["mode"] == "configuration" and status["display"]["code"] == 80
    assert "there is a slave with address 0" in status["display"]["meaning"]
    # before any Modbus telegram: config err is lit while no Modbus communication is
    # (and ser active for a while after one)
    text = served.run("gateway", "panel").stdout
    assert text.startswith("display  80 (error leaving configuration mode")
    assert "leds     power, config err, U AS-i, AS-i active, prj mode on" in text
    remote = served.remote_status("localhost")
    assert remote["panel"] == "gateway" and remote["display"]["code"] == 80
    assert remote["display"] == panel_now(served)["display"]


def test_the_panel_needs_a_gateway(tmp_path: Path):
    env = {**os.environ, "ASICTL_STATE_DIR": str(tmp_path)}
    result = subprocess.run(
        [sys.executable, "-m", "asictl", "gateway", "press", "set"], capture_output=True,
        text=True, env=env, timeout=60,
    )
    assert result.returncode == 1
    assert "no gateway serves board 300h: start one with 'asictl gateway serve" in (
        result.stderr
    )
    result = subprocess.run(
        [sys.executable, "-m", "asictl", "gateway", "press"], capture_output=True,
        text=True, env=env, timeout=60,
    )
    assert result.returncode == 2 and "which key?" in result.stderr


def test_the_first_commissioning_of_the_manuals_appendix(served):
    """Chapter 9 (lines 1403-1417): a slave with address 0 on the cable, set until "1",
    set held until it blinks, set again; then mode held 5 s stores it all."""
    served.run("bus", "plug", "0", "oooi,2")
    assert served.run("gateway", "panel", "--json").stdout.count('"code": 0') == 1
    panel = served.press("set")
    assert panel["display"]["code"] == 1 and not panel["display"]["blinking"]
    panel = served.press("set", "--hold", "6s")
    assert panel["display"] == {
        "code": 1, "text": "  01", "blinking": True,
        "meaning": "target address 1: set programs the slave with address 0 to it",
    }
    served.press("set")
    cable = json.loads(served.run("bus", "--json").stdout)
    assert [s["address"] for s in cable["slaves"]] == [1]
    served.press("mode", "--hold", "6s")
    status = served.status()
    assert status["mode"] == "protected" and status["lps"] == [1] and status["config_ok"]
    assert status["display"]["code"] is None  # protected mode without errors: blank
    leds = status["leds"]
    assert leds["config_err"] and not leds["ser_active"], "no Modbus traffic lights it (143)"


def test_a_board_served_without_the_gateway_has_no_panel(tmp_path: Path):
    env = {**os.environ, "ASICTL_STATE_DIR": str(tmp_path)}
    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", "serve"], stderr=subprocess.PIPE, text=True, env=env,
    )
    try:
        assert "live at" in process.stderr.readline()
        result = subprocess.run(
            [sys.executable, "-m", "asictl", "gateway", "panel"], capture_output=True,
            text=True, env=env, timeout=60,
        )
        assert result.returncode == 1
        assert "is served by asictl serve (pid" in result.stderr
        assert "which has no front panel" in result.stderr
    finally:
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=20) == 0


def test_both_keys_give_the_gateway_another_modbus_address_it_keeps(served):
    """5.6: both keys 5 s, set counts the address up, mode stores it; then the serial
    setting. The gateway answers to the new address at once, and after a restart."""
    panel = served.press("--both", "--hold", "6s")
    assert panel["menu"] == "address" and panel["display"]["code"] == 1
    assert not panel["leds"]["asi_active"], "the AS-i circuit is offline meanwhile"
    served.press("set")
    assert served.press("mode")["display"]["code"] == 40  # 9600 baud, no parity, 1 stop bit
    served.press("set")
    panel = served.press("mode")
    assert panel["menu"] is None and panel["unit"] == 2
    assert panel["serial"] == "9600 baud, odd parity, 1 stop bit"
    client = ModbusTcpClient("127.0.0.1", port=served.modbus_port, timeout=1, retries=0)
    assert client.connect()
    assert not client.read_holding_registers(1007, count=1, device_id=2).isError()
    with pytest.raises(ModbusIOException):  # unit 1 is nobody now: no answer
        client.read_holding_registers(1007, count=1, device_id=1)
    client.close()
    stored = json.loads((served.state / "gateway-300h.json").read_text())
    assert stored == {"unit": 2, "baud": 9600, "parity": "O", "stopbits": 1}


def test_a_restarted_gateway_keeps_what_its_keys_stored(tmp_path: Path):
    (tmp_path / "gateway-300h.json").write_text(
        '{"unit": 7, "baud": 19200, "parity": "E", "stopbits": 1}'
    )
    with serve_gateway(tmp_path) as (port, lines):
        assert "Modbus address 7, 19200 baud E1 as its keys stored them" in lines[0]
        assert "gateway unit 7 for board 300h" in lines[-1]
        client = ModbusTcpClient("127.0.0.1", port=port, timeout=1, retries=0)
        assert client.connect()
        assert not client.read_holding_registers(1007, count=1, device_id=7).isError()
        client.close()
    env = {**os.environ, "ASICTL_STATE_DIR": str(tmp_path)}
    (tmp_path / "gateway-300h.json").write_text("{broken")
    result = subprocess.run(
        [sys.executable, "-m", "asictl", "gateway", "serve"], capture_output=True, text=True,
        env=env, timeout=60,
    )
    assert result.returncode == 2 and "cannot read the gateway's stored settings" in (
        result.stderr
    )
