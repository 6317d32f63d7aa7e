"""A corpus of malformed and hostile rig files, generated here: every one is refused with a one-line
`RigError` naming the file and the problem, or, when merely doubtful, loads correctly with a `RigWarning`.

Each case runs under a hang guard (an alarm that raises, and a faulthandler backstop that dumps the stack
and exits) and under tracemalloc (peak of Python and NumPy allocations under 1 GB); the cases that would
take gigabytes if the readers trusted the files also run in a child process whose address space is
capped at 1 GiB above what importing the package takes.
"""

from __future__ import annotations

import faulthandler
import json
import subprocess
import sys
import tracemalloc
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

import rigs
from rigs import RigError
from rigs._rig import RigWarning
from tests.rigs import hostile_glb, hostile_gltf, hostile_npz, hostile_obj, hostile_target
from tests.rigs.hostile_corpus import CASES, HANG_SECONDS, PEAK_BYTES, Case
from tests.rigs.hostile_obj import obj_text
from tests.rigs.rig_files import hang_alarm

#: The modules whose import adds their cases to `CASES`, one per format.
CASE_MODULES = (hostile_obj, hostile_gltf, hostile_glb, hostile_npz, hostile_target)


@contextmanager
def guarded(*, trace: bool = True) -> Iterator[dict]:
    """Fail on a hang (the alarm raises in the test; faulthandler dumps every stack and exits if even
    that cannot interrupt), and report the peak of traced allocations in ``stats["peak"]``."""

    faulthandler.dump_traceback_later(3 * HANG_SECONDS, exit=True)
    if trace:
        tracemalloc.start()
    stats: dict = {}
    try:
        with hang_alarm(HANG_SECONDS):
            yield stats
    finally:
        if trace:
            stats["peak"] = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
        faulthandler.cancel_dump_traceback_later()


def test_the_corpus_is_large_and_its_names_unique() -> None:
    names = [case.name for case in CASES]
    assert len(names) == len(set(names))
    classes = {}
    for name in names:
        classes[name.split("/")[0]] = classes.get(name.split("/")[0], 0) + 1
    assert len(CASES) >= 150 and set(classes) == {"obj", "gltf", "glb", "npz", "target"}


@pytest.mark.parametrize("case", CASES, ids=lambda case: case.name)
def test_malformed_input_is_refused_naming_file_and_problem(case: Case, tmp_path: Path) -> None:
    path, options = case.build(tmp_path)
    if case.error is not None:
        with guarded() as stats, pytest.raises(RigError) as caught:
            rigs.load(path, **options)
        message = str(caught.value)
        assert "\n" not in message and (str(tmp_path) in message or str(path) in message)
        assert caught.match(case.error), message
    else:
        with guarded() as stats, pytest.warns(RigWarning, match=case.warning):
            rig = rigs.load(path, **options)
        assert case.check(rig), rig
    assert stats["peak"] < PEAK_BYTES, f"peak of {stats['peak'] / 2**20:.0f} MiB"


CHILD = """
import json, resource, sys
import rigs
from pathlib import Path
status = dict(line.split(":", 1) for line in open("/proc/self/status") if ":" in line)
base = int(status["VmSize"].split()[0]) * 1024
resource.setrlimit(resource.RLIMIT_AS, (base + 2**30, base + 2**30))
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
try:
    rigs.load(Path(sys.argv[1]), **json.loads(sys.argv[2]))
    outcome = "loaded"
except rigs.RigError as error:
    outcome = "RigError: " + str(error)
except BaseException as error:
    outcome = type(error).__name__ + ": " + str(error)[:300]
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"outcome": outcome, "rss": (after - before) * 1024}))
"""


@pytest.mark.parametrize("case", [case for case in CASES if case.heavy], ids=lambda case: case.name)
def test_inputs_that_would_take_gigabytes_stay_within_1_gib_of_address_space(
    case: Case, tmp_path: Path
) -> None:
    path, options = case.build(tmp_path)
    done = subprocess.run(
        [sys.executable, "-c", CHILD, str(path), json.dumps(options)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["outcome"].startswith("RigError: "), result["outcome"]
    assert result["rss"] < PEAK_BYTES


def test_an_8000_corner_concave_polygon_triangulates_without_hanging(tmp_path: Path) -> None:
    n = 8000
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    radii = np.where(np.arange(n) % 2 == 0, 1.0, 0.6)
    ring = np.stack([np.cos(angles) * radii, np.sin(angles) * radii, np.zeros(n)], axis=1)
    rig = tmp_path / "star"
    rig.mkdir()
    (rig / "neutral.obj").write_text(obj_text(ring, [list(range(n))]))
    (rig / "lift.obj").write_text(obj_text(ring + [0, 0, 0.1], [list(range(n))]))
    with guarded(trace=False):
        loaded = rigs.load(rig)
    normals = np.cross(
        *(loaded.neutral[loaded.triangles[:, i]] - loaded.neutral[loaded.triangles[:, 0]] for i in (1, 2))
    )
    assert loaded.n_triangles == n - 2 and (normals[:, 2] > 0).all()
    area = 0.5 * np.abs(
        np.dot(ring[:, 0], np.roll(ring[:, 1], -1)) - np.dot(ring[:, 1], np.roll(ring[:, 0], -1))
    )
    assert 0.5 * normals[:, 2].sum() == pytest.approx(area)
