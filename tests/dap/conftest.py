"""The adapter as an editor starts it, one per test (``dap_client.DapClient``)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from dap_client import DapClient


@pytest.fixture
def client(tmp_path: Path) -> Iterator[DapClient]:
    client = DapClient(tmp_path)
    yield client
    client.close()
