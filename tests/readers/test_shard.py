"""``--shard I/N``: read strictly, and a split that gives every file to exactly one of
the N shards, whatever the paths, their order or where the checkout is."""

from __future__ import annotations

import posixpath
from collections import Counter
from random import Random

import pytest
from hypothesis import given
from hypothesis import strategies as st

from asictl.readers.shard import Shard, ShardError, keys, select, shard_of

_SEGMENT = st.text(alphabet="ab-_.0Z é", min_size=1, max_size=4).filter(
    lambda s: s not in (".", "..") and s.strip() == s)
#: relative file paths, some named twice, some sharing folders
_PATHS = st.lists(st.lists(_SEGMENT, min_size=1, max_size=3).map("/".join), max_size=30)


def _split(paths: list[str], total: int) -> list[list[int]]:
    """The positions of ``paths`` each shard takes, shard 1 first."""
    positions = list(range(len(paths)))
    return [select(positions, paths, Shard(i, total)) for i in range(1, total + 1)]


@given(_PATHS, st.integers(1, 8))
def test_every_file_is_in_exactly_one_shard(paths: list[str], total: int) -> None:
    shards = _split(paths, total)
    taken = [n for shard in shards for n in shard]
    assert sorted(taken) == list(range(len(paths)))  # the union is all, none twice
    for shard in shards:
        assert shard == sorted(shard)  # each keeps the given order
    # a file named twice is one file: every name of it in one shard
    for shard in shards:
        others = {paths[n] for other in shards if other is not shard for n in other}
        assert not {paths[n] for n in shard} & others
    # the shards differ by one file at most
    sizes = [len({paths[n] for n in shard}) for shard in shards]
    assert max(sizes) - min(sizes) <= 1


@given(_PATHS, st.integers(1, 8), st.randoms(use_true_random=False),
       st.sampled_from(["/work/ci/a", "/builds/x/y/z", "/r"]))
def test_the_split_is_the_same_in_every_job(paths: list[str], total: int,
                                             random: Random, root: str) -> None:
    """Each job of a matrix decides alone: the shard of a file does not depend on the
    order the files were found in, nor on where the checkout is on the runner."""
    here = dict(zip(paths, shard_of(paths, total), strict=True))
    shuffled = list(paths)
    random.shuffle(shuffled)
    moved = [posixpath.join(root, p) for p in shuffled]
    elsewhere = dict(zip(shuffled, shard_of(moved, total), strict=True))
    assert elsewhere == here


@given(_PATHS)
def test_keys_name_each_file_apart(paths: list[str]) -> None:
    named = keys(paths)
    assert Counter(Counter(named).values()) == Counter(Counter(
        posixpath.normpath(p) for p in paths).values())


@pytest.mark.parametrize(("text", "index", "total"), [
    ("1/1", 1, 1), ("2/4", 2, 4), (" 3 / 3 ", 3, 3), ("10/12", 10, 12),
])
def test_i_of_n(text: str, index: int, total: int) -> None:
    assert Shard.parse(text) == Shard(index, total)
    assert str(Shard(index, total)) == f"{index}/{total}"


@pytest.mark.parametrize(("text", "says"), [
    ("0/2", "I counts from 1 to N (2)"),
    ("3/2", "I counts from 1 to N (2)"),
    ("-1/2", "I counts from 1 to N (2)"),
    ("1/0", "N is at least 1"),
    ("1/-3", "N is at least 1"),
    ("a/2", "I and N are whole numbers"),
    ("1.5/2", "I and N are whole numbers"),
    ("1/", "I and N are whole numbers"),
    ("2", "is not I/N"),
    ("", "is not I/N"),
    ("1/2/3", "I and N are whole numbers"),
])
def test_what_names_no_shard_is_refused_plainly(text: str, says: str) -> None:
    with pytest.raises(ShardError, match=says.replace("(", r"\(").replace(")", r"\)")):
        Shard.parse(text)


def test_auto_reads_gitlab_parallel() -> None:
    env = {"CI_NODE_INDEX": "2", "CI_NODE_TOTAL": "5"}
    assert Shard.parse("auto", env) == Shard(2, 5)
    assert Shard.parse("AUTO", env) == Shard(2, 5)
    assert Shard.parse("auto", {}) == Shard(1, 1)  # not a parallel job: the whole
    with pytest.raises(ShardError, match="CI_NODE_TOTAL is not set"):
        Shard.parse("auto", {"CI_NODE_INDEX": "1"})
    with pytest.raises(ShardError, match="CI_NODE_INDEX is not set"):
        Shard.parse("auto", {"CI_NODE_TOTAL": "3"})
    with pytest.raises(ShardError, match="CI_NODE_INDEX/CI_NODE_TOTAL '4/3'"):
        Shard.parse("auto", {"CI_NODE_INDEX": "4", "CI_NODE_TOTAL": "3"})
