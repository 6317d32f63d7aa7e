"""``harness run --together / --apart / --constraints / --regions``: passed to packing for every cell,
stored in run.json, and checked up front with one-line errors."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from click.testing import CliRunner

import harness
import packing
import rigs
from harness.cli import cli


def invoke(*arguments):
    return CliRunner().invoke(cli, [str(argument) for argument in arguments])


def _grid(rig_file) -> list[str]:
    return ["run", "--rigs", rig_file, "--warps", "none", "--transfers", "ebfr", "--j-values", "2", "-q"]


def test_constraints_and_regions_reach_every_cell_and_run_json(rig_file, tmp_path) -> None:
    constraints = tmp_path / "constraints.json"
    constraints.write_text(json.dumps({"apart": [["bump0_L", "bump1_L"]]}))
    regions = tmp_path / "regions.json"
    names = [name for pair in packing.DEFAULT_REGION_PAIRS for name in pair]
    regions.write_text(json.dumps({name: list(range(16 * k, 16 * k + 8)) for k, name in enumerate(names)}))
    out = tmp_path / "out"
    result = invoke(
        *_grid(rig_file),
        *("--solvers", "greedy,cpsat", "--jobs", "1", "--out", out),
        *("--together", "bump2_L,bump4_L", "--apart", "bump0_R, bump1_R", "--constraints", constraints),
        *("--regions", regions),
    )
    assert result.exit_code == 0, result.output
    config = harness.read_run(out)["config"]
    assert config["together"] == [["bump2_L", "bump4_L"]]
    assert config["apart"] == [["bump0_L", "bump1_L"], ["bump0_R", "bump1_R"]]
    assert config["regions"] == {name: list(range(16 * k, 16 * k + 8)) for k, name in enumerate(names)}
    records = harness.read_records(out)
    assert set(records.loc[records["kind"] == "cell", "status"]) == {"ok"}
    for shapes in records.loc[records["kind"] == "expression", "shapes"]:
        assert ("bump2_L" in shapes) == ("bump4_L" in shapes)
        assert not {"bump0_L", "bump1_L"} <= set(shapes) and not {"bump0_R", "bump1_R"} <= set(shapes)

    line = invoke("run", "--resume", out, "--together", "bump2_L,bump3_L").output.strip()
    assert "--together bump2_L,bump3_L (the run has bump2_L,bump4_L)" in line


@pytest.mark.parametrize(
    ("arguments", "files", "message"),
    [
        (("--together", "bump0_L"), {}, "--together: 'bump0_L' is not a pair of shape names 'A,B'"),
        (("--apart", "bump0_L,bump0_L"), {}, "--apart: 'bump0_L,bump0_L' pairs a shape with itself"),
        (
            ("--together", "bump0_L,bmup1_L"),
            {},
            "--together on rig .*: no blendshape named 'bmup1_L' .*did you mean bump1_L",
        ),
        (("--constraints", "{c}"), {"c": "[1, 2]"}, r"{c}: constraints JSON must be an object"),
        (("--constraints", "{c}"), {"c": '{"alone": []}'}, r"{c}: unknown key 'alone'"),
        (("--constraints", "{c}"), {}, r"{c}: no such file"),
        (
            ("--constraints", "{c}"),
            {"c": '{"apart": [["bump0_L", "bmup1_L"]]}'},
            r"{c}: apart bump0_L,bmup1_L: .*no blendshape named 'bmup1_L' .*did you mean bump1_L",
        ),
        (
            ("--together", "bump2_L,bump4_L", "--constraints", "{c}"),
            {"c": '{"together": [["bump0_L", "bmup1_L"]]}'},
            r"{c}: together bump0_L,bmup1_L: .*no blendshape named 'bmup1_L'",
        ),
        (("--regions", "{r}"), {"r": "{not json"}, r"{r}: not a readable JSON regions file"),
        (
            ("--regions", "{r}"),
            {"r": '{"lip": [1, -2]}'},
            r"{r}: region 'lip' holds a negative vertex index",
        ),
        (
            ("--regions", "{r}"),
            {"r": '{"lip": [1, 999]}'},
            r"--regions on .*'lip' indexes outside 0..255",
        ),
        (
            ("--regions", "{r}"),
            {"r": '{"lip": [1, 9]}'},
            r"--regions on rig .*no region .* of the region pairs",
        ),
    ],
)
def test_bad_constraints_and_regions_are_one_line_errors_before_any_cell(
    rig_file, tmp_path, arguments, files, message
) -> None:
    paths = {key: tmp_path / f"{key}.json" for key in ("c", "r")}
    for key, text in files.items():
        paths[key].write_text(text)
    arguments = [argument.format(**paths) for argument in arguments]
    out = tmp_path / "out"
    result = invoke(*_grid(rig_file), "--solvers", "greedy", "--out", out, *arguments)
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert re.search(message.format(**{key: re.escape(str(path)) for key, path in paths.items()}), lines[0])
    assert not (out / "records").exists()


def test_regions_from_the_face_groups_of_an_obj_reach_every_cell(tmp_path) -> None:
    tiny = rigs.resolve("tiny")
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in tiny.neutral]
    expected = {}
    for name in sorted(tiny.regions):
        inside = np.isin(tiny.triangles, tiny.regions[name]).all(axis=1)
        lines.append(f"g {name}")
        lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in tiny.triangles[inside]]
        expected[name] = sorted(np.unique(tiny.triangles[inside]).tolist())
    regions = tmp_path / "regions.obj"
    regions.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    arguments = ("--solvers", "greedy", "--transfers", "delta", "--regions", regions, "--out", out, "-q")
    result = invoke("run", "--rigs", "tiny", *arguments)
    assert result.exit_code == 0, result.output
    assert harness.read_run(out)["config"]["regions"] == expected
    records = harness.read_records(out)
    assert set(records.loc[records["kind"] == "cell", "status"]) == {"ok"}
