"""`harness pack`: output folders, the whole-pack timeout, the solver's overlap allowance, refinement with
extra examples, artist constraints, regions and cancellation warnings."""

from __future__ import annotations

import contextlib
import functools
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import packing
import rigs
import session._pack
import solvers
from registry import _outdir
from registry._outdir import MANIFEST_NAME
from tests.harness import cli_helpers
from tests.harness.cli_helpers import assert_one_line_error, flat, invoke

#: `harness pack` with cpsat, at most 20 expressions and no pictures.
pack = functools.partial(cli_helpers.pack, pictures=False)


def contents(folder: Path) -> dict[str, bytes]:
    return {
        path.relative_to(folder).as_posix(): path.read_bytes() for path in folder.rglob("*") if path.is_file()
    }


@pytest.fixture(scope="module")
def tiny() -> rigs.Rig:
    return rigs.generate("tiny")


def test_the_users_files_in_the_output_folder_are_kept(tmp_path) -> None:
    out = tmp_path / "session"
    out.mkdir()
    (out / "expression_07.obj").write_text("the user's own scan\n")
    (out / "notes.txt").write_text("take 3\n")
    mine = contents(out)
    for force in ((), ("--force",)):
        assert_one_line_error(
            invoke("pack", "tiny", "--out", out, *force),
            "is not empty and holds no harness output (expression_07.obj, notes.txt)",
            "move its files away",
        )
    assert contents(out) == mine
    document, _ = pack("tiny", tmp_path / "packed")
    pack("tiny", tmp_path / "packed", "--force", "--jmax", "1")  # a shorter packing leaves no extra mesh
    after = contents(tmp_path / "packed")
    assert len(document["expressions"]) > 1
    assert sorted(name for name in after if name.startswith("expression_")) == ["expression_01.obj"]


def test_a_file_of_the_user_in_the_way_stops_the_pack_before_writing(tmp_path) -> None:
    out = tmp_path / "session"
    out.mkdir()
    (out / "expression_01.obj").write_text("the user's own scan\n")
    result = invoke("pack", "tiny", "--out", out, "--force")
    assert_one_line_error(result, f"{out}: is not empty and holds no harness output (expression_01.obj)")
    assert contents(out) == {"expression_01.obj": b"the user's own scan\n"}


def test_a_session_needs_force_to_be_replaced(tmp_path) -> None:
    out = tmp_path / "session"
    pack("tiny", out)
    before = contents(out)
    assert_one_line_error(invoke("pack", "tiny", "--out", out), f"{out}: holds a harness pack", "--force")
    assert contents(out) == before
    pack("tiny", out, "--force", "--seed", "1")


@pytest.mark.parametrize("where", ["rig", "inside", "neutral"])
def test_the_rig_is_never_the_output(tiny, tmp_path, where: str) -> None:
    folder = rigs.save(tiny, tmp_path / "face")
    before = contents(folder)
    argument, out = {
        "rig": (folder, folder),
        "inside": (folder, folder / "packed"),
        "neutral": (folder / "neutral.obj", folder),
    }[where]
    for force in ((), ("--force",)):
        assert_one_line_error(
            invoke("pack", argument, "--out", out, *force), "the input", "apart from the inputs"
        )
    assert contents(folder) == before and not (folder / "packed").exists()
    assert rigs.load(folder).names == tiny.names


class Clock:
    """A wall clock the test moves: each solve takes ``step`` seconds, or its whole time limit."""

    def __init__(self, step: float | None) -> None:
        self.now = 0.0
        self.step = step
        self.limits: list[float | None] = []

    def __call__(self) -> float:
        return self.now


class TimedSolver:
    """Greedy (sec. 4.5.2) on the test clock; with ``step=None`` it spends the whole limit and finds nothing,
    like an exact solver stopped before its first incumbent."""

    def __init__(self, clock: Clock) -> None:
        self.inner = solvers.get("greedy")
        self.name = "timed"
        self.capabilities = self.inner.capabilities
        self.clock = clock

    def solve(self, problem, *, time_limit=None, seed=0):
        self.clock.limits.append(time_limit)
        if self.clock.step is None:
            self.clock.now += time_limit
            return packing.Solution((), (), 0.0, None, packing.Termination.TIME_LIMIT)
        self.clock.now += self.clock.step
        return self.inner.solve(problem, time_limit=time_limit, seed=seed)


class InProcess(contextlib.nullcontext):
    """`harness.IsolatedSolver` without the worker: the solver on the test clock solves here."""

    def __init__(self, label, clock: Clock) -> None:
        super().__init__(TimedSolver(clock))


@pytest.fixture
def clock(monkeypatch) -> Clock:
    clock = Clock(step=1.0)
    monkeypatch.setattr(session._pack, "monotonic", clock)
    monkeypatch.setattr(session._pack, "IsolatedSolver", lambda label: InProcess(label, clock))
    return clock


def test_timeout_writes_the_expressions_found_so_far_and_says_so(clock, tmp_path) -> None:
    out = tmp_path / "out"
    result = invoke("pack", "male", "--out", out, "--timeout", "2.5s", "--time-limit", "2s")
    assert result.exit_code == 0, result.output
    document = json.loads((out / "expressions.json").read_text())
    assert len(document["expressions"]) == 3 and len(list(out.glob("expression_*.obj"))) == 3
    assert clock.limits == [2.0, 1.5, 0.5]  # each solve gets at most the time left; none after it
    assert document["sequence"]["timeout"] == 2.5
    message = "stopped by --timeout 2.5s after 3 expressions; the expressions found so far are written"
    assert message in document["warnings"]
    output = flat(result.output)
    assert (
        f"warning: {message}" in output and "blendshapes in no expression (--timeout 2.5s ran out)" in output
    )


def test_timeout_before_the_first_expression_is_one_line_error(clock, tmp_path) -> None:
    clock.step = None
    result = invoke("pack", "tiny", "--out", tmp_path / "out", "--timeout", "3s")
    assert_one_line_error(result, "--timeout 3.0s ran out before the first expression was found")
    assert clock.limits == [3.0]
    assert not (tmp_path / "out" / "expressions.json").exists()


def test_greedy_overlap_is_checked_with_its_declared_allowance(tmp_path) -> None:
    document, _ = pack("male", tmp_path / "out", "--solver", "greedy-overlap")
    allowance = solvers.get("greedy-overlap").capabilities.max_overlap
    assert allowance > 0 and document["sequence"]["overlap"] == allowance
    rig = rigs.generate("male")
    expressions = document["expressions"]
    packing.check(rig, expressions, pairs=document["pairs"], overlap=allowance, **document["params"])
    with pytest.raises(packing.CheckError) as strict:  # it does overlap: a strict check would fail
        packing.check(rig, expressions, pairs=document["pairs"], **document["params"])
    assert strict.value.kind == "overlap"


def test_rejections_with_extra_examples_apply_to_the_expression_named(tmp_path) -> None:
    options = ("--jmax", "4", "--extra-examples")
    plain, _ = pack("male", tmp_path / "plain", *options)
    assert all(e["extra_examples"] for e in plain["expressions"][1:3])  # extra passes before expression 3
    name = plain["expressions"][2]["shapes"][0]
    rejected, _ = pack("male", tmp_path / "rejected", *options, "--reject", f"3:{name}")
    third = rejected["expressions"][2]
    assert name not in third["shapes"] + third["extra_examples"]
    assert [e["shapes"] for e in rejected["expressions"][:2]] == [
        e["shapes"] for e in plain["expressions"][:2]
    ]
    assert third["status"] == "optimal"  # optimal for the problem without the rejected shape


def test_extra_examples_are_put_to_the_artist_as_such(tmp_path) -> None:
    result = invoke(
        "pack",
        "male",
        "--jmax",
        "2",
        "--extra-examples",
        "--refine",
        "--out",
        tmp_path / "out",
        input="y\n" * 200,
    )
    assert result.exit_code == 0, result.output
    document = json.loads((tmp_path / "out" / "expressions.json").read_text())
    extra = document["expressions"][1]["extra_examples"]
    prompts = [line for line in result.output.splitlines() if "as an extra example?" in line]
    assert extra and any(line.startswith(f"expression 2: keep {extra[0]}") for line in prompts)
    assert all(line.startswith("expression 2:") for line in prompts)


def test_together_and_apart_constraints_from_options_and_a_file(tiny, tmp_path) -> None:
    plain, _ = pack("tiny", tmp_path / "plain")
    shared = next(e["shapes"] for e in plain["expressions"] if len(e["shapes"]) >= 2)
    a, b = shared[0], shared[1]
    separate = next(
        (x, y)
        for x in tiny.names
        for y in tiny.names
        if x < y
        and not any(x in e["shapes"] and y in e["shapes"] for e in plain["expressions"])
        and not any({x, y} & set(pair) for pair in plain["pairs"])
    )
    document, _ = pack("tiny", tmp_path / "options", "--apart", f"{a},{b}", "--together", ",".join(separate))
    constraints = tmp_path / "constraints.json"
    constraints.write_text(json.dumps({"apart": [[a, b]], "together": [list(separate)]}))
    from_file, _ = pack("tiny", tmp_path / "file", "--constraints", constraints)
    for result in (document, from_file):
        assert result["params"]["apart"] == [[a, b]] and result["params"]["together"] == [list(separate)]
        groups = [set(e["shapes"]) for e in result["expressions"]]
        assert not any({a, b} <= group for group in groups)
        assert any(set(separate) <= group for group in groups)
        packing.check(tiny, result["expressions"], pairs=result["pairs"], **result["params"])


def test_bad_constraints_are_one_line_errors(tmp_path) -> None:
    out = tmp_path / "out"
    assert_one_line_error(invoke("pack", "tiny", "--out", out, "--apart", "jawOpen,jawOpn"), "did you mean")
    single = invoke("pack", "tiny", "--out", out, "--together", "jawOpen")
    assert single.exit_code == 2 and "'jawOpen' is not a pair of shape names 'A,B'" in single.output
    broken = tmp_path / "constraints.json"
    broken.write_text('{"apart": [["jawOpen"]]}')
    assert_one_line_error(invoke("pack", "tiny", "--out", out, "--constraints", broken), str(broken))
    assert not out.exists()


def test_regions_file_gives_motion_symmetry_to_a_rig_without_regions(tiny, tmp_path) -> None:
    bare = rigs.save(
        replace(tiny, regions={}, landmarks={}, provenance=rigs.Provenance(), truth=None),
        tmp_path / "bare.npz",
    )
    _, without = pack(bare, tmp_path / "without")
    regions = tmp_path / "regions.json"
    regions.write_text(json.dumps({name: indices.tolist() for name, indices in tiny.regions.items()}))
    document, output = pack(bare, tmp_path / "with", "--regions", regions)
    assert "0 motion)" in without and "0 motion)" not in output
    reference, _ = pack("tiny", tmp_path / "reference")
    assert sorted(document["pairs"]) == sorted(reference["pairs"])
    assert document["params"]["regions"] == str(regions)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"upper_lip": [tiny.n_vertices + 5]}))
    assert_one_line_error(invoke("pack", bare, "--out", tmp_path / "bad", "--regions", bad), str(bad))


def cancelling_rig(tiny: rigs.Rig) -> rigs.Rig:
    """``tiny`` with ``jawOpenUndo``, the exact opposite of ``jawOpen``."""
    undo = -tiny.deltas[tiny.index("jawOpen")]
    return replace(tiny, deltas=np.concatenate([tiny.deltas, undo[None]]), names=(*tiny.names, "jawOpenUndo"))


def test_an_expression_holding_shapes_that_cancel_is_warned_about(tiny, tmp_path) -> None:
    path = rigs.save(cancelling_rig(tiny), tmp_path / "undo.npz")
    document, output = pack(path, tmp_path / "out", "--together", "jawOpen,jawOpenUndo")
    holding = next(i for i, e in enumerate(document["expressions"], start=1) if "jawOpen" in e["shapes"])
    warning = next(text for text in document["warnings"] if "jawOpen and jawOpenUndo" in text)
    assert f"expression {holding} holds" in warning and f"warning: {warning}" in output
    plain, _ = pack(rigs.save(tiny, tmp_path / "tiny.npz"), tmp_path / "plain")
    assert plain["warnings"] == []


def test_rigs_info_warns_about_twins_that_cancel(tiny, tmp_path) -> None:
    shift = np.zeros_like(tiny.neutral)
    shift[tiny.neutral[:, 1] < np.median(tiny.neutral[:, 1]), 0] = 0.3  # moves the lower face sideways
    rig = replace(
        tiny,
        deltas=np.concatenate([tiny.deltas, shift[None], -shift[None]]),
        names=(*tiny.names, "jawLeft", "jawRight"),
    )
    path = rigs.save(rig, tmp_path / "jaw.npz")
    summary = json.loads(invoke("rigs", "info", path, "--json").output)
    assert any("jawLeft and jawRight" in message for message in summary["cancelling_twins"])
    table = invoke("rigs", "info", path)
    assert table.exit_code == 0 and "warning: combining jawLeft and jawRight" in flat(table.output)
    assert json.loads(invoke("rigs", "info", "tiny", "--json").output)["cancelling_twins"] == []


def test_a_packing_is_put_in_place_at_once_with_expressions_json_last(tmp_path, monkeypatch) -> None:
    written: list[str] = []
    swapped: list[list[str]] = []
    original_write, original_swap = _outdir.atomic_write, _outdir.swap_folder

    def write(path: Path, data: bytes, **options: bool) -> Path:
        if path.name != MANIFEST_NAME:
            written.append(path.name)
        return original_write(path, data, **options)

    def swap(new: Path, target: Path) -> Path | None:
        assert list(target.iterdir()) == []  # nothing is in place before all is written
        swapped.append(sorted(contents(new)))
        return original_swap(new, target)

    monkeypatch.setattr(_outdir, "atomic_write", write)
    monkeypatch.setattr(_outdir, "swap_folder", swap)
    document, _ = pack("tiny", tmp_path / "out")
    files = [expression["files"]["mesh"] for expression in document["expressions"]]
    assert written[-1] == "expressions.json" and set(files) <= set(written)
    assert swapped == [sorted(contents(tmp_path / "out"))]  # listed and written, then renamed in at once
    listed = json.loads((tmp_path / "out" / MANIFEST_NAME).read_text())["files"]
    assert sorted(listed) == sorted(name for name in contents(tmp_path / "out") if name != MANIFEST_NAME)
