"""The `harness` command line: rigs, list, pack, show, plugin commands, and one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner, Result

import harness
import packing
import rigs
from harness.cli import cli
from tests.harness.cli_helpers import assert_one_line_error, invoke


def test_list_json_reports_plugins_presets_and_warps() -> None:
    result = invoke("list", "--json")
    assert result.exit_code == 0, result.output
    found = json.loads(result.output)
    solvers = {item["name"]: item for item in found["solvers"]}
    assert solvers["cpsat"]["available"] and solvers["cpsat"]["capabilities"]["exact"] is True
    assert solvers["greedy"]["capabilities"]["exact"] is False and solvers["greedy"]["version"]
    assert {"ebfr", "dt"} <= {item["name"] for item in found["transfers"]}
    assert set(found["rig_presets"]) == set(rigs.PRESETS) and set(found["warps"]) == set(rigs.WARPS)
    assert found["run_presets"] == sorted(harness.PRESETS)


def test_list_shows_an_unavailable_solver_with_its_reason(test_plugins) -> None:
    result = CliRunner(env={"COLUMNS": "200"}).invoke(cli, ["list"])
    blocks = "\n".join(line.strip() for line in result.output.splitlines()).split("\n\n")  # one per plugin
    row = " ".join(next(block for block in blocks if block.startswith("missing ")).split())
    assert row.startswith("missing no") and "package 'harness-test-nothing' is not installed" in row


def test_rigs_generate_info_and_convert(tmp_path) -> None:
    archive = tmp_path / "tiny.npz"
    result = invoke("rigs", "generate", "tiny", "--seed", "3", "--out", archive)
    assert result.exit_code == 0 and archive.exists(), result.output
    from_file = json.loads(invoke("rigs", "info", archive, "--json").output)
    from_preset = json.loads(invoke("rigs", "info", "tiny", "--seed", "3", "--json").output)
    rig = rigs.generate("tiny", seed=3)
    assert from_file["n_vertices"] == rig.n_vertices and from_file["n_shapes"] == rig.n_shapes
    assert from_file["n_triangles"] == rig.n_triangles
    assert from_file["regions"] == {name: len(v) for name, v in sorted(rig.regions.items())}
    assert np.allclose(from_file["bbox"]["min"], rig.bounding_box()[0])
    assert isinstance(from_file["empty_shapes"], list)
    provenance = ("source", "units")  # the native .npz holds geometry, names and regions only
    assert {k: v for k, v in from_file.items() if k not in provenance} == {
        k: v for k, v in from_preset.items() if k not in provenance
    }
    folder = tmp_path / "objs"
    assert invoke("rigs", "convert", archive, folder).exit_code == 0
    converted = rigs.load(folder)
    assert converted.names == rig.names and np.allclose(converted.neutral, rig.neutral)
    table = invoke("rigs", "info", archive)
    assert table.exit_code == 0 and "n_shapes" in table.output


@pytest.mark.skipif(not rigs.WARPS, reason="no warp presets registered yet")
def test_rigs_warp_keeps_topology(tmp_path) -> None:
    name = sorted(rigs.WARPS)[0]
    out = tmp_path / "warped.npz"
    result = invoke("rigs", "warp", "tiny", "--warp", name, "--out", out)
    assert result.exit_code == 0, result.output
    warped, rig = rigs.load(out), rigs.generate("tiny")
    assert warped.names == rig.names and np.array_equal(warped.triangles, rig.triangles)


def test_bad_rig_arguments_are_one_line_errors(tmp_path) -> None:
    assert_one_line_error(invoke("rigs", "info", "nosuchrig"), "unknown rig 'nosuchrig'", "presets:", "tiny")
    assert_one_line_error(
        invoke("rigs", "generate", "huge", "--out", tmp_path / "x.npz"), "unknown rig preset 'huge'"
    )
    broken = tmp_path / "broken.npz"
    broken.write_bytes(b"not a zip archive")
    assert_one_line_error(invoke("rigs", "info", broken), str(broken))
    assert_one_line_error(
        invoke("rigs", "warp", "tiny", "--warp", "melt", "--out", tmp_path / "w.npz"),
        "unknown warp step 'melt'; use a preset (scale-x1.3",
    )


def test_rigs_warp_takes_parametric_specs(tmp_path) -> None:
    out = tmp_path / "w.npz"
    result = invoke("rigs", "warp", "tiny", "--warp", "scale:1.2,1,1", "--out", out)
    assert result.exit_code == 0, result.output
    template, warped = rigs.generate("tiny"), rigs.load(out)
    np.testing.assert_allclose(warped.neutral[:, 0], 1.2 * template.neutral[:, 0])


def run_tiny(out: Path, solvers: str, *extra: object) -> Result:
    """``harness run`` of the ``tiny`` preset, unwarped, with ``solvers`` and the ``dt`` transfer."""
    grid = ["--rigs", "tiny", "--warps", "none", "--solvers", solvers, "--transfers", "dt"]
    return invoke("run", *grid, "--out", out, *extra)


def test_bad_run_arguments_are_one_line_errors(tmp_path) -> None:
    out = tmp_path / "out"
    assert_one_line_error(
        invoke("run", "--rigs", "tiny", "--warps", "none", "--solvers", "cpsat,gurobi", "--out", out),
        "unknown solver 'gurobi'",
        "valid: cbc-mip, cbc-pulp, cpsat",
    )
    assert_one_line_error(
        invoke("run", "--rigs", "tiny", "--warps", "melt", "--out", out), "unknown warp 'melt'"
    )
    assert_one_line_error(
        invoke("run", "--rigs", "tiny.npz", "--warps", "none", "--out", out), "unknown rig 'tiny.npz'"
    )
    bad_duration = invoke("run", "--time-limit", "3 parsecs", "--out", out)
    assert bad_duration.exit_code == 2 and "not a duration: '3 parsecs'" in bad_duration.output
    assert not out.exists()

    first = run_tiny(out, "greedy", "-q")
    assert first.exit_code == 0, first.output
    again = invoke("run", "--rigs", "tiny", "--warps", "none", "--solvers", "greedy", "--out", out)
    assert_one_line_error(again, "already holds a run; use --resume to finish it, --force to overwrite it")


def test_show_summarises_a_run(tmp_path) -> None:
    out = tmp_path / "out"
    run = run_tiny(out, "greedy,highs")
    assert run.exit_code == 0, run.output
    assert "ok tiny greedy" in " ".join(run.output.split())
    shown = CliRunner(env={"COLUMNS": "200"}).invoke(cli, ["show", str(out)])
    assert shown.exit_code == 0, shown.output
    assert "complete, 2 cells" in shown.output and "greedy" in shown.output and "highs" in shown.output
    assert "transfer RMS vs J" in shown.output
    assert_one_line_error(invoke("show", tmp_path / "nothing"), "no run.json here")


def _pack(out, *extra: str, input: str | None = None) -> dict:
    result = invoke("pack", "tiny", "--solver", "cpsat", "--jmax", "3", "--out", out, *extra, input=input)
    assert result.exit_code == 0, result.output
    return json.loads((out / "expressions.json").read_text())


def test_pack_writes_exactly_the_documented_keys_and_one_mesh_per_expression(tmp_path) -> None:
    document = _pack(tmp_path / "pack")
    assert list(document) == [
        "rig", "solver", "params", "sequence", "target", "pairs", "expressions", "excluded", "constraints",
        "warnings",
    ]  # fmt: skip
    assert document["rig"] == "tiny" and document["solver"] == "cpsat"
    assert document["params"] == {
        "mu": 0.3,
        "alpha": 0.5,
        "beta": 0.0,
        "symmetry": True,
        "importance": True,
        "max_per_expression": None,
        "extra_examples": False,
        "together": [],
        "apart": [],
        "regions": None,
    }
    assert document["sequence"] == {
        "mode": "sequence", "jmax": 3, "seed": 0, "time_limit": None, "timeout": None, "overlap": 0.0
    }  # fmt: skip
    assert document["target"] is None and document["excluded"] == []
    assert document["constraints"] == {"default": True, "rules": [], "notes": []}  # no ARKit gaze in tiny
    assert all(len(pair) == 2 for pair in document["pairs"])
    assert 1 <= len(document["expressions"]) <= 3
    for expression in document["expressions"]:
        assert list(expression) == ["shapes", "extra_examples", "objective", "status", "files"]
        assert expression["status"] == "optimal"
    assert isinstance(document["warnings"], list)
    rig = rigs.generate("tiny")
    packing.check(
        rig,
        document["expressions"],
        pairs=document["pairs"],
        overlap=document["sequence"]["overlap"],
        **document["params"],
    )
    meshes = sorted((tmp_path / "pack").glob("expression_*.obj"))
    assert [m.name for m in meshes] == [
        f"expression_{i:02d}.obj" for i in range(1, len(document["expressions"]) + 1)
    ]
    assert [e["files"]["mesh"] for e in document["expressions"]] == [m.name for m in meshes]
    first = np.array(
        [line.split()[1:] for line in meshes[0].read_text().splitlines() if line.startswith("v ")], float
    )
    expected = rig.neutral + rig.deltas[rig.indices(document["expressions"][0]["shapes"])].sum(axis=0)
    assert np.allclose(first, expected)


def test_pack_rejections_remove_a_shape_from_that_expression_only(tmp_path) -> None:
    chosen = _pack(tmp_path / "plain")["expressions"][0]["shapes"]
    rejected = _pack(tmp_path / "rejected", "--reject", f"1:{chosen[0]}")
    assert chosen[0] not in rejected["expressions"][0]["shapes"]
    assert rejected["expressions"][0]["status"] == "optimal"  # optimal once the rejected shape is out
    assert (
        any(chosen[0] in e["shapes"] for e in rejected["expressions"][1:])
        or len(rejected["expressions"]) == 3
    )
    interactive = _pack(tmp_path / "interactive", "--refine", input="n\n" + "y\n" * 100)
    assert interactive["expressions"][0]["shapes"] != chosen
    assert_one_line_error(
        invoke("pack", "tiny", "--out", tmp_path / "x", "--reject", "1:noSuchShape"), "noSuchShape"
    )
    assert_one_line_error(
        invoke("pack", "tiny", "--out", tmp_path / "x", "--reject", "first:jawOpen"), "EXPR:NAME"
    )
    assert_one_line_error(
        invoke("pack", "tiny", "--out", tmp_path / "x", "--solver", "gurobi"), "unknown solver 'gurobi'"
    )


def test_commands_from_the_entry_point_group(test_plugins) -> None:
    assert invoke("hello", "world").output == "hello world\n"
    assert invoke("greet", "evening", "Ada").output == "good evening Ada\n"
    assert_one_line_error(
        invoke("broken"), "the 'broken' command (harness_test_plugins:no_such_thing) failed to load"
    )
    listing = CliRunner().invoke(cli, ["--help"], terminal_width=200).output
    assert "hello" in listing and "greet" in listing and "(unavailable: failed to load)" in listing


def test_pack_reads_a_target_neutral_obj(tmp_path) -> None:
    from rigs._obj_folder import write_obj

    rig = rigs.generate("tiny")
    target = tmp_path / "target.obj"
    write_obj(target, rig.neutral * np.array([1.3, 1.0, 1.0]), rig.triangles, comment="wider face")
    document = _pack(tmp_path / "pack", "--target", target)
    assert document["expressions"] and document["pairs"]
    short = tmp_path / "short.obj"
    write_obj(short, rig.neutral[:-1], rig.triangles[:0])
    assert_one_line_error(
        invoke("pack", "tiny", "--target", short, "--out", tmp_path / "x"),
        f"{short}: target neutral has {rig.n_vertices - 1} vertices, the rig has {rig.n_vertices}",
    )


def test_rigs_fetch_faceunits_loads_and_saves_the_cached_rig(tmp_path, monkeypatch) -> None:
    # The fetcher returns the cached file's path; the command must load it as a rig, not save the path.
    from rigs._faceunits import CACHE_VARIABLE, cached_rig_path

    monkeypatch.setenv(CACHE_VARIABLE, str(tmp_path / "cache"))
    tiny = rigs.generate("tiny")
    rigs.save(tiny, cached_rig_path())
    out = tmp_path / "faceunits.npz"
    result = invoke("rigs", "fetch", "faceunits", "--out", out)
    assert result.exit_code == 0, result.output
    assert f"N={tiny.n_vertices} K={tiny.n_shapes}" in result.output
    assert rigs.load(out).names == tiny.names
    assert invoke("rigs", "fetch", "faceunits").exit_code == 0
    assert invoke("rigs", "fetch", "nothing").exit_code == 2


def test_python_dash_m_harness_is_the_harness_command() -> None:
    """``python -m harness`` is the ``harness`` command, with its exit codes (a usage error exits 2)."""
    listed = subprocess.run(
        [sys.executable, "-m", "harness", "list", "--json"], capture_output=True, text=True, check=False
    )
    assert listed.returncode == 0, listed.stderr
    assert "greedy" in {item["name"] for item in json.loads(listed.stdout)["solvers"]}
    unknown = subprocess.run([sys.executable, "-m", "harness", "nonsense"], capture_output=True, text=True)
    assert unknown.returncode == 2 and "No such command 'nonsense'" in unknown.stderr
