"""How ``serve --opcua`` starts quickly (docs/performance.md): asyncua's standard address
space built once and then loaded from the user's cache directory, and the address space
built without the garbage collector and frozen out of its reach."""

from __future__ import annotations

import asyncio
import gc
import pickle
from pathlib import Path

import pytest
from asyncua import Client, ua
from asyncua.server.address_space import AddressSpace
from asyncua.server.standard_address_space import standard_address_space
from opcua_space import collector_off, standard_server
from test_opcua import NAMESPACE, node, served
from test_opcua import state as state

from asictl.files import cache_directory
from asictl.opcua.server import _kept_for_good
from asictl.opcua.standard_space import cache_file


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    path = cache_file()  # its directory made
    assert path is not None and path.parent == tmp_path / "cache" / "asictl"
    return path


async def standard_nodes() -> dict[ua.NodeId, str]:
    """The standard address space as a server built on the cache has it: each node's
    browse name."""
    with collector_off():
        server = await standard_server()
        nodes = server.iserver.aspace
        ids = list(nodes.keys())  # the address space is no mapping: no iterating over it
        return {nodeid: nodes.read_attribute_value(nodeid, ua.AttributeIds.BrowseName)
                .Value.Value.Name for nodeid in ids}


def test_the_standard_address_space_is_built_once_then_loaded(
    cache: Path, monkeypatch: pytest.MonkeyPatch,
):
    built = asyncio.run(standard_nodes())
    assert cache.is_file() and cache.stat().st_mode & 0o077 == 0  # the owner's alone
    assert len(built) > 5000 and built[ua.NodeId(ua.ObjectIds.Server)] == "Server"

    def never(_service: object) -> None:
        raise AssertionError("built again although it was in the cache")

    monkeypatch.setattr(standard_address_space, "fill_address_space", never)
    assert asyncio.run(standard_nodes()) == built


def test_a_cache_that_does_not_load_is_built_anew(cache: Path):
    cache.write_bytes(b"\x80\x05not a pickle")
    assert len(asyncio.run(standard_nodes())) > 5000
    with cache.open("rb") as stored, collector_off():  # replaced by the nodes built
        assert len(pickle.load(stored)) > 5000


def test_a_cache_that_cannot_be_written_leaves_nothing(cache: Path,
                                                        monkeypatch: pytest.MonkeyPatch):
    def unpicklable(_space: object, _path: object) -> None:
        raise pickle.PicklingError("a node of a later asyncua")

    monkeypatch.setattr(AddressSpace, "dump", unpicklable)
    assert len(asyncio.run(standard_nodes())) > 5000  # served all the same
    assert list(cache.parent.iterdir()) == []  # no half-written file either


def test_no_cache_where_others_may_write(cache: Path):
    cache.parent.chmod(0o777)
    assert cache_directory() is None and cache_file() is None
    assert len(asyncio.run(standard_nodes())) > 5000
    assert list(cache.parent.iterdir()) == []


@pytest.mark.parametrize("collecting", [True, False])
def test_the_address_space_is_built_without_collections_and_frozen(collecting: bool):
    async def build() -> list[object]:
        async with _kept_for_good():
            assert not gc.isenabled()
            return [[n] for n in range(1000)]  # containers the collector would visit

    was = gc.isenabled()
    frozen = gc.get_freeze_count()
    (gc.enable if collecting else gc.disable)()
    try:
        kept = asyncio.run(build())
        assert gc.isenabled() is collecting  # as it was before
        assert gc.get_freeze_count() >= frozen + len(kept)
    finally:
        gc.unfreeze()
        (gc.enable if was else gc.disable)()


def test_serve_builds_the_cache_then_starts_from_it(state: Path, tmp_path: Path):
    async def session(url: str) -> None:
        async with Client(url) as client:
            ns = await client.get_namespace_index(NAMESPACE)
            assert await node(client, ns, "Master.Phase").read_value() == "normal operation"
            status = client.get_node(ua.ObjectIds.Server_ServerStatus_State)
            assert await status.read_value() == ua.ServerState.Running

    env = {"XDG_CACHE_HOME": str(tmp_path / "cache")}
    stored = tmp_path / "cache" / "asictl"
    written: list[tuple[str, int]] = []
    for _ in range(2):  # the first start writes the cache, the second loads it
        with served(state, "serve", env=env) as url:
            asyncio.run(session(url))
        written += [(path.name, path.stat().st_mtime_ns) for path in stored.iterdir()]
    first, second = written  # one file, and the second start did not write it again
    assert first == second and first[0].startswith("opcua-standard-space-asyncua")
