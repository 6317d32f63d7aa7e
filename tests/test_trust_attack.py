"""A second attack on the `harness` command line, on what keeps a benchmark honest and on the surfaces added
since the first (`test_fresh_attack`): forged manifests and copied outputs, part files and run files that
are not what they claim, plugin settings and numbers past their bounds, solver and rig-format plugins that
fail in every way a third party's may, files of other formats (glTF, regions, benchmark JSON, accepted
slow-downs), and commits, stores and suites that cannot be measured (``harness compare --commits``,
``harness track``). Each case runs as a user would run it, in a subprocess with a 60 s limit, and must end
*clear* as `test_fresh_attack.outcome` says: a non-zero exit that is not 70, no traceback, one line naming
the file or option (or, for an input the command recovers from, exit 0 with a note naming it); never a
hang, a silent exit 0, or a file outside the command's output touched.
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

import numpy as np
import pytest

import rigs
from tests.plugin_distribution import write_distribution
from tests.rigs.format_plugins import ENTRY_POINTS as FORMAT_ENTRY_POINTS
from tests.test_fresh_attack import HANG_SECONDS, Ran, outcome

ROOT = Path(__file__).resolve().parents[1]

#: The cheating solvers' entry points (`tests/harness/cheating_solvers.py`).
SOLVER_ENTRY_POINTS = """[harness.solvers]
check-breaker = cheating_solvers:CheckBreaker
forking = cheating_solvers:ForkingSolver
silent = cheating_solvers:SilentAvailability
sleeping = cheating_solvers:SleepingSolver
exiting = cheating_solvers:ExitingSolver
"""


def harness(*arguments: object, cwd: Path, site: Path | None = None) -> Ran:
    """``harness ARGUMENTS`` in a child process in ``cwd``, with the plugins of ``site`` installed."""
    path = os.pathsep.join([str(ROOT), *([str(site)] if site else [])])
    environment = {**os.environ, "PYTHONPATH": path, "COLUMNS": "250", "NO_COLOR": "1"}
    command = [
        sys.executable,
        "-P",
        "-c",
        "from harness.cli import main; main()",
        *map(os.fsdecode, arguments),
    ]
    try:
        done = subprocess.run(
            command, cwd=cwd, env=environment, capture_output=True, text=True, timeout=HANG_SECONDS
        )
    except subprocess.TimeoutExpired as stopped:
        return Ran(None, str(stopped.stdout or ""), str(stopped.stderr or ""))
    return Ran(done.returncode, done.stdout, done.stderr)


# == where a case runs ======================================================================================
@dataclass
class Place:
    """A case's own folder, with what it may copy: the tiny rig and a finished run of it (and one of
    another setting), a folder of plugins and a clone of this repository with branches to compare."""

    folder: Path
    shared: dict[str, Path]

    def rig(self, name: str = "rig") -> Path:
        return Path(shutil.copytree(self.shared["tiny"], self.folder / name))

    def run(self, name: str = "run", which: str = "run") -> Path:
        return Path(shutil.copytree(self.shared[which], self.folder / name))

    def write(self, name: str, content: str | bytes) -> Path:
        path = self.folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
        return path

    @property
    def site(self) -> Path:
        return self.shared["site"]

    @property
    def clone(self) -> Path:
        return self.shared["clone"]


@dataclass(frozen=True)
class Case:
    """``build(place)`` prepares the input and returns the arguments, the text the one line must hold and
    where to run (by default the case's folder); ``safe(place)`` checks afterwards that nothing outside
    the output was touched; ``noted`` accepts exit 0 with a note naming the text; ``site`` installs the
    plugins."""

    name: str
    build: Callable[[Place], tuple[list[object], str] | tuple[list[object], str, Path]]
    safe: Callable[[Place], bool] | None = None
    noted: bool = False
    site: bool = False


CASES: list[Case] = []


def case(name: str, *, safe=None, noted: bool = False, site: bool = False) -> Callable:
    def register(build: Callable) -> Callable:
        CASES.append(Case(name, build, safe, noted, site))
        return build

    return register


def add(name: str, arguments: Callable[[Place], list[object]], fragment: str, **options) -> None:
    """A case whose arguments need only the place, the fragment known in advance."""
    case(name, **options)(lambda place: (arguments(place), fragment))


def run_options(place: Place, *options: object) -> list[object]:
    return [
        "run", "--rigs", "tiny", "--warps", "none", "--transfers", "delta", "--j-values", "2", "--jobs", "1",
        "-q", "--out", place.folder / "out", *options,
    ]  # fmt: skip


def pack(rig: object, place: Place, *options: object) -> list[object]:
    return ["pack", rig, "--solver", "greedy", "--no-pictures", "--out", place.folder / "out", *options]


def export(rig: object, place: Place, *options: object) -> list[object]:
    return ["instances", "export", rig, "--out", place.folder / "mps", *options]


# == trust: forged and copied outputs =======================================================================
def _session(place: Place) -> Path:
    """A session folder ``out`` written by ``harness pack``, with the user's ``notes.txt`` in it."""
    ran = harness(*pack("tiny", place), cwd=place.folder)
    assert ran.code == 0, ran.stderr
    place.write("out/notes.txt", "my notes\n")
    return place.folder / "out"


def _notes_kept(place: Place) -> bool:
    return (place.folder / "out" / "notes.txt").read_text() == "my notes\n"


def _forge(place: Place, entry: Callable[[Path], dict], version: int = 2) -> None:
    out = _session(place)
    manifest = out / ".harness-manifest.json"
    document = json.loads(manifest.read_text())
    document["version"] = version
    document["files"]["notes.txt"] = entry(out / "notes.txt")
    manifest.write_text(json.dumps(document))


def _sha(path: Path) -> str:
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


for label, entry, version in [
    ("right-hash", lambda path: {"kind": "pack", "sha256": _sha(path)}, 2),
    ("right-hash-version-1", lambda path: {"kind": "pack", "sha256": _sha(path)}, 1),
    ("right-hash-wrong-inode", lambda path: {"kind": "pack", "sha256": _sha(path), "inode": 1}, 2),
    ("inode-not-a-number", lambda path: {"kind": "pack", "sha256": _sha(path), "inode": "x"}, 2),
    ("version-3", lambda path: {"kind": "pack", "sha256": _sha(path)}, 3),
]:

    def _forged(place: Place, entry=entry, version=version) -> tuple[list[object], str]:
        _forge(place, entry, version)
        return pack("tiny", place, "--force"), "out"

    case(f"trust/pack-force-manifest-{label}", safe=_notes_kept)(_forged)


@case(
    "trust/pack-force-into-a-copied-session",
    safe=lambda place: (place.folder / "copy" / "neutral.obj").exists(),
)
def _copied_session(place: Place) -> tuple[list[object], str]:
    out = _session(place)
    (out / "notes.txt").unlink()
    shutil.copytree(out, place.folder / "copy")
    return [
        "pack",
        "tiny",
        "--solver",
        "greedy",
        "--no-pictures",
        "--out",
        place.folder / "copy",
        "--force",
    ], "copy"


@case("trust/session-manifest-nested-deep", safe=_notes_kept)
def _deep_manifest(place: Place) -> tuple[list[object], str]:
    out = _session(place)
    (out / ".harness-manifest.json").write_text("[" * 100_000 + "]" * 100_000)
    return pack("tiny", place, "--force"), ".harness-manifest.json"


@case("trust/run-force-over-a-copied-run", safe=lambda place: (place.folder / "out" / "run.json").exists())
def _copied_run(place: Place) -> tuple[list[object], str]:
    place.run("out")
    return run_options(place, "--solvers", "greedy", "--force"), "out"


@case("trust/check-breaker-is-invalid", noted=True, site=True)
def _check_breaker(place: Place) -> tuple[list[object], str]:
    return run_options(place, "--solvers", "check-breaker"), "invalid 1"


def _foreign_part(place: Place) -> Path:
    """A run with a part file copied in from a run of another ``--mu``."""
    run = place.run()
    (part,) = (place.shared["other"] / "records").glob("*.parquet")
    shutil.copy(part, run / "records" / part.name)
    return run


for command in ("show", "report", "compare"):

    def _foreign(place: Place, command=command) -> tuple[list[object], str]:
        run = _foreign_part(place)
        arguments = {"show": ["show", run], "report": ["report", run], "compare": ["compare", run, run]}
        return arguments[command], "not a cell of this run's grid"

    case(f"trust/{command}-part-copied-from-another-run")(_foreign)


@case("trust/show-part-renamed-to-another-cell")
def _renamed_part(place: Place) -> tuple[list[object], str]:
    run = place.run()
    (part,) = (run / "records").glob("*.parquet")
    part.rename(part.with_name("0123456789abcdef.parquet"))
    return ["show", run], "0123456789abcdef.parquet"


@case("trust/resume-plugin-rig-file-changed", site=True)
def _plugin_rig_changed(place: Place) -> tuple[list[object], str]:
    rig = place.folder / "plug"
    rig.mkdir()
    (rig / "face.side").write_text("x")
    (rig / "offset.txt").write_text("0.5")
    arguments = ["run", "--rigs", rig / "face.side", "--warps", "none", "--solvers", "greedy", "--transfers",
                 "delta", "--j-values", "2", "--jobs", "1", "-q", "--out", place.folder / "out"]  # fmt: skip
    ran = harness(*arguments, cwd=place.folder, site=place.site)
    assert ran.code == 0, ran.stderr
    (rig / "offset.txt").write_text("0.25")
    return ["run", "--resume", place.folder / "out", "-q"], "offset.txt changed"


# == settings ===============================================================================================
for label, request, fragment in [
    ("cpsat-workers-on", "cpsat[workers=on]", "workers must be an integer"),
    ("cpsat-workers-huge", "cpsat[workers=99999999999999999999]", "workers must be an integer"),
    ("cpsat-workers-zero", "cpsat[workers=0]", "workers must be an integer"),
    ("cpsat-workers-negative", "cpsat[workers=-2]", "workers must be an integer"),
    ("cpsat-workers-fraction", "cpsat[workers=1.5]", "workers must be an integer"),
    ("cpsat-unknown-setting", "cpsat[threads=2]", "cpsat has no setting 'threads'"),
    ("highs-presolve-number", "highs[presolve=2]", "presolve must be on or off"),
    ("highs-presolve-word", "highs[presolve=maybe]", "presolve must be on or off"),
    ("highs-effort-above-one", "highs[mip_heuristic_effort=2]", "mip_heuristic_effort must be a number"),
    ("highs-effort-nan", "highs[mip_heuristic_effort=nan]", "mip_heuristic_effort must be a number"),
    ("overlap-one", "greedy-overlap[overlap=1]", "overlap must be a number in [0, 1)"),
    ("overlap-negative", "greedy-overlap[overlap=-0.1]", "overlap must be a number in [0, 1)"),
    ("cbc-unknown-binary", "cbc-pulp[cbc=gurobi]", "cbc must be one of"),
    ("greedy-takes-none", "greedy[depth=2]", "greedy"),
    ("setting-given-twice", "highs[presolve=on,presolve=off]", "given twice"),
    ("setting-without-value", "highs[presolve]", "--solvers"),
]:
    add(
        f"settings/run-{label}",
        lambda place, request=request: run_options(place, "--solvers", request),
        fragment,
    )

for label, request, fragment in [
    ("cpsat-workers-on", "cpsat[workers=on]", "workers must be an integer"),
    ("highs-unknown", "highs[threads=4]", "highs has no setting 'threads'"),
    ("two-settings", "cpsat[workers=1,2]", "--solver"),
]:
    add(
        f"settings/pack-{label}",
        lambda place, request=request: (
            pack("tiny", place)[:2] + ["--solver", request, "--no-pictures", "--out", place.folder / "out"]
        ),
        fragment,
    )
    add(
        f"settings/export-{label}",
        lambda place, request=request: export("tiny", place, "--solver", request),
        fragment,
    )

for label, request, fragment in [
    ("ebfr-beta-word", "ebfr[beta=abc]", "beta"),
    ("ebfr-unknown", "ebfr[nonsense=1]", "nonsense"),
    ("plbs-no-patches", "plbs[n_patches=0]", "n_patches"),
    ("dt-align-number", "dt[align=3]", "align"),
]:
    add(
        f"settings/transfers-{label}",
        lambda place, request=request: run_options(place, "--solvers", "greedy", "--transfers", request),
        fragment,
    )


# == numbers ================================================================================================
HUGE = str(10**12)
for label, options, fragment in [
    ("seeds-open-range", ["--seeds", "0-"], "--seeds"),
    ("seeds-negative", ["--seeds", "-1"], "--seeds"),
    ("seeds-three-parts", ["--seeds", "1-2-3"], "--seeds"),
    ("seeds-words", ["--seeds", "a-b"], "--seeds"),
    ("seeds-past-64-bits-range", ["--seeds", "0-99999999999999999999"], "--seeds"),
    ("seeds-only-commas", ["--seeds", ",,"], "--seeds"),
    ("permutations-huge", ["--permutations", HUGE], "--permutations"),
    ("permutations-zero", ["--permutations", "0"], "--permutations"),
    ("repetitions-huge", ["--repetitions", HUGE], "--repetitions"),
    ("repetitions-zero", ["--repetitions", "0"], "--repetitions"),
    ("jobs-huge", ["--jobs", HUGE], "--jobs"),
    ("jobs-zero", ["--jobs", "0"], "--jobs"),
    ("jmax-huge", ["--jmax", str(10**30)], "--jmax"),
    ("jmax-float", ["--jmax", "1e30"], "--jmax"),
    ("jmax-zero", ["--jmax", "0"], "--jmax"),
    ("j-values-huge", ["--j-values", f"2,{10**30}"], "--j-values"),
    ("cap-huge", ["--cap", str(10**30)], "--cap"),
    ("cap-zero", ["--cap", "0"], "--cap"),
    ("scan-seed-past-64-bits", ["--scan-seed", str(2**63)], "--scan-seed"),
    ("scan-seed-float", ["--scan-seed", "1e30"], "--scan-seed"),
    ("scan-seed-negative", ["--scan-seed", "-1"], "--scan-seed"),
    ("solver-seed-past-31-bits", ["--solver-seed", str(2**31)], "--solver-seed"),
    ("time-limit-centuries", ["--time-limit", "999999999h"], "--time-limit"),
    ("timeout-exponent", ["--timeout", "1e400"], "--timeout"),
    ("worker-wait-zero", ["--worker-wait", "0"], "--worker-wait"),
    ("grid-of-ten-million", ["--seeds", "0-9999", "--repetitions", "1000"], "the grid has"),
    ("mu-zero", ["--mu", "0"], "mu"),
    ("alpha-above-one", ["--alpha", "1.5"], "alpha"),
]:
    add(
        f"numbers/run-{label}",
        lambda place, options=options: run_options(place, "--solvers", "greedy", *options),
        fragment,
    )

for label, options, fragment in [
    ("jmax-huge", ["--jmax", str(10**30)], "--jmax"),
    ("cap-huge", ["--cap", str(10**30)], "--cap"),
    ("seed-past-31-bits", ["--seed", str(2**31)], "--seed"),
    ("time-limit-words", ["--time-limit", "fast"], "--time-limit"),
]:
    add(f"numbers/pack-{label}", lambda place, options=options: pack("tiny", place, *options), fragment)
    add(f"numbers/export-{label}", lambda place, options=options: export("tiny", place, *options), fragment)

for label, arguments, fragment in [
    ("rigs-info-seed-past-64-bits", ["rigs", "info", "tiny", "--seed", str(2**64)], "--seed"),
    ("rigs-convert-seed-negative", ["rigs", "convert", "tiny", "x.npz", "--seed", "-1"], "--seed"),
]:
    add(f"numbers/{label}", lambda place, arguments=arguments: arguments, fragment)


# == plugins that fail ======================================================================================
for label, name, fragment in [
    ("claims-raises", "plug.xyz", "rig format plugin 'claims-raise'"),
    ("reader-raises", "r.rai", "rig format plugin 'raising'"),
    ("reader-returns-a-dict", "d.dic", "rig format plugin 'dict'"),
    ("reader-skips-validation", "u.unc", "rig format plugin 'unchecked'"),
]:
    for command in ("info", "pack", "run"):

        def _format(place: Place, name=name, fragment=fragment, command=command) -> tuple[list[object], str]:
            path = place.write(name, "x")
            arguments = {
                "info": ["rigs", "info", path],
                "pack": pack(path, place),
                "run": [
                    "run",
                    "--rigs",
                    path,
                    "--warps",
                    "none",
                    "--solvers",
                    "greedy",
                    "--transfers",
                    "delta",
                    "-q",
                    "--out",
                    place.folder / "out",
                ],  # fmt: skip
            }[command]
            return arguments, fragment

        case(f"plugins/format-{label}-{command}", site=True)(_format)


@case("plugins/format-claims-raises-on-an-empty-folder", site=True)
def _empty_folder(place: Place) -> tuple[list[object], str]:
    (place.folder / "empty").mkdir()
    return pack(place.folder / "empty", place), "empty"


@case("plugins/format-read-only-plugin-as-output", site=True)
def _read_only(place: Place) -> tuple[list[object], str]:
    return ["rigs", "convert", "tiny", place.folder / "out.rai"], "out.rai"


for label, arguments, fragment, noted in [
    (
        "pack-forking",
        lambda place: (
            pack("tiny", place)[:2] + ["--solver", "forking", "--no-pictures", "--out", place.folder / "out"]
        ),
        "solver forking failed on expression 1",
        False,
    ),
    ("run-forking", lambda place: run_options(place, "--solvers", "forking"), "error 1", True),
    (
        "export-forking",
        lambda place: export("tiny", place, "--solver", "forking"),
        "reference solver forking failed",
        False,
    ),
    (
        "export-exiting",
        lambda place: export("tiny", place, "--solver", "exiting"),
        "it called sys.exit(0)",
        False,
    ),
    (
        "export-sleeping-past-its-limit",
        lambda place: export("tiny", place, "--solver", "sleeping", "--time-limit", "1s"),
        "=unkn=",
        True,
    ),
    (
        "pack-exiting",
        lambda place: (
            pack("tiny", place)[:2] + ["--solver", "exiting", "--no-pictures", "--out", place.folder / "out"]
        ),
        "sys.exit(0)",
        False,
    ),
    ("list-silent-availability", lambda place: ["list"], "did not answer within", True),
    (
        "run-silent-availability",
        lambda place: run_options(place, "--solvers", "silent"),
        "did not answer within",
        True,
    ),
]:
    add(f"plugins/{label}", arguments, fragment, noted=noted, site=True)


# == run files, records and benchmark files that are not what they claim ====================================
def _edit_run(place: Place, change: Callable[[dict], object]) -> Path:
    run = place.run()
    document = json.loads((run / "run.json").read_text())
    changed = change(document)
    text = changed if isinstance(changed, str) else json.dumps(document)
    (run / "run.json").write_text(text)
    return run


def _set(path: str, value: object) -> Callable[[dict], None]:
    def change(document: dict) -> None:
        *parents, key = path.split(".")
        target = document
        for parent in parents:
            target = target[parent]
        target[key] = value

    return change


def _without(path: str) -> Callable[[dict], None]:
    def change(document: dict) -> None:
        *parents, key = path.split(".")
        for parent in parents:
            document = document[parent]
        del document[key]

    return change


RUN_FILES = [
    ("config-mu-words", _set("config.mu", ["abc"]), "config.mu"),
    ("config-rigs-number", _set("config.rigs", 5), "config.rigs"),
    ("config-time-limit-word", _set("config.time_limit", "fast"), "config.time_limit"),
    ("config-unknown-key", _set("config.nonsense", 1), "nonsense"),
    ("config-regions-nested", _set("config.regions", {"lip": [[1, 2]]}), "config.regions"),
    ("config-missing-rigs", _without("config.rigs"), "config lacks rigs"),
    ("git-number", _set("git", 5), "git"),
    ("no-state", _without("state"), "state"),
    ("state-unknown", _set("state", "sleeping"), "state"),
    ("format-text", _set("format", "2"), "format"),
    ("versions-solvers-number", _set("versions.solvers", 5), "versions"),
    ("command-number", _set("command", 5), "command"),
    ("nested-deep", lambda document: "[" * 100_000 + "]" * 100_000, "nested too deeply"),
    ("null", lambda document: "null", "run.json"),
    ("config-seed-huge", _set("config.seed", [2**70]), "run.json"),
]
for label, change, fragment in RUN_FILES:
    for command in ("show", "report", "compare", "instances", "resume"):

        def _run_file(
            place: Place, change=change, fragment=fragment, command=command
        ) -> tuple[list[object], str]:
            run = _edit_run(place, change)
            arguments = {
                "show": ["show", run],
                "report": ["report", run],
                "compare": ["compare", place.run("other-copy"), run],
                "instances": export(run, place),
                "resume": ["run", "--resume", run, "-q"],
            }[command]
            return arguments, fragment

        if command in ("show", "instances") or label == "config-mu-words":
            case(f"records/run-json-{label}-{command}")(_run_file)


@case("records/part-is-a-folder")
def _part_folder(place: Place) -> tuple[list[object], str]:
    run = place.run()
    (run / "records" / "0123456789abcdef.parquet").mkdir()
    return ["show", run], "0123456789abcdef.parquet"


@case("records/part-links-outside", safe=lambda place: True)
def _part_link(place: Place) -> tuple[list[object], str]:
    run = place.run()
    (run / "records" / "0123456789abcdef.parquet").symlink_to("/etc/passwd")
    return ["show", run], "0123456789abcdef.parquet"


@case("records/records-is-a-file")
def _records_file(place: Place) -> tuple[list[object], str]:
    run = place.run()
    shutil.rmtree(run / "records")
    (run / "records").write_text("nothing")
    return ["show", run], "records"


for label, document, fragment in [
    ("benchmarks-number", {"benchmarks": 5}, "a.json"),
    ("benchmark-not-object", {"benchmarks": [5]}, "a.json"),
    ("benchmark-without-name", {"benchmarks": [{"stats": {"median": 1}}]}, "a.json"),
    ("median-word", {"benchmarks": [{"name": "x", "stats": {"median": "fast"}}]}, "a.json"),
    ("median-list", {"benchmarks": [{"name": "x", "stats": {"median": [1]}}]}, "a.json"),
    ("stats-number", {"benchmarks": [{"name": "x", "stats": 3}]}, "a.json"),
    ("extra-info-list", {"benchmarks": [{"name": "x", "extra_info": [1]}]}, "a.json"),
    ("top-level-list", [], "a.json"),
]:

    def _bench(place: Place, document=document, fragment=fragment) -> tuple[list[object], str]:
        place.write("b.json", '{"benchmarks": []}')
        return ["compare", place.write("a.json", json.dumps(document)), place.folder / "b.json"], fragment

    case(f"records/compare-benchmark-{label}")(_bench)

add(
    "records/compare-benchmark-nested-deep",
    lambda place: [
        "compare",
        place.write("a.json", "[" * 100_000 + "]" * 100_000),
        place.write("b.json", "{}"),
    ],
    "a.json",
)


# == rig files ==============================================================================================
def _gltf(place: Place, *, extra: int = 0, rotation: list | None = None) -> Path:
    """A one-triangle glTF with one morph target whose data URI holds ``extra`` bytes more than its
    byteLength, its node rotated by ``rotation``."""
    neutral = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=np.float32)
    delta = np.array([[0, 0, 0.1], [0, 0, 0], [0, 0, 0]], dtype=np.float32)
    blob = neutral.tobytes() + delta.tobytes() + np.array([0, 1, 2], dtype=np.uint32).tobytes()
    node: dict = {"mesh": 0, **({"rotation": rotation} if rotation is not None else {})}
    primitive = {"attributes": {"POSITION": 0}, "indices": 2, "targets": [{"POSITION": 1}]}
    uri = "data:application/octet-stream;base64," + base64.b64encode(blob + b"\0" * extra).decode()
    document = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [node],
        "meshes": [{"primitives": [primitive], "extras": {"targetNames": ["jawOpen"]}}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5125, "count": 3, "type": "SCALAR"},
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 36 * k, "byteLength": 36 if k < 2 else 12} for k in range(3)
        ],
        "buffers": [{"byteLength": len(blob), "uri": uri}],
    }
    return place.write("face/face.gltf", json.dumps(document))


for label, options, fragment in [
    ("data-uri-longer-than-its-buffer", {"extra": 4_000_000}, "more than its byteLength"),
    ("rotation-zero-quaternion", {"rotation": [0, 0, 0, 0]}, "not a unit quaternion"),
    ("rotation-scaled-quaternion", {"rotation": [0, 0, 0, 2]}, "not a unit quaternion"),
    ("rotation-three-numbers", {"rotation": [0, 0, 1]}, "rotation"),
    ("rotation-words", {"rotation": ["a", 0, 0, 1]}, "rotation"),
]:
    add(
        f"rigs/gltf-{label}",
        lambda place, options=options: ["rigs", "info", _gltf(place, **options)],
        fragment,
    )
    add(
        f"rigs/gltf-pack-{label}",
        lambda place, options=options: pack(_gltf(place, **options), place),
        fragment,
    )


@case("rigs/npz-region-of-two-dimensions")
def _npz_region(place: Place) -> tuple[list[object], str]:
    rig = rigs.generate("tiny")
    arrays = {"neutral": rig.neutral, "deltas": rig.deltas, "triangles": rig.triangles,
              "names": np.array(rig.names), "region__lip": np.array([[1, 2], [3, 4]])}  # fmt: skip
    path = place.folder / "rig.npz"
    with path.open("wb") as stream:
        np.savez(stream, **arrays)
    return ["rigs", "info", path], "rig.npz"


for label, document in [("nested-list", {"lip": [[1, 2], [3, 4]]}), ("deep", {"lip": [[[1]]]})]:
    add(
        f"rigs/regions-{label}",
        lambda place, document=document: pack(
            "tiny", place, "--regions", place.write("regions.json", json.dumps(document))
        ),
        "regions.json",
    )


@case("rigs/shape-name-not-utf8")
def _not_utf8(place: Place) -> tuple[list[object], str]:
    rig = place.rig()
    (rig / "rig.json").unlink(missing_ok=True)
    os.rename(rig / "jawOpen.obj", os.fsencode(rig) + b"/jaw\xff\xfeOpen.obj")
    return pack(rig, place), "jaw"


@case("rigs/pack-a-rig-without-shapes")
def _no_shapes(place: Place) -> tuple[list[object], str]:
    tiny = rigs.generate("tiny")
    path = rigs.save(
        rigs.Rig(tiny.neutral, np.zeros((0, tiny.n_vertices, 3)), tiny.triangles, []),
        place.folder / "bare.npz",
    )
    return pack(path, place), "no blendshapes"


@case("rigs/run-a-rig-without-shapes")
def _run_no_shapes(place: Place) -> tuple[list[object], str]:
    tiny = rigs.generate("tiny")
    path = rigs.save(
        rigs.Rig(tiny.neutral, np.zeros((0, tiny.n_vertices, 3)), tiny.triangles, []),
        place.folder / "bare.npz",
    )
    return [
        "run",
        "--rigs",
        path,
        "--warps",
        "none",
        "--solvers",
        "greedy",
        "--transfers",
        "delta",
        "-q",
        "--out",
        place.folder / "out",
    ], "bare.npz"


# == commits, stores, suites ================================================================================
for label, arguments, fragment in [
    ("unknown-base", ["compare", "--commits", "nosuchref", "HEAD"], "nosuchref"),
    ("unknown-head", ["compare", "--commits", "HEAD", "nosuchref"], "nosuchref"),
    ("base-before-the-first-commit", ["compare", "--commits", "HEAD~99999", "HEAD"], "HEAD~99999"),
    ("ref-that-is-an-option", ["compare", "--commits", "--all", "HEAD"], "--all"),
    ("ref-with-a-range", ["compare", "--commits", "HEAD~1..HEAD", "HEAD"], "HEAD~1..HEAD"),
    ("unknown-suite", ["compare", "--commits", "HEAD", "HEAD", "--suite", "nosuch"], "nosuch"),
    ("unknown-solver", ["compare", "--commits", "HEAD", "HEAD", "--solvers", "nosuch"], "nosuch"),
    ("rounds-zero", ["compare", "--commits", "HEAD", "HEAD", "--rounds", "0"], "--rounds"),
    ("fail-above-nan", ["compare", "--commits", "HEAD", "HEAD", "--fail-above", "nan"], "--fail-above"),
    ("alpha-one", ["compare", "--commits", "HEAD", "HEAD", "--alpha", "1"], "--alpha"),
    ("threshold-nan", ["compare", "--commits", "HEAD", "HEAD", "--threshold", "nan"], "--threshold"),
    ("budget-zero", ["compare", "--commits", "HEAD", "HEAD", "--budget", "0"], "--budget"),
    ("sample-time-words", ["compare", "--commits", "HEAD", "HEAD", "--sample-time", "long"], "--sample-time"),
    ("one-commit", ["compare", "--commits", "HEAD"], "--commits"),
]:
    case(f"commits/{label}")(
        lambda place, arguments=arguments, fragment=fragment: (arguments, fragment, place.clone)
    )

#: Accepted slow-downs files that are not what they claim: (label, content, what the one line names).
ACCEPTED: list[tuple[str, str | bytes, str]] = [
    ("not-toml", "[[slowdown]\ncase = ", "accepted-slowdowns.toml"),
    ("no-reason", '[[slowdown]]\nafter = "0123456789"\ncase = "*"\n', "needs a case pattern and a reason"),
    (
        "both-after-and-commit",
        '[[slowdown]]\nafter = "0123456789"\ncommit = "0123456789"\ncase = "*"\nreason = "r"\n',
        "exactly one of after",
    ),  # fmt: skip
    ("short-commit", '[[slowdown]]\nafter = "01"\ncase = "*"\nreason = "r"\n', "7 hex digits"),
    (
        "ratio-below-one",
        '[[slowdown]]\nafter = "0123456789"\ncase = "*"\nreason = "r"\nmax_ratio = 0.5\n',
        "max_ratio",
    ),  # fmt: skip
    (
        "ratio-word",
        '[[slowdown]]\nafter = "0123456789"\ncase = "*"\nreason = "r"\nmax_ratio = "big"\n',
        "max_ratio",
    ),  # fmt: skip
    ("unknown-table", "[other]\nx = 1\n", "[[slowdown]]"),
    ("not-utf8", b"\xff\xfe[[slowdown]]", "accepted-slowdowns.toml"),
]
for label, _, fragment in ACCEPTED:
    case(f"commits/accepted-slowdowns-{label}")(
        lambda place, label=label, fragment=fragment: (
            ["compare", "--commits", "HEAD", f"slowdowns-{label}", "--suite", "quick", "--solvers", "greedy"],
            fragment,
            place.clone,
        )
    )

for label, arguments, fragment in [
    ("unknown-range-start", ["track", "nosuch..HEAD"], "nosuch"),
    ("unknown-range-end", ["track", "run", "HEAD~1..nosuch"], "nosuch"),
    ("range-backwards", ["track", "run", "HEAD..HEAD~3"], "HEAD..HEAD~3"),
    ("every-zero", ["track", "run", "HEAD~1..HEAD", "--every", "0"], "--every"),
    ("unknown-anchor", ["track", "run", "HEAD~1..HEAD", "--anchor", "nosuch"], "nosuch"),
    ("unknown-suite", ["track", "run", "HEAD~1..HEAD", "--suite", "nosuch"], "nosuch"),
    ("rounds-one", ["track", "run", "HEAD~1..HEAD", "--rounds", "1"], "--rounds"),
    ("store-of-an-unknown-protocol", ["track", "steps", "--store", "nosuchfs://bucket"], "nosuchfs"),
    ("alpha-zero", ["track", "steps", "--alpha", "0"], "--alpha"),
]:
    case(f"track/{label}")(
        lambda place, arguments=arguments, fragment=fragment: (arguments, fragment, place.clone)
    )


@case("track/store-is-a-file")
def _store_file(place: Place) -> tuple[list[object], str, Path]:
    return ["track", "steps", "--store", place.write("store", "x")], "store", place.clone


for label, content in [("not-parquet", b"not parquet"), ("other-columns", "parquet of other columns")]:

    def _store_broken(place: Place, content=content) -> tuple[list[object], str, Path]:
        part = place.folder / "store/machine=m/commit=0123456789abcdef0123456789abcdef01234567/part.parquet"
        part.parent.mkdir(parents=True)
        if isinstance(content, bytes):
            part.write_bytes(content)
        else:
            import pyarrow as pa
            import pyarrow.parquet as pq

            pq.write_table(pa.table({"x": [1]}), part)
        return (
            ["track", "steps", "--store", place.folder / "store", "--machine", "m"],
            "part.parquet",
            place.clone,
        )

    case(f"track/store-part-{label}")(_store_broken)


@case("track/publish-out-is-a-file", safe=lambda place: (place.folder / "site").read_text() == "keep")
def _publish_file(place: Place) -> tuple[list[object], str, Path]:
    place.write("site", "keep")
    place.write("store/.keep", "")
    return (
        ["track", "publish", "--store", place.folder / "store", "--out", place.folder / "site"],
        "site",
        place.clone,
    )


# == the test ===============================================================================================
@pytest.fixture(scope="session")
def shared(tmp_path_factory) -> dict[str, Path]:
    """What the cases copy: the tiny rig as OBJs, two finished runs of it (mu 0.3 and 0.2), the plugins'
    site folder, and a clone of this repository with one branch per accepted slow-downs file."""
    root = tmp_path_factory.mktemp("shared")
    found = {"tiny": rigs.save(rigs.generate("tiny"), root / "tiny")}
    for name, mu in (("run", "0.3"), ("other", "0.2")):
        ran = harness(
            "run", "--rigs", "tiny", "--warps", "none", "--solvers", "greedy", "--transfers", "delta",
            "--j-values", "2", "--jobs", "1", "-q", "--mu", mu, "--out", root / name, cwd=root,
        )  # fmt: skip
        assert ran.code == 0, ran.stderr
        found[name] = root / name
    site = root / "site"
    write_distribution(site, "cheating_solvers", SOLVER_ENTRY_POINTS)
    write_distribution(site, "format_plugins", FORMAT_ENTRY_POINTS)
    shutil.copy(ROOT / "tests" / "harness" / "cheating_solvers.py", site)
    shutil.copy(ROOT / "tests" / "rigs" / "format_plugins.py", site)
    found["site"] = site
    found["clone"] = _clone(root / "clone")
    return found


def _clone(folder: Path) -> Path:
    """A clone of this repository whose branch ``slowdowns-LABEL`` holds each accepted slow-downs file of
    `ACCEPTED`, one commit after the clone's ``HEAD``."""
    git = ["git", "-c", "user.name=attack", "-c", "user.email=attack@example.org", "-C", str(folder)]
    subprocess.run(["git", "clone", "-q", str(ROOT), str(folder)], check=True)
    base = subprocess.run(
        [*git, "rev-parse", "HEAD"], check=True, capture_output=True, text=True
    ).stdout.strip()
    for label, text, _ in ACCEPTED:
        subprocess.run([*git, "checkout", "-q", "-B", f"slowdowns-{label}", base], check=True)
        target = folder / "benchmarks" / "accepted-slowdowns.toml"
        target.write_bytes(text if isinstance(text, bytes) else text.encode())
        subprocess.run([*git, "add", str(target)], check=True)
        subprocess.run([*git, "commit", "-q", "-m", f"accepted slow-downs: {label}"], check=True)
    subprocess.run([*git, "checkout", "-q", "--detach", base], check=True)
    return folder


def attack(case: Case, tmp_path: Path, shared: dict[str, Path]) -> tuple[str, Ran]:
    """Build the case in ``tmp_path``, run it, and classify the ending (`test_fresh_attack.outcome`)."""
    place = Place(tmp_path / "case", shared)
    place.folder.mkdir()
    built = case.build(place)
    arguments, fragment = built[0], built[1]
    cwd = built[2] if len(built) > 2 else place.folder
    ran = harness(*arguments, cwd=cwd, site=shared["site"] if case.site else None)
    return outcome(ran, fragment, case.safe(place) if case.safe else True, case.noted), ran


def test_the_attack_has_at_least_150_cases() -> None:
    assert len(CASES) >= 150 and len({c.name for c in CASES}) == len(CASES)


@pytest.mark.parametrize("case", [pytest.param(c, id=c.name) for c in CASES])
def test_a_bad_input_ends_in_one_clear_line(case: Case, tmp_path: Path, shared: dict[str, Path]) -> None:
    ending, ran = attack(case, tmp_path, shared)
    assert ending == "clear", f"{ending}: exit {ran.code}\n{ran.stderr[-3000:]}\n{ran.stdout[-1500:]}"
