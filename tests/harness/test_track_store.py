"""`harness.TrackStore`: a Parquet dataset partitioned by machine and commit, at a path or any fsspec URL,
to which files are only ever added."""

from __future__ import annotations

import uuid

import pandas as pd
import pytest

import harness
from harness import CodeVersion, CommitFacts, Measurement, TrackStore, machine_id
from harness._track_store import StoreError

COMMIT, ANCHOR = "c" * 40, "a" * 40
MACHINE = {"hostname": "box", "cpu_model": "Test CPU @ 3 GHz", "cpu_count": 2}


def _measurement(problems: tuple[str, ...] = ()) -> Measurement:
    versions = (CodeVersion("anchor", ANCHOR, "python", ()), CodeVersion("commit", COMMIT, "python", ()))
    rows = [
        {"version": version.name, "commit": version.commit, "round": 0, "kind": "solve", "group": "tiny/none",
         "instance": 1, "case": "tiny/none/cpsat", "digest": "d", "number": 10, "wall": 0.01, "thread": 0.01,
         "process": 0.01, "children": 0.0, "cold": False, "valid": True}
        for version in versions
    ]  # fmt: skip
    answers = pd.DataFrame(
        [{"group": "tiny/none", "instance": 1, "solver": "cpsat", "problem": text} for text in problems],
        columns=["group", "instance", "solver", "problem"],
    )
    samples = pd.DataFrame(rows, columns=list(harness.SAMPLE_COLUMNS))
    errors = ["anchor: solver scip: not installed"]
    return Measurement(
        versions, harness.suite("quick"), samples, answers, pd.DataFrame(), errors, 1, 1.0, "2026-12-07"
    )


@pytest.mark.parametrize("where", ["local", "memory"])
def test_a_session_is_added_under_its_machine_and_commit_and_read_back(tmp_path, where):
    url = str(tmp_path / "store") if where == "local" else f"memory://track-{uuid.uuid4().hex}"
    store = TrackStore(url)
    assert store.parts() == [] and store.read().empty
    path = store.add(
        _measurement(("overlap",)), CommitFacts(COMMIT, "2026-12-07", "a commit"), ANCHOR, MACHINE
    )
    assert f"machine={machine_id(MACHINE)}/commit={COMMIT}/" in path
    frame = store.read()
    assert set(frame["version"]) == {"anchor", "commit"} and set(frame["commit"]) == {COMMIT}
    assert set(frame["anchor"]) == {ANCHOR} and set(frame["subject"]) == {"a commit"}
    assert frame["problems"].iloc[0].splitlines() == [
        "anchor: solver scip: not installed",
        "tiny/none expression 1, cpsat: overlap",
    ]
    assert store.read(machine="0" * 12).empty and store.read(suite="large").empty
    assert store.read(anchor="b" * 40).empty and len(store.read(anchor=ANCHOR)) == 2
    store.add(_measurement(), CommitFacts(COMMIT, "2026-12-07", "a commit"), ANCHOR, MACHINE)
    assert len(store.parts()) == 2 and frame["session"].nunique() == 1  # a new file, the first untouched


def test_a_part_holds_one_commit_and_its_anchor(tmp_path):
    with pytest.raises(StoreError, match="its anchor's"):
        TrackStore(str(tmp_path)).add(_measurement(), CommitFacts("e" * 40, "", ""), ANCHOR, MACHINE)


def test_a_part_that_does_not_read_is_named(tmp_path):
    broken = tmp_path / f"machine=x/commit={COMMIT}/s.parquet"
    broken.parent.mkdir(parents=True)
    broken.write_bytes(b"PAR1 not parquet")
    with pytest.raises(StoreError, match="s.parquet does not read"):
        TrackStore(str(tmp_path)).read()


def test_a_store_of_an_unknown_file_system_is_one_line():
    with pytest.raises(StoreError, match="nosuchfs"):
        TrackStore("nosuchfs://bucket/track")
