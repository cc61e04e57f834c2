"""plant.toml: masters and how each is reached; every mistake at its line with a caret."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.cli import main
from asictl.diagnostics import DiagnosticError
from asictl.fleet.inventory import read_inventory
from asictl.source import from_bytes

GOOD = """\
[defaults]
timeout = "500ms"
retries = 1

[masters.press-1]
modbus = "tcp://127.0.0.1:5020"
unit = 3
line = "line-1"
groups = ["presses"]

[masters.pc-1]
port = "304h"
state_dir = "boards"
attempts = 3
line = "line-2"

[masters.rtu]
modbus = "/dev/ttyUSB0"
baud = 19200
parity = "even"
groups = ["presses"]
"""


def inventory(text: str, name: str = "plant.toml"):
    return read_inventory(from_bytes(name, text.encode()))


def problems(text: str) -> list[tuple[int, int, str]]:
    with pytest.raises(DiagnosticError) as caught:
        inventory(text)
    return [(d.span.line, d.span.column, d.message) for d in caught.value.diagnostics]


def test_masters_become_the_addresses_the_single_master_commands_use():
    plant = inventory(GOOD, "/plant/plant.toml")
    press, pc, rtu = plant.masters
    assert (press.name, press.reached, press.line, press.groups) == (
        "press-1", "tcp://127.0.0.1:5020 unit 3", "line-1", ("presses",)
    )
    assert press.address.modbus == "tcp://127.0.0.1:5020" and press.address.unit == 3
    assert (press.address.timeout, press.address.retries) == (0.5, 1)  # from [defaults]
    assert pc.address.modbus is None and pc.address.port == "304h"
    assert pc.address.state_dir == Path("/plant/boards") and pc.attempts == 3
    assert (rtu.address.baud, rtu.address.parity) == (19200, "even")
    assert [m.name for m in plant.select(groups=("presses",))] == ["press-1", "rtu"]
    assert [m.name for m in plant.select(lines=("line-2",))] == ["pc-1"]


def test_a_line_no_master_is_on_is_refused_with_the_closest():
    from asictl.errors import UserError

    with pytest.raises(UserError, match="no master is on line 'lien-1'; did you mean 'line-1'"):
        inventory(GOOD).select(lines=("lien-1",))


def test_each_mistake_is_at_its_key():
    text = (
        "[masters.a]\n"            # 1
        'modbus = "udp://x"\n'     # 2
        "unit = 99\n"              # 3
        "[masters.b]\n"            # 4
        'port = "301h"\n'          # 5
        "timout = 1\n"             # 6
        "[masters.c]\n"            # 7
        'port = "300h"\n'          # 8
        'modbus = "tcp://h:1"\n'   # 9
        "[masters.d]\n"            # 10
        'port = "300h"\n'          # 11
        "unit = 2\n"               # 12
    )
    found = problems(text)
    assert [(line, column) for line, column, _ in found] == [
        (2, 1), (3, 1), (5, 1), (6, 1), (7, 1), (12, 1)
    ]
    messages = [m for _, _, m in found]
    assert "modbus 'udp://x': expected tcp://HOST[:PORT]" in messages[0]
    assert messages[1] == "unit is a whole number from 1 to 64, not 99"
    assert "port '301h': a PC2 board sits at 300h" in messages[2]
    assert "unknown key 'timout' in [masters.b]; did you mean 'timeout'?" in messages[3]
    assert "give either port" in messages[4] and "not both" in messages[4]
    assert messages[5] == "unit is for a gateway (modbus = ...), not a PC2 board"


def test_names_that_cannot_be_folders_and_names_equal_but_for_case():
    found = problems(
        '[masters."../x"]\nport = "300h"\n[masters.Press]\nport = "300h"\n'
        '[masters.press]\nport = "304h"\n'
    )
    assert [(line, m.split(":")[0]) for line, _, m in found] == [
        (1, "master '../x'"), (5, "master 'press' and 'Press' differ only in case (their "
                               "archive folders would be one on some file systems)")
    ]


def test_no_masters_and_not_toml():
    found = problems('[defaults]\ntimeout = "1s"\n')
    assert found[0][2].startswith("the inventory names no masters")
    line, column, message = problems('[masters.a]\nport = "300h\n')[0]
    assert (line, column) == (2, 13) and message.startswith("not valid TOML")


def test_the_cli_shows_the_line_and_caret_and_exits_2(tmp_path: Path):
    plant = tmp_path / "plant.toml"
    plant.write_text('[masters.a]\nmodbus = "tcp://127.0.0.1:1"\nretries = -1\n')
    result = CliRunner().invoke(main, ["fleet", "status", str(plant)])
    assert result.exit_code == 2, result.output
    assert result.stderr == (
        f"{plant}:3:1: error: retries is a whole number from 0 to 20, not -1 [E404]\n"
        "  retries = -1\n"
        "  ^~~~~~~\n"
    )


def test_one_master_twice_is_refused():
    found = problems(
        '[masters.a]\nmodbus = "tcp://127.0.0.1:5020"\n'
        '[masters.b]\nmodbus = "tcp://127.0.0.1:5020"\nunit = 2\n'
        '[masters.c]\nmodbus = "tcp://127.0.0.1:5020"\nunit = 1\n'
        '[masters.d]\nport = "300h"\nstate_dir = "x"\n[masters.e]\nport = "300h"\n'
        'state_dir = "x/"\n'
    )
    assert [(line, message.split(":")[0]) for line, _, message in found] == [
        (6, "master 'c' is reached as 'a' is (tcp"),
        (12, "master 'e' is reached as 'd' is (port 300h)"),
    ]


def test_a_timeout_takes_a_unit_and_a_bare_number_shows_both_readings():
    base = '[masters.a]\nmodbus = "tcp://127.0.0.1:1"\n'
    assert problems(base + "timeout = 2\n") == [
        (3, 1, 'timeout: give a unit: "2s" or "2ms"')]
    assert problems(base + 'timeout = "2min"\n') == [
        (3, 1, "timeout: '2min' is longer than the longest allowed, 1 min 0 s")]
    inventory = read_inventory(from_bytes("plant.toml", (base + 'timeout = "250ms"\n').encode()))
    assert inventory.masters[0].address.timeout == 0.25
