"""Bad inputs to the `harness` command line, each run as a user would run it (a subprocess, a 60 s limit):
malformed OBJ, glTF and ``.target`` rigs, hostile manifests, regions and constraints files, option values
out of their domain, run folders and records that are not what they claim to be, and commits or stores
that cannot be measured.

Every case must end *clear*: a non-zero exit (not 70, the code of a program fault), no traceback, and one
line on stderr naming the file or option at fault. `outcome` tells the other endings apart: ``traceback``,
``hang`` (over the limit), ``silent`` (exit 0) and ``unsafe`` (a file outside the command's input and output
was read into the output, written, or removed).
"""

from __future__ import annotations

import base64
import json
import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

import rigs

#: Seconds a command may take before it counts as a hang.
HANG_SECONDS = 60
#: Exit code of a program fault (``EX_SOFTWARE``): never the answer to a user's bad input.
FAULT_EXIT = 70
ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Ran:
    """One finished (or stopped) command: exit code (None after a hang), stdout, stderr."""

    code: int | None
    stdout: str
    stderr: str


def harness(*arguments: object, cwd: Path) -> Ran:
    """``harness ARGUMENTS`` in a child process in ``cwd`` (this checkout first on the path)."""
    environment = {**os.environ, "PYTHONPATH": str(ROOT), "COLUMNS": "250", "NO_COLOR": "1"}
    command = [sys.executable, "-c", "from harness.cli import main; main()", *map(os.fsdecode, arguments)]
    try:
        done = subprocess.run(
            command, cwd=cwd, env=environment, capture_output=True, text=True, timeout=HANG_SECONDS
        )
    except subprocess.TimeoutExpired as stopped:
        return Ran(None, str(stopped.stdout or ""), str(stopped.stderr or ""))
    return Ran(done.returncode, done.stdout, done.stderr)


#: Lines of a usage error that click prints before its one line saying what is wrong.
USAGE_PREAMBLE = ("Usage: ", "Try '")


def message_lines(stderr: str) -> list[str]:
    """The lines of ``stderr`` that say what went wrong: without click's usage preamble, blank lines and
    the warnings printed on the way (each one line of its own)."""
    return [
        line
        for line in stderr.splitlines()
        if line.strip() and not line.startswith(USAGE_PREAMBLE) and not line.startswith("warning: ")
    ]


def outcome(ran: Ran, fragment: str, safe: bool = True, noted: bool = False) -> str:
    """``clear``, ``traceback``, ``hang``, ``silent`` or ``unsafe`` (see the module's docstring); a
    non-zero exit whose message is not one line naming ``fragment`` counts as ``traceback`` (unclear).
    With ``noted``, the input is one the command recovers from: exit 0 with a note naming ``fragment``
    is clear too."""
    if not safe:
        return "unsafe"
    if ran.code is None:
        return "hang"
    if ran.code == 0:
        return "clear" if noted and fragment in " ".join((ran.stdout + ran.stderr).split()) else "silent"
    lines = message_lines(ran.stderr)
    if ran.code == FAULT_EXIT or "Traceback" in ran.stderr + ran.stdout or len(lines) != 1:
        return "traceback"
    return "clear" if fragment in lines[0] else "traceback"


# == the inputs ============================================================================================
@pytest.fixture(scope="session")
def tiny_folder(tmp_path_factory) -> Path:
    """The generated ``tiny`` rig (600 vertices, 12 shapes) as an OBJ folder."""
    return rigs.save(rigs.generate("tiny"), tmp_path_factory.mktemp("rig") / "tiny")


@pytest.fixture(scope="session")
def tiny_run(tmp_path_factory) -> Path:
    """A finished one-cell run of the ``tiny`` rig (greedy, the delta transfer)."""
    out = tmp_path_factory.mktemp("run") / "run"
    ran = harness(
        "run", "--rigs", "tiny", "--warps", "none", "--solvers", "greedy", "--transfers", "delta",
        "--j-values", "2", "--jobs", "1", "-q", "--out", out, cwd=out.parent,
    )  # fmt: skip
    assert ran.code == 0, ran.stderr
    return out


@dataclass
class Place:
    """Where one case runs: its own folder, with copies of the tiny rig and run made on demand."""

    folder: Path
    tiny_folder: Path
    tiny_run: Path

    def rig(self, name: str = "rig") -> Path:
        return Path(shutil.copytree(self.tiny_folder, self.folder / name))

    def run(self, name: str = "run") -> Path:
        return Path(shutil.copytree(self.tiny_run, self.folder / name))

    def write(self, name: str, content: str | bytes) -> Path:
        path = self.folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
        return path


@dataclass(frozen=True)
class Case:
    """``build(place)`` writes the input and returns the command's arguments and the text its one line must
    hold; ``safe(place)`` (when given) checks, after the command, that nothing outside was touched."""

    name: str
    build: Callable[[Place], tuple[list[object], str]]
    safe: Callable[[Place], bool] | None = None
    gap: str | None = None
    noted: bool = False


CASES: list[Case] = []


def case(
    name: str, safe: Callable[[Place], bool] | None = None, gap: str | None = None, noted: bool = False
) -> Callable:
    """Register the decorated builder; ``gap`` names what the command still lacks (an expected failure)."""

    def register(build: Callable[[Place], tuple[list[object], str]]) -> Callable:
        CASES.append(Case(name, build, safe, gap, noted))
        return build

    return register


def pack(rig: Path, place: Place, *options: object) -> list[object]:
    return ["pack", rig, "--solver", "greedy", "--no-pictures", "--out", place.folder / "out", *options]


def edit_neutral(place: Place, change: Callable[[str], str]) -> Path:
    rig = place.rig()
    neutral = rig / "neutral.obj"
    neutral.write_text(change(neutral.read_text()))
    return rig


def edit_shape(place: Place, change: Callable[[str], str], name: str = "jawOpen") -> Path:
    rig = place.rig()
    shape = rig / f"{name}.obj"
    shape.write_text(change(shape.read_text()))
    return rig


def first_vertex(text: str, replacement: str) -> str:
    start = text.index("\nv ") + 1
    end = text.index("\n", start)
    return text[:start] + replacement + text[end:]


# -- OBJ rigs ----------------------------------------------------------------------------------------------
for label, vertex in [
    ("decimal-comma", "v 0,5 0 0"),
    ("underscore-digits", "v 1_0 0 0"),
    ("fullwidth-digits", "v \uff11 0 0"),
    ("hex-float", "v 0x1p3 0 0"),
    ("double-sign", "v +-1 0 0"),
    ("five-coordinates", "v 1 2 3 4 5"),
    ("minus-huge-exponent", "v -1e400 0 0"),
]:
    case(f"obj/neutral-{label}")(
        lambda place, vertex=vertex: (
            pack(edit_neutral(place, lambda text: first_vertex(text, vertex)), place),
            "neutral.obj",
        )
    )

case("obj/shape-nul-in-face")(
    lambda place: (
        pack(edit_shape(place, lambda text: text.replace("\nf ", "\nf \x00", 1)), place),
        "jawOpen.obj",
    )
)
case("obj/shape-face-too-many-slashes")(
    lambda place: (
        pack(edit_shape(place, lambda text: text.replace("\nf ", "\nf 1/1/1/1 ", 1)), place),
        "jawOpen.obj",
    )
)
case("obj/neutral-texture-index-past-end")(
    lambda place: (
        pack(edit_neutral(place, lambda text: "vt 0 0\n" + text.replace("\nf 1 ", "\nf 1/9 ", 1)), place),
        "neutral.obj",
    )
)
case("obj/neutral-vt-nan")(
    lambda place: (pack(edit_neutral(place, lambda text: "vt nan 0\n" + text), place), "neutral.obj")
)
case("obj/shape-crlf-and-bad-line")(
    lambda place: (
        pack(edit_shape(place, lambda text: text.replace("\n", "\r\n", 50) + "v 1 2\r\n"), place),
        "jawOpen.obj",
    )
)
case("obj/folder-of-only-the-neutral")(lambda place: (pack(_only_neutral(place), place), "rig"))


def _only_neutral(place: Place) -> Path:
    rig = place.rig()
    for path in rig.glob("*.obj"):
        if path.name != "neutral.obj":
            path.unlink()
    return rig


@case("obj/empty-folder")
def _empty_folder(place: Place) -> tuple[list[object], str]:
    (place.folder / "empty").mkdir()
    return pack(place.folder / "empty", place), "empty"


@case("obj/non-utf8-shape-name")
def _non_utf8_name(place: Place) -> tuple[list[object], str]:
    rig = place.rig()
    os.rename(rig / "jawOpen.obj", os.fsencode(rig) + b"/jaw\xffOpen.obj")
    return pack(rig, place), "jaw"


@case("obj/mtllib-outside", noted=True, safe=lambda place: not any((place.folder / "out").rglob("passwd*")))
def _mtllib_outside(place: Place) -> tuple[list[object], str]:
    rig = edit_neutral(place, lambda text: "mtllib ../../../../../../../etc/passwd\n" + text)
    return pack(rig, place), "neutral.obj:1: material library '../../../../../../../etc/passwd' lies outside"


@case("obj/preset-misspelled")
def _preset_misspelled(place: Place) -> tuple[list[object], str]:
    return pack(Path("tinyy"), place), "tinyy"


# -- glTF --------------------------------------------------------------------------------------------------
def gltf(place: Place, targets: list[str], *, uri: str | None = None, extra: dict | None = None) -> Path:
    """A small glTF whose two morph targets are named ``targets``; ``uri`` replaces the embedded buffer."""
    import numpy as np

    neutral = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float32)
    deltas = np.zeros((2, 4, 3), dtype=np.float32)
    deltas[0, 2] = [0, 0, 0.5]
    deltas[1, 3] = [0, 0, 0.5]
    indices = np.array([0, 1, 2, 0, 2, 3], dtype=np.uint32)
    parts = [neutral, deltas[0], deltas[1], indices]
    blob, views = b"", []
    for array in parts:
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": array.nbytes})
        blob += array.tobytes()
    document = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [
            {
                "primitives": [
                    {
                        "attributes": {"POSITION": 0},
                        "indices": 3,
                        "targets": [{"POSITION": 1}, {"POSITION": 2}],
                    }
                ],
                "extras": {"targetNames": targets},
            }
        ],
        "accessors": [{"bufferView": k, "componentType": 5126, "count": 4, "type": "VEC3"} for k in range(3)]
        + [{"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"}],
        "bufferViews": views,
        "buffers": [
            {
                "byteLength": len(blob),
                "uri": uri or "data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
            }
        ],
    }
    document.update(extra or {})
    return place.write("face/face.gltf", json.dumps(document))


def nothing_outside(place: Place) -> bool:
    """No file was written beside the case's folder or above it (the convert destination is ``out``)."""
    return not (place.folder.parent / "escaped.obj").exists() and not (place.folder / "escaped.obj").exists()


for label, names in [
    ("name-dotdot", ["../../escaped", "smile"]),
    ("name-absolute", [None, "smile"]),
    ("name-with-slash", ["a/b", "smile"]),
    ("name-nul", ["jaw\x00Open", "smile"]),
    ("names-duplicated-up-to-case", ["Smile", "smile"]),
]:

    def _convert(place: Place, names=names) -> tuple[list[object], str]:
        resolved = [str(place.folder.parent / "escaped") if name is None else name for name in names]
        return ["rigs", "convert", gltf(place, resolved), place.folder / "out"], "blendshape name"

    case(f"gltf/convert-target-{label}", safe=nothing_outside)(_convert)

case("gltf/data-uri-not-base64")(
    lambda place: (
        ["rigs", "info", gltf(place, ["a", "b"], uri="data:application/octet-stream;base64,@@@@")],
        "face.gltf",
    )
)
case("gltf/uri-percent-dotdot-slash")(
    lambda place: (["rigs", "info", gltf(place, ["a", "b"], uri="..%2fsecret.bin")], "face.gltf")
)
case("gltf/target-names-not-strings")(lambda place: (["rigs", "info", gltf(place, [1, 2])], "face.gltf"))
case("gltf/target-names-too-many")(
    lambda place: (["rigs", "info", gltf(place, ["a", "b", "c"])], "face.gltf")
)


@case("glb/json-chunk-length-lies")
def _glb_lies(place: Place) -> tuple[list[object], str]:
    import struct

    body = json.dumps({"asset": {"version": "2.0"}}).encode().ljust(32, b" ")
    chunk = struct.pack("<II", 10**6, 0x4E4F534A) + body
    return [
        "rigs",
        "info",
        place.write("face.glb", struct.pack("<III", 0x46546C67, 2, 12 + len(chunk)) + chunk),
    ], ("face.glb")


# -- .target sets ------------------------------------------------------------------------------------------
def target_set(place: Place, content: str, manifest: object | None = None) -> Path:
    rig = place.rig("set")
    root = place.folder / "targets"
    root.mkdir()
    (root / "base.obj").write_text((rig / "neutral.obj").read_text())
    (root / "bad.target").write_text(content)
    (root / "ok.target").write_text("1 0 0 1\n")
    if manifest is not None:
        (root / "set.json").write_text(json.dumps(manifest))
        return root / "set.json"
    return root


case("target/underscore-vertex-id")(
    lambda place: (pack(target_set(place, "1_0 0 0 1\n"), place), "bad.target")
)
case("target/fullwidth-vertex-id")(
    lambda place: (pack(target_set(place, "\uff11 0 0 1\n"), place), "bad.target")
)
case("target/decimal-comma")(lambda place: (pack(target_set(place, "3 0,5 0 1\n"), place), "bad.target"))
case("target/manifest-targets-not-list")(
    lambda place: (
        pack(target_set(place, "3 0 0 1\n", {"base": "base.obj", "targets": 5}), place),
        "set.json",
    )
)

# -- rig.json ----------------------------------------------------------------------------------------------


def manifest(place: Place, document: object) -> Path:
    rig = place.rig()
    (rig / "rig.json").write_text(json.dumps(document))
    return rig


case("rig.json/shapes-listed-twice")(
    lambda place: (pack(manifest(place, {"shapes": ["jawOpen", "jawOpen"]}), place), "rig.json")
)
case("rig.json/shape-with-extension")(
    lambda place: (pack(manifest(place, {"shapes": ["jawOpen.obj"]}), place), "rig.json")
)
case("rig.json/region-empty-name")(
    lambda place: (pack(manifest(place, {"shapes": ["jawOpen"], "regions": {"": [1, 2]}}), place), "rig.json")
)
case("rig.json/million-missing-names")(
    lambda place: (pack(manifest(place, {"shapes": [f"s{k}" for k in range(1_000_000)]}), place), ".obj")
)

# -- --regions and --constraints ---------------------------------------------------------------------------
for label, document, fragment in [
    ("regions-list", [1, 2, 3], "regions.json"),
    ("regions-string-indices", {"lip": "1,2,3"}, "regions.json"),
    ("regions-negative", {"lip": [-5, 1]}, "regions.json"),
    ("regions-huge-index", {"lip": [10**10]}, "regions.json"),
    ("regions-empty-region", {"lip": []}, "regions.json"),
    ("regions-none", {}, "regions.json"),
]:
    case(f"options/{label}")(
        lambda place, document=document, fragment=fragment: (
            pack(place.rig(), place, "--regions", place.write("regions.json", json.dumps(document))),
            fragment,
        )
    )

case("options/regions-obj-of-another-mesh")(
    lambda place: (
        pack(
            place.rig(),
            place,
            "--regions",
            place.write("regions.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\ng a\nf 1 2 3\n"),
        ),
        "regions.obj",
    )
)

for label, document in [
    ("constraints-unknown-shape", {"together": [["jawOpen", "noSuchShape"]]}),
    ("constraints-wrong-type", {"together": "jawOpen"}),
    ("constraints-self-pair", {"apart": [["jawOpen", "jawOpen"]]}),
    (
        "constraints-contradiction",
        {"together": [["jawOpen", "eyeBlink_L"]], "apart": [["eyeBlink_L", "jawOpen"]]},
    ),
    ("constraints-misspelled-key", {"togther": [["jawOpen", "eyeBlink_L"]]}),
    ("constraints-three-names", {"together": [["jawOpen", "eyeBlink_L", "eyeBlink_R"]]}),
]:
    case(f"options/{label}")(
        lambda place, document=document: (
            pack(place.rig(), place, "--constraints", place.write("rules.json", json.dumps(document))),
            "rules.json",
        )
    )

case("options/constraints-empty-file")(
    lambda place: (pack(place.rig(), place, "--constraints", place.write("rules.json", "")), "rules.json")
)
case("options/together-one-name")(
    lambda place: (pack(place.rig(), place, "--together", "jawOpen"), "--together")
)
case("options/exclude-unknown")(
    lambda place: (pack(place.rig(), place, "--exclude", "noSuchShape"), "noSuchShape")
)
case("options/reject-malformed")(lambda place: (pack(place.rig(), place, "--reject", "abc"), "--reject"))
case("options/reject-unknown-shape")(
    lambda place: (pack(place.rig(), place, "--reject", "1:noSuchShape"), "noSuchShape")
)

# -- option values -----------------------------------------------------------------------------------------
for label, options, fragment in [
    ("mu-nan", ["--mu", "nan"], "--mu"),
    ("mu-inf", ["--mu", "inf"], "--mu"),
    ("alpha-nan", ["--alpha", "nan"], "--alpha"),
    ("beta-inf", ["--beta", "inf"], "--beta"),
    ("time-limit-zero", ["--time-limit", "0"], "--time-limit"),
    ("time-limit-negative", ["--time-limit", "-5s"], "--time-limit"),
    ("timeout-1e309", ["--timeout", "1e309"], "--timeout"),
    ("timeout-nan", ["--timeout", "nan"], "--timeout"),
    ("seed-past-64-bits", ["--seed", str(2**70)], "--seed"),
    ("solver-bad-setting", ["--solver", "cpsat[workers=abc]"], "workers"),
    ("solver-unclosed-bracket", ["--solver", "cpsat[workers=2"], "--solver"),
]:
    case(f"pack/{label}")(
        lambda place, options=options, fragment=fragment: (pack(place.rig(), place, *options), fragment)
    )


@case("pack/target-other-mesh")
def _target_other_mesh(place: Place) -> tuple[list[object], str]:
    other = place.write("other.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    return pack(place.rig(), place, "--target", other), "other.obj"


@case("pack/out-is-a-file", safe=lambda place: (place.folder / "out").read_text() == "keep")
def _out_is_file(place: Place) -> tuple[list[object], str]:
    place.write("out", "keep")
    return pack(place.rig(), place), "out"


def run(place: Place, *options: object) -> list[object]:
    return [
        "run", "--rigs", "tiny", "--warps", "none", "--transfers", "delta", "--j-values", "2", "--jobs", "1",
        "-q", "--out", place.folder / "out", *options,
    ]  # fmt: skip


for label, options, fragment in [
    ("solvers-bad-setting", ["--solvers", "cpsat[workers=abc]"], "workers"),
    ("solvers-empty", ["--solvers", ""], "--solvers"),
    ("transfers-unknown", ["--solvers", "greedy", "--transfers", "noSuchTransfer"], "noSuchTransfer"),
    ("transfer-negative-beta", ["--solvers", "greedy", "--transfers", "ebfr[beta=-1]"], "beta"),
    ("j-values-zero", ["--solvers", "greedy", "--j-values", "0"], "--j-values"),
    ("seeds-reversed-range", ["--solvers", "greedy", "--seeds", "5-2"], "--seeds"),
    ("mu-list-with-nan", ["--solvers", "greedy", "--mu", "0.3,nan"], "'--mu': expected a finite number"),
    ("seeds-ten-billion", ["--solvers", "greedy", "--seeds", "0-10000000000"], "--seeds"),
    ("seeds-past-64-bits", ["--solvers", "greedy", "--seeds", str(2**63)], "seeds go up to 2**63 - 1"),
    ("solver-seed-past-32-bits", ["--solvers", "greedy", "--solver-seed", str(2**40)], "--solver-seed"),
    ("timeout-zero", ["--solvers", "greedy", "--timeout", "0"], "--timeout"),
    ("rigs-empty", ["--solvers", "greedy", "--rigs", ","], "--rigs"),
    ("warps-unknown", ["--solvers", "greedy", "--warps", "noSuchWarp"], "noSuchWarp"),
    (
        "dask-bad-scheduler",
        ["--solvers", "greedy", "--executor", "dask", "--scheduler", "nonsense"],
        "nonsense",
    ),
]:
    case(f"run/{label}")(lambda place, options=options, fragment=fragment: (run(place, *options), fragment))


@case("run/out-is-a-file", safe=lambda place: (place.folder / "out").read_text() == "keep")
def _run_out_file(place: Place) -> tuple[list[object], str]:
    place.write("out", "keep")
    return run(place, "--solvers", "greedy"), "out"


# -- run folders: resume, show, report, compare, instances -------------------------------------------------
def broken_run(place: Place, change: Callable[[Path], None]) -> Path:
    folder = place.run()
    change(folder)
    return folder


def run_json_list(folder: Path) -> None:
    (folder / "run.json").write_text("[1, 2, 3]")


def records_as_csv(folder: Path) -> None:
    part = next((folder / "records").glob("*.parquet"))
    part.write_text("cell,status\n1,ok\n")


def no_records(folder: Path) -> None:
    shutil.rmtree(folder / "records")
    (folder / "records").mkdir()


for command, label, change, fragment in [
    ("resume", "run-json-list", run_json_list, "run.json"),
    ("resume", "records-csv", records_as_csv, ".parquet: unreadable"),  # set aside, its cell runs again
    ("show", "run-json-list", run_json_list, "run.json"),
    ("show", "records-csv", records_as_csv, ".parquet"),
    ("report", "run-json-list", run_json_list, "run.json"),
    ("report", "records-csv", records_as_csv, ".parquet"),
    ("report", "no-records", no_records, "records"),
    ("instances", "run-json-list", run_json_list, "run.json"),
]:

    def _build(place: Place, command=command, change=change, fragment=fragment) -> tuple[list[object], str]:
        folder = broken_run(place, change)
        arguments = {
            "resume": ["run", "--resume", folder, "-q"],
            "show": ["show", folder],
            "report": ["report", folder],
            "instances": ["instances", "export", folder, "--out", place.folder / "mps"],
        }[command]
        return arguments, fragment

    case(f"{command}/{label}", noted=(command, label) == ("resume", "records-csv"))(_build)


case("report/empty-folder")(lambda place: (["report", place.folder], str(place.folder.name)))
case("show/a-file")(lambda place: (["show", place.write("notes.txt", "hello")], "notes.txt"))
case("instances/unknown-rig")(
    lambda place: (
        ["instances", "export", place.run(), "--rig", "noSuchRig", "--out", place.folder / "mps"],
        "noSuchRig",
    )
)
case("compare/against-itself-without-records")(
    lambda place: (["compare", broken_run(place, no_records), place.folder / "run"], "records")
)
case("compare/run-with-benchmark-json")(
    lambda place: (["compare", place.run(), place.write("bench.json", '{"benchmarks": []}')], "bench.json")
)
case("compare/benchmark-json-list")(
    lambda place: (["compare", place.write("a.json", "[]"), place.write("b.json", "[]")], "a.json")
)
case("compare/commits-outside-a-repository")(
    lambda place: (["compare", "--commits", "HEAD~1", "HEAD"], "not inside a git repository")
)
case("compare/commits-and-folders")(
    lambda place: (["compare", place.run("a"), place.run("b"), "--commits", "HEAD", "HEAD"], "not both")
)
case("compare/commits-unknown-suite")(
    lambda place: (["compare", "--commits", "HEAD", "HEAD", "--suite", "nosuch"], "nosuch")
)
case("track/steps-outside-a-repository")(lambda place: (["track", "steps"], "not inside a git repository"))
case("track/store-of-an-unknown-file-system")(
    lambda place: (["track", "steps", "--store", "nosuchfs://bucket/track"], "nosuchfs")
)

# -- rigs info / convert -----------------------------------------------------------------------------------
case("rigs/info-text-file")(lambda place: (["rigs", "info", place.write("notes.txt", "hello")], "notes.txt"))
case("rigs/convert-unknown-extension")(
    lambda place: (["rigs", "convert", place.rig(), place.folder / "rig.xyz"], "rig.xyz")
)


@case(
    "rigs/convert-over-a-users-file", safe=lambda place: (place.folder / "mine.npz").read_bytes() == b"keep"
)
def _convert_over(place: Place) -> tuple[list[object], str]:
    place.write("mine.npz", "keep")
    return ["rigs", "convert", place.rig(), place.folder / "mine.npz"], "mine.npz"


@case(
    "rigs/convert-into-a-users-folder",
    safe=lambda place: (place.folder / "dest" / "jawOpen.obj").read_bytes() == b"keep",
)
def _convert_into(place: Place) -> tuple[list[object], str]:
    place.write("dest/jawOpen.obj", "keep")
    return ["rigs", "convert", place.rig(), place.folder / "dest"], "dest"


@case("rigs/convert-onto-itself")
def _convert_onto_itself(place: Place) -> tuple[list[object], str]:
    rig = place.rig()
    return ["rigs", "convert", rig, rig], "rig"


# == the test ==============================================================================================
def attack(case: Case, tmp_path: Path, tiny_folder: Path, tiny_run: Path) -> tuple[str, Ran]:
    """Build the case in ``tmp_path``, run it, and classify the ending."""
    place = Place(tmp_path / "case", tiny_folder, tiny_run)
    place.folder.mkdir()
    arguments, fragment = case.build(place)
    ran = harness(*arguments, cwd=place.folder)
    return outcome(ran, fragment, case.safe(place) if case.safe else True, case.noted), ran


@pytest.mark.parametrize(
    "case",
    [
        pytest.param(c, id=c.name, marks=[pytest.mark.xfail(reason=c.gap, strict=True)] if c.gap else [])
        for c in CASES
    ],
)
def test_a_bad_input_ends_in_one_clear_line(
    case: Case, tmp_path: Path, tiny_folder: Path, tiny_run: Path
) -> None:
    ending, ran = attack(case, tmp_path, tiny_folder, tiny_run)
    assert ending == "clear", f"{ending}: exit {ran.code}\n{ran.stderr[-3000:]}\n{ran.stdout[-1500:]}"
