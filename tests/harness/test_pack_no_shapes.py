"""A rig without blendshapes is said to be one, by ``harness pack`` and ``harness run`` alike, before any
solve: nothing blames an ``--exclude`` that was not given."""

from __future__ import annotations

import numpy as np
from click.testing import CliRunner

import rigs
from harness.cli import cli


def test_a_rig_without_blendshapes_is_named_as_one(tmp_path) -> None:
    tiny = rigs.generate("tiny")
    bare = rigs.save(
        rigs.Rig(tiny.neutral, np.zeros((0, tiny.n_vertices, 3)), tiny.triangles, []), tmp_path / "bare.npz"
    )
    packed = CliRunner().invoke(cli, ["pack", str(bare), "--no-pictures", "--out", str(tmp_path / "out")])
    assert packed.exit_code == 2 and "--exclude" not in packed.output, packed.output
    assert packed.output.strip().endswith("bare.npz: the rig has no blendshapes to pack")
    ran = CliRunner().invoke(
        cli,
        [
            "run",
            "--rigs",
            str(bare),
            "--warps",
            "none",
            "--solvers",
            "greedy",
            "--out",
            str(tmp_path / "run"),
        ],
    )
    assert ran.exit_code == 2 and "it has no blendshapes, so there is nothing to pack" in ran.output, (
        ran.output
    )
