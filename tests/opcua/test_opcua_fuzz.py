"""Hostile OPC UA writes, generated, to the writable server's variables (a flag byte, a
flag bit, a slave's inputs, the inputs of a slave not on the cable, a read-only status
value): values of every scalar variant type, in and out of the variable's range, NaN,
the largest integers, strings, arrays empty or not, Null. Each write is refused with a
Bad status, or taken and the value read back is one the variable can hold; and the
server answers a read after each. One server for the module; sized for CI, ``-m slow``
runs many more examples."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from asyncua import ua
from asyncua.sync import Client
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_opcua import NAMESPACE, PROGRAM, asictl, served

V = ua.VariantType

#: Each written variable, and what a value it holds must be.
HOLDS: dict[str, Any] = {
    "FY 13": lambda v: isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= 0xFF,
    "F 14.3": lambda v: isinstance(v, bool),
    "Slave.1.Inputs": lambda v: isinstance(v, int) and 0 <= v <= 0xF,
    "Slave.2.Inputs": lambda v: isinstance(v, int) and 0 <= v <= 0xF,
    "Master.StartFlag": lambda v: isinstance(v, bool),
}

BOUNDS = {V.SByte: 7, V.Byte: 8, V.Int16: 15, V.UInt16: 16, V.Int32: 31, V.UInt32: 32,
          V.Int64: 63, V.UInt64: 64}


def integers(kind: ua.VariantType) -> st.SearchStrategy[int]:
    bits = BOUNDS[kind]
    low, high = (0, 2**bits - 1) if kind.name.startswith(("U", "Byte")) else (
        -2**bits, 2**bits - 1)
    return st.integers(low, high) | st.sampled_from(
        [n for n in (low, high, 0, 15, 16, 255, 256) if low <= n <= high])


def scalars(kind: ua.VariantType) -> st.SearchStrategy[Any]:
    if kind in BOUNDS:
        return integers(kind)
    if kind == V.Boolean:
        return st.booleans()
    if kind in (V.Float, V.Double):
        return st.floats(width=32 if kind == V.Float else 64) | st.sampled_from(
            [math.nan, math.inf, -0.0, 15.5, 1e300 if kind == V.Double else 3e38])
    if kind == V.String:
        return st.text(max_size=20) | st.sampled_from(["15", "0x0F", "\0", "9" * 400])
    return st.binary(max_size=20)


@st.composite
def variants(draw: st.DrawFn) -> ua.Variant:
    kind = draw(st.sampled_from([V.Null, V.Boolean, *BOUNDS, V.Float, V.Double, V.String,
                                 V.ByteString]))
    if kind == V.Null:
        return ua.Variant(None, V.Null)
    if draw(st.integers(0, 4)) == 0:
        return ua.Variant(draw(st.lists(scalars(kind), max_size=3)), kind, is_array=True)
    return ua.Variant(draw(scalars(kind)), kind)


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Client, int]]:
    state: Path = tmp_path_factory.mktemp("opcua-fuzz")
    state.chmod(0o700)
    (state / "flag.asi").write_text(PROGRAM)
    asictl(state, "download", str(state / "flag.asi"), "--start")
    with served(state, "serve", "--opcua-writable") as url, Client(url) as connected:
        yield connected, connected.get_namespace_index(NAMESPACE)


def written_plainly(client: tuple[Client, int], name: str, variant: ua.Variant) -> None:
    connected, ns = client
    node = connected.get_node(ua.NodeId(name, ns))
    try:
        node.write_value(variant)
    except ua.UaStatusCodeError as exc:
        assert ua.StatusCode(exc.code).is_bad(), exc
    value = node.read_value()
    assert HOLDS[name](value), (name, variant, value)
    assert isinstance(connected.get_node(ua.NodeId("Master.Phase", ns)).read_value(), str)


@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
@given(name=st.sampled_from(sorted(HOLDS)), variant=variants())
def test_a_hostile_write_is_refused_or_stored_within_range(client, name, variant):
    written_plainly(client, name, variant)


@pytest.mark.slow
@settings(max_examples=3000, deadline=None, suppress_health_check=list(HealthCheck))
@given(name=st.sampled_from(sorted(HOLDS)), variant=variants())
def test_a_hostile_write_is_refused_or_stored_within_range_long_run(client, name, variant):
    written_plainly(client, name, variant)


def test_an_array_written_to_a_scalar_is_a_type_mismatch(client):
    """Found by the test above: asyncua passed an empty Boolean array on to a flag bit,
    which cleared the bit and stored ``[]`` as its value."""
    connected, ns = client
    bit = connected.get_node(ua.NodeId("F 14.3", ns))
    bit.write_value(ua.Variant(True, V.Boolean))
    for name, variant in (("F 14.3", ua.Variant([], V.Boolean, is_array=True)),
                          ("FY 13", ua.Variant([7, 8], V.Byte, is_array=True))):
        with pytest.raises(ua.UaStatusCodeError) as refused:
            connected.get_node(ua.NodeId(name, ns)).write_value(variant)
        assert refused.value.code == ua.StatusCodes.BadTypeMismatch
    assert bit.read_value() is True
