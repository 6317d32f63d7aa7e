"""Durations, the records store and the grid: the harness's own pieces, without running solvers."""

from __future__ import annotations

import math
import os
import shutil

import pyarrow.parquet as pq
import pytest
from hypothesis import given, strategies as st

import harness
import rigs
from harness import _records
from harness._durations import format_duration, parse_duration
from harness._grid import CellSpec, RunConfig, rig_digest
from registry import _atomic
from tests.harness.full_disk import FullDisk


@pytest.mark.parametrize(
    ("text", "seconds"),
    [
        ("30s", 30.0),
        ("2m", 120.0),
        ("500ms", 0.5),
        ("1.5h", 5400.0),
        ("90", 90.0),
        (" 2 min ", 120.0),
        (".5s", 0.5),
    ],
)
def test_parse_duration_accepts_units(text: str, seconds: float) -> None:
    assert parse_duration(text) == pytest.approx(seconds)


@pytest.mark.parametrize("text", ["", "s", "1d", "-3s", "ten", "3 s s"])
def test_parse_duration_rejects_with_the_accepted_forms(text: str) -> None:
    with pytest.raises(ValueError, match=r"not a duration: .* \(use e.g. 30s, 2m, 500ms"):
        parse_duration(text)


@pytest.mark.parametrize("text", ["1000h", "600h", "700000"])
def test_a_duration_longer_than_a_week_is_refused(text: str) -> None:
    """Waits on worker processes overflow near 596 hours: a longer --timeout or --time-limit is one line."""
    assert parse_duration("168h") == 7 * 24 * 3600.0
    with pytest.raises(ValueError, match=rf"duration '{text}' is longer than 168h, the longest a limit"):
        parse_duration(text)


@given(st.floats(min_value=0, max_value=1e5, allow_nan=False))
def test_format_duration_is_short(seconds: float) -> None:
    text = format_duration(seconds)
    assert len(text) <= 9 and text[-1] == "s"


def _cell_rows(cell: str) -> list[dict]:
    base = {
        "cell": cell,
        "rig": "r",
        "rig_seed": 0,
        "warp": "none",
        "solver": "greedy",
        "mu": 0.3,
        "alpha": 0.5,
    }
    return [
        {**base, "kind": "cell", "status": "ok", "message": "", "n_expressions": 1, "cap": None},
        {
            **base,
            "kind": "expression",
            "expression": 1,
            "shapes": ["a", "b"],
            "extra_examples": [],
            "status": "optimal",
        },
        {
            **base,
            "kind": "transfer",
            "transfer": "ebfr",
            "j": 1,
            "rms": 0.5,
            "worst_rms": [0.7, 0.6],
            "status": "ok",
        },
    ]


def test_part_files_round_trip_in_the_documented_schema(tmp_path) -> None:
    for cell in ("b" * 16, "a" * 16):
        _records.write_part(tmp_path, cell, _cell_rows(cell))
    assert _records.check_parts(tmp_path) == ({"a" * 16, "b" * 16}, {})
    table = pq.read_table(_records.part_path(tmp_path, "a" * 16))
    assert table.schema.names == list(harness.RECORD_COLUMNS)
    assert table.schema.metadata == {b"harness.cell": b"a" * 16, b"harness.rows": b"3"}
    frame = harness.read_records(tmp_path)
    assert list(frame["cell"]) == ["a" * 16] * 3 + ["b" * 16] * 3
    assert list(frame["kind"][:3]) == ["cell", "expression", "transfer"]
    assert frame["shapes"][1] == ["a", "b"] and frame["worst_rms"][2] == [0.7, 0.6]
    assert frame["cap"].isna()[0] and str(frame["expression"].dtype) == "Int64"


def test_unknown_record_column_is_refused() -> None:
    with pytest.raises(ValueError, match=r"unknown columns \['colour'\]"):
        _records.records_table([{"cell": "x", "colour": "red"}])


def test_full_disk_leaves_no_part_file_behind(tmp_path, monkeypatch) -> None:
    monkeypatch.setattr(_atomic, "os", FullDisk())
    with pytest.raises(harness.RecordsWriteError, match=r"could not write .*aaaa.parquet: disk full"):
        _records.write_part(tmp_path, "a" * 16, _cell_rows("a" * 16))
    assert list((tmp_path / "records").iterdir()) == []
    assert _records.check_parts(tmp_path) == (set(), {})


def test_temporary_files_are_invisible_and_removed_on_resume(tmp_path) -> None:
    _records.write_part(tmp_path, "a" * 16, _cell_rows("a" * 16))
    stale = tmp_path / "records" / f".{'b' * 16}.parquet.harness-x1y2z3_4.tmp"
    stale.write_bytes(b"PAR1 torn")
    users = [
        tmp_path / "records" / ".mine.txt.abc.tmp",
        tmp_path / "records" / f".{'c' * 16}.parquet.20241204.tmp",  # (a user's dated copy of a part)
        tmp_path / "records" / "notes.parquet",
    ]
    for path in users:
        path.write_bytes(b"the user's")
    assert _records.check_parts(tmp_path) == ({"a" * 16}, {})
    assert len(harness.read_records(tmp_path)) == 3
    assert _records.remove_partial_files(tmp_path) == [stale]
    assert not stale.exists() and all(path.exists() for path in users)


@pytest.mark.parametrize(
    ("damage", "problem"),
    [
        (lambda path, data: path.write_bytes(data[: len(data) // 2]), "unreadable"),
        (lambda path, data: path.write_bytes(data.replace(b"greedy", b"greedx", 1)), "CRC checksum"),
        (lambda path, data: path.write_bytes(b""), "unreadable"),
        (lambda path, data: shutil.copy(path.with_name("b" * 16 + ".parquet"), path), "another cell"),
    ],
    ids=["truncated", "flipped-bit", "empty", "renamed-copy"],
)
def test_a_damaged_part_file_is_found_and_named(tmp_path, damage, problem) -> None:
    for cell in ("a" * 16, "b" * 16):
        _records.write_part(tmp_path, cell, _cell_rows(cell))
    path = _records.part_path(tmp_path, "a" * 16)
    damage(path, path.read_bytes())
    done, broken = _records.check_parts(tmp_path)
    assert done == {"b" * 16} and list(broken) == [path] and problem in broken[path]
    moved = _records.set_aside(tmp_path, path)
    assert moved == tmp_path / "broken-parts" / path.name and moved.exists() and not path.exists()


def test_reading_a_truncated_part_is_one_line_naming_it(tmp_path) -> None:
    _records.write_part(tmp_path, "a" * 16, _cell_rows("a" * 16))
    path = _records.part_path(tmp_path, "a" * 16)
    path.write_bytes(path.read_bytes()[:300])
    expected = rf"^{path}: not a readable part file .* --resume"
    with pytest.raises(_records.RecordsReadError, match=expected) as e:
        harness.read_records(tmp_path)
    assert "\n" not in str(e.value)


def test_reading_an_empty_run_says_where_it_looked(tmp_path) -> None:
    with pytest.raises(FileNotFoundError, match="no records"):
        harness.read_records(tmp_path)


def _config(**changes) -> RunConfig:
    values = {
        "rigs": ("r1", "r2"),
        "warps": ("none",),
        "solvers": ("greedy", "cpsat"),
        "transfers": ("ebfr",),
    }
    return RunConfig(**{**values, **changes})


def test_grid_is_the_product_of_its_axes_with_solvers_innermost() -> None:
    config = _config(importance=(True, False), cap=(None, 4), repetitions=3, solver_seed=7, scan_seed=20)
    cells = config.cells()
    assert len(cells) == 2 * 2 * 2 * 3 * 2
    assert [c.solver for c in cells[:4]] == ["greedy", "cpsat", "greedy", "cpsat"]
    assert {c.seed for c in cells} == {7, 8, 9} and {c.scan_seed for c in cells} == {20, 21, 22}
    assert {(c.repetition, c.seed, c.scan_seed) for c in cells} == {(r, 7 + r, 20 + r) for r in range(3)}
    assert len({c.id for c in cells}) == len(cells)


def test_rig_seeds_and_distortions_are_axes_and_settings_are_cases() -> None:
    config = _config(
        seed=(0, 3),
        distortion=("paper", "excess"),
        solvers=("greedy", "cpsat[workers=1]", "cpsat[workers=2]"),
    )
    cells = config.cells({"r1@3": "sha256:3"})
    assert len(cells) == 2 * 2 * 2 * 3
    assert {(c.rig_seed, c.distortion) for c in cells} == {
        (s, d) for s in (0, 3) for d in ("paper", "excess")
    }
    assert {c.solver_settings for c in cells} == {"", "workers=1", "workers=2"}
    assert {c.rig_digest for c in cells if c.rig == "r1" and c.rig_seed == 3} == {"sha256:3"}
    assert {c.rig_digest for c in cells if (c.rig, c.rig_seed) != ("r1", 3)} == {""}


def test_a_config_from_before_the_seed_axis_is_refused_by_name() -> None:
    with pytest.raises(ValueError, match="seed must be a tuple of rig generator seeds, got 7"):
        _config(seed=7)


def test_cell_ids_are_stable_and_depend_on_every_field() -> None:
    cell = _config(together=(("a", "b"),), regions=(("lip", (3, 4)),)).cells({"r1": "sha256:1"})[0]
    assert CellSpec.from_dict(cell.to_dict()) == cell
    assert CellSpec.from_dict(cell.to_dict()).id == cell.id
    for change in (
        {"mu": 0.31},
        {"time_limit": 1.0},
        {"j_values": (2,)},
        {"transfers": ()},
        {"solver": "x"},
        {"rig_digest": "sha256:2"},
        {"together": ()},
        {"apart": (("a", "b"),)},
        {"regions": {"lip": [3, 5]}},
        {"distortion": "excess"},
        {"scan_seed": 5},
        {"solver_settings": "workers=2"},
    ):
        changed = CellSpec.from_dict({**cell.to_dict(), **change})
        assert changed.id != cell.id


def test_the_rig_digest_follows_the_content_not_the_path(tmp_path) -> None:
    """Each file form's whole content is tested in ``tests/rigs/test_rig_inputs.py``."""
    first, copy, other = tmp_path / "a.npz", tmp_path / "b.npz", tmp_path / "c.npz"
    rigs.save(rigs.generate("tiny"), first)
    shutil.copy(first, copy)
    rigs.save(rigs.generate("tiny", seed=1), other)
    assert rig_digest(str(first), 0) == rig_digest(str(copy), 0) != rig_digest(str(other), 0)
    folder = rigs.save(rigs.generate("tiny"), tmp_path / "folder", format="obj-folder")
    (folder / "rig.json").unlink()
    before = rig_digest(str(folder), 0)
    (folder / "extra.obj").write_bytes(next(folder.glob("*_L.obj")).read_bytes())
    assert rig_digest(str(folder), 0) != before
    assert rig_digest("tiny", 0) == rig_digest("tiny", 0) != rig_digest("tiny", 1) != rig_digest("male", 1)


def test_the_rig_digest_never_reads_a_fifo(tmp_path) -> None:
    fifo = tmp_path / "rig.npz"
    os.mkfifo(fifo)
    with pytest.raises(rigs.RigError, match="is a FIFO"):
        rig_digest(str(fifo), 0)


def test_run_config_round_trips_through_json_and_rejects_unknown_keys() -> None:
    config = _config(cap=(None, 3), time_limit=2.5, apart=(("a", "b"),), regions=(("lip", (1, 2)),))
    assert RunConfig.from_dict(config.to_dict()) == config
    with pytest.raises(ValueError, match=r"unknown keys \['colour'\]"):
        RunConfig.from_dict({**config.to_dict(), "colour": 1})


def test_every_run_preset_is_a_valid_config() -> None:
    for name, values in harness.PRESETS.items():
        config = RunConfig(preset=name, **values)
        assert config.cells() and not math.isnan(config.cells()[0].mu)


def test_a_transfer_is_computed_once_per_rig_method_and_training_set() -> None:
    """Cells whose solvers agree share one transfer computation, and a method that ignores the training
    expressions (``delta``) one estimate per rig, whatever the expressions (`harness._cell`)."""
    import numpy as np

    import transfer
    from harness import _cell

    template = rigs.generate("tiny", seed=0)
    spec = CellSpec(
        rig="tiny",
        rig_seed=0,
        warp="none",
        solver="greedy",
        mu=0.0,
        alpha=0.0,
        beta=0.0,
        symmetry=True,
        importance=True,
        cap=None,
        jmax=None,
        time_limit=None,
        repetition=0,
        seed=0,
        rig_digest="sha256:units",
    )
    weights = np.zeros((1, template.n_shapes))
    weights[0, :2] = 1.0
    estimates = []

    def estimate() -> np.ndarray:
        estimates.append(1)
        return template.deltas * 0.5

    first = _cell._transfer_metrics(transfer, "delta", spec, template, template, weights, estimate)
    again = _cell._transfer_metrics(transfer, "delta", spec, template, template, weights, estimate)
    other = weights.copy()
    other[0, 2] = 1.0
    third = _cell._transfer_metrics(transfer, "delta", spec, template, template, other, estimate)
    assert (first["transfer_reused"], again["transfer_reused"], third["transfer_reused"]) == (
        False,
        True,
        True,
    )
    assert len(estimates) == 1
    assert again["rms"] == first["rms"] > 0


@pytest.mark.parametrize(("time_limit", "used"), [(None, 5.0), (0.1, 0.1), (60.0, 5.0)])
def test_the_warm_up_solve_keeps_to_the_runs_time_limit(monkeypatch, time_limit, used) -> None:
    """An anytime solver searches until its limit: its warm-up gets the cells' limit when that is shorter,
    so a --timeout that fits its cells fits its warm-up."""
    from harness import _cell

    limits: list[float | None] = []

    class Recorder:
        def solve(self, problem, *, time_limit=None, seed=0):
            limits.append(time_limit)

    monkeypatch.setattr(_cell, "_warmed_up", set())
    monkeypatch.setattr(_cell.plugins, "load_solver", lambda name: Recorder())
    _cell.warm_up("anytime", time_limit)
    _cell.warm_up("anytime", time_limit)  # (once per process)
    assert limits == [used]


def test_a_cell_line_says_how_its_solves_ended_beside_its_time() -> None:
    """No time without its terminations: a cell whose solves hit the time limit, some answered by greedy
    fallback, says so on its progress line; a cell of optimal solves shows its time alone."""
    from harness._progress import cell_summary

    spec = CellSpec(
        rig="tiny", rig_seed=0, warp="none", solver="cbc-pulp", mu=0.0, alpha=0.0, beta=0.0, symmetry=True,
        importance=True, cap=None, jmax=None, time_limit=0.001, repetition=0, seed=0,
    )  # fmt: skip
    cell = {
        "kind": "cell", "status": "ok", "n_expressions": 3, "n_covered": 12, "n_shapes": 12,
        "analysis_time": 0.01, "sequence_time": 0.294,
    }  # fmt: skip
    ended = [("time_limit", "greedy"), ("time_limit", None), ("optimal", None)]
    solves = [{"kind": "expression", "termination": t, "fallback": f} for t, f in ended]
    line = cell_summary(spec, [cell, *solves])
    assert "sequence 294ms [yellow](2 of 3 solves time limit, 1 greedy fallbacks)[/]" in line
    optimal = [{"kind": "expression", "termination": "optimal", "fallback": None}] * 3
    assert cell_summary(spec, [cell, *optimal]).endswith("sequence 294ms")
