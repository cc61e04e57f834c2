"""``asictl gateway serve``: serves the persistent board of --port, saves it on Ctrl-C."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys

from pymodbus.client import ModbusTcpClient

from asictl.host.transports import gateway_pdus as pdus


def test_serve_download_over_modbus_persists_for_the_pc2_port(tmp_path):
    env = {**os.environ, "ASICTL_STATE_DIR": str(tmp_path)}
    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", "gateway", "serve", "--tcp", "127.0.0.1:0"],
        stderr=subprocess.PIPE, text=True, env=env,
    )
    try:
        line = process.stderr.readline()
        match = re.search(r"tcp 127\.0\.0\.1:(\d+)", line)
        assert match, line
        client = ModbusTcpClient("127.0.0.1", port=int(match.group(1)), timeout=2, retries=0)
        for cls in pdus.CLIENT_PDUS:
            client.register(cls)
        assert client.connect()
        block = bytes(range(100, 116))
        assert client.execute(False, pdus.DownloadRequest(0, block, dev_id=1)).address == 0
        client.close()
    finally:
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=10) == 0
    state = json.loads((tmp_path / "pc2-300h.json").read_text())
    assert bytes.fromhex(state["eeprom"]).startswith(block)
    bad_unit = subprocess.run(
        [sys.executable, "-m", "asictl", "gateway", "serve", "--unit", "0"],
        capture_output=True, text=True, env=env, timeout=20,
    )
    assert bad_unit.returncode == 2 and "--unit" in bad_unit.stderr
