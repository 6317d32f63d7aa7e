"""Stopping a command: Ctrl-C and SIGTERM after any backend leave the output folder as it was, the files a
killed writer staged are removed by the next run, a plugin's own KeyboardInterrupt is no Ctrl-C, and a
fault of the program is reported as one (a short traceback and where to report it)."""

from __future__ import annotations

import errno
import os
import shutil
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

import harness
import packing
import rigs
import solvers
from harness.cli import main
from registry import OutputFolderError, claim, handle_stop_signals, stop_signal, stop_signals_deferred
from registry._outdir import MANIFEST_NAME
from solvers._colouring import colour_cpsat
from solvers._cpsat_run import interruptible
from solvers.cpsat import CpSatSolver
from solvers.greedy import GreedySolver
from tests.harness.cli_helpers import assert_one_line_error, invoke

#: Bound on every wait of these tests (seconds); a pack of the tiny rig takes about one.
PATIENCE = 60.0

#: ``harness pack`` in a process that, once three of its files are staged, writes the process's caught
#: signals (``SigCgt``) to the mark file and waits to be stopped: the signal arrives after every CP-SAT
#: solve of the packing, while staged files lie in the output folder.
PAUSED_PACK = """
import sys, threading
from pathlib import Path
from registry import _outdir
from harness.cli import main

mark = Path(sys.argv[1])
write = _outdir.atomic_write
written = []

def pausing(path, data, **options):
    if len(written) == 3:
        caught = next(line for line in open("/proc/self/status") if line.startswith("SigCgt"))
        mark.write_text(caught.split()[1])
        threading.Event().wait()
    written.append(path)
    return write(path, data, **options)

_outdir.atomic_write = pausing
main(sys.argv[2:])
"""


def _catches(mask: str, number: int) -> bool:
    return bool(int(mask, 16) >> (number - 1) & 1)


def _caught_signals() -> str:
    return next(line for line in open("/proc/self/status") if line.startswith("SigCgt")).split()[1]


def _contents(folder: Path) -> dict[str, bytes]:
    return {
        path.relative_to(folder).as_posix(): path.read_bytes() for path in folder.rglob("*") if path.is_file()
    }


@pytest.fixture
def pythons_sigint_handler() -> Iterator[None]:
    """Python's own SIGINT handler (`signal.default_int_handler`) for the test, restored after it: a test
    suite started with SIGINT ignored (``cmd &``, ``nohup``, many CI wrappers) begins without it."""
    earlier = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, earlier)


def _tiny_problem() -> packing.PackingProblem:
    incidence = np.array([[1, 1, 0, 0], [0, 1, 1, 0], [0, 0, 1, 1], [1, 0, 0, 1]])
    return packing.problem_from_incidence(incidence, [0.5, 0.9, 0.4, 0.7])


@pytest.mark.skipif(not Path("/proc/self/status").is_file(), reason="needs /proc/self/status (Linux)")
@pytest.mark.usefixtures("pythons_sigint_handler")
def test_cp_sat_solves_leave_pythons_sigint_handler_in_place() -> None:
    pytest.importorskip("ortools")
    handler = signal.getsignal(signal.SIGINT)
    assert _catches(_caught_signals(), signal.SIGINT)
    solution = solvers.load(CpSatSolver).solve(_tiny_problem())
    assert solution.termination is packing.Termination.OPTIMAL
    problem = _tiny_problem()
    colour_cpsat(problem, np.arange(problem.n_items), 1, None, 0)  # the colouring model (cp_model.CpSolver)
    assert _catches(_caught_signals(), signal.SIGINT), "a CP-SAT solve left SIGINT to the system's default"
    assert signal.getsignal(signal.SIGINT) is handler


@pytest.mark.usefixtures("pythons_sigint_handler")
def test_ctrl_c_during_a_solve_stops_the_search_and_is_raised_once_it_ended() -> None:
    stopped = threading.Event()

    def solve() -> str:
        os.kill(os.getpid(), signal.SIGINT)  # the user's Ctrl-C, while the search runs
        assert stopped.wait(PATIENCE)
        return "stopped early"

    with pytest.raises(KeyboardInterrupt):
        interruptible(solve, stopped.set)
    assert stopped.is_set()


def test_a_solve_that_raises_raises_in_the_waiting_thread() -> None:
    def solve() -> None:
        raise RuntimeError("backend failed")

    with pytest.raises(RuntimeError, match="backend failed"):
        interruptible(solve, lambda: None)
    assert interruptible(lambda: 42, lambda: None) == 42


@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM], ids=["ctrl-c", "sigterm"])
@pytest.mark.parametrize("earlier", [False, True], ids=["new-folder", "earlier-packing"])
def test_a_pack_stopped_after_cp_sat_leaves_the_folder_as_it_was_and_runs_again(
    stop, earlier, tmp_path
) -> None:
    pytest.importorskip("ortools")
    out, mark = tmp_path / "session", tmp_path / "mark"
    arguments = ["pack", "tiny", "--solver", "cpsat", "--no-pictures", "--out", str(out)]
    if earlier:
        assert invoke(*arguments).exit_code == 0
    before = _contents(out) if earlier else {}
    force = ["--force"] if earlier else []
    process = subprocess.Popen(
        [sys.executable, "-c", PAUSED_PACK, str(mark), *arguments, *force],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    try:
        while not mark.exists() or not mark.read_text():
            assert process.poll() is None, process.communicate()[1].decode()
            threading.Event().wait(0.02)
        assert _catches(mark.read_text(), signal.SIGINT), "SIGINT is no longer caught after CP-SAT"
        new = list(tmp_path.glob(".session.*.tmp"))
        assert len(new) == 1 and len(list(new[0].iterdir())) >= 3  # the stop comes while files are written
        process.send_signal(stop)
        _, stderr = process.communicate(timeout=PATIENCE)
    finally:
        process.kill()
    word = "interrupted" if stop == signal.SIGINT else "terminated"
    assert process.returncode == 128 + stop and word in stderr.decode(), stderr.decode()
    assert _contents(out) == before and not list(tmp_path.glob(".session.*"))
    rerun = invoke(*arguments, *force)
    assert rerun.exit_code == 0, rerun.output


def test_what_a_killed_pack_left_is_removed_by_the_next_one_and_the_users_look_alikes_stay(tmp_path) -> None:
    """What harness writes on the way bears ``harness`` in its name; a user's dated backup beside the
    session (a whole copy, manifest and all) or inside it is named otherwise, and stays."""
    out = tmp_path / "session"
    (out / "pictures").mkdir(parents=True)
    staging = tmp_path / ".session.harness-abcd_123.tmp"
    (staging / "pictures").mkdir(parents=True)
    leftovers = [
        out / ".expression_01.obj.harness-k2x_9abc.tmp",
        out / "pictures" / ".expression_01_front.png.harness-a1b2c3d4.tmp",
        staging / "pictures" / "expression_01_front.png",
    ]
    for path in leftovers:
        path.write_bytes(b"half a file")
    earlier = tmp_path / "earlier"
    claim(earlier, kind="pack", force=False).replace({"expressions.json": "{}\n"})
    backup = tmp_path / ".session.20241204.tmp"  # (cp -a of an earlier session: its manifest holds)
    shutil.copytree(earlier, backup)
    result = invoke("pack", "tiny", "--solver", "greedy", "--no-pictures", "--out", out)
    assert result.exit_code == 0, result.output
    assert not any(path.exists() for path in leftovers) and not (out / "pictures").exists()
    assert not list(out.rglob("*.tmp")) and not staging.exists()
    assert (backup / "expressions.json").read_text() == "{}\n" and (backup / MANIFEST_NAME).is_file()


def test_leftovers_of_a_replaced_session_go_with_force_and_the_users_look_alikes_stay(tmp_path) -> None:
    out = tmp_path / "out"
    first = claim(out, kind="pack", force=False)
    first.replace({"expression_01.obj": "v 0 0 0\n", "pictures/front.png": b"png"})
    staged = [
        out / ".expression_02.obj.harness-abcdefgh.tmp",
        out / "pictures" / ".front.png.harness-zz_00000.tmp",
    ]
    users = [
        out / "notes.tmp",
        out / ".notes.txt.tmp",  # no random part
        out / ".expression_01.obj.20241204.tmp",  # a dated copy of a file harness wrote
        out / ".notes.txt.harness-ABCDEFGH.tmp",  # not the random part tempfile makes
        out / "drafts" / ".take.obj.harness-abcdefgh.tmp",  # in a folder harness writes nothing into
    ]
    for path in [*staged, *users]:
        path.parent.mkdir(exist_ok=True)
        path.write_text("x")
    link = out / ".expression_03.obj.harness-linkedxx.tmp"
    link.symlink_to(users[0])
    with pytest.raises(OutputFolderError, match=r"\(\.expression_01\.obj\.20241204\.tmp, \.expression_03"):
        claim(out, kind="pack", force=True)  # the look-alikes are the user's: nothing is removed
    assert all(path.exists() for path in [*staged, *users]) and link.is_symlink()
    for path in [*users, link]:
        path.unlink()
    (out / "drafts").rmdir()
    claim(out, kind="pack", force=True)
    assert not any(path.exists() for path in staged)
    assert sorted(path.name for path in out.iterdir()) == [MANIFEST_NAME, "expression_01.obj", "pictures"]


def test_a_folder_of_only_leftovers_is_empty_and_one_with_more_holds_no_harness_output(tmp_path) -> None:
    out = tmp_path / "out"
    (out / "pictures").mkdir(parents=True)
    (out / "pictures" / ".a.png.harness-abcdefgh.tmp").write_text("x")
    claim(out, kind="pack", force=False)
    assert list(out.iterdir()) == []
    (out / ".a.obj.harness-abcdefgh.tmp").write_text("x")
    (out / "take3.obj").write_text("the user's")
    assert_one_line_error(invoke("pack", "tiny", "--out", out), "holds no harness output")
    assert (out / ".a.obj.harness-abcdefgh.tmp").exists()
    only_dated = tmp_path / "dated"
    only_dated.mkdir()
    (only_dated / ".notes.20241204.tmp").write_text("the user's")  # (named like a temporary file, once)
    assert_one_line_error(invoke("pack", "tiny", "--out", only_dated), "holds no harness output")
    assert (only_dated / ".notes.20241204.tmp").read_text() == "the user's"


def test_a_run_stopped_by_sigterm_is_marked_interrupted(grid_arguments, module_plugins, tmp_path) -> None:
    out, marks = tmp_path / "out", tmp_path / "marks"
    marks.mkdir()
    env = {**os.environ, "HARNESS_FAULT_MARKS": str(marks), "HARNESS_FAULT_SLEEP": str(PATIENCE)}
    process = subprocess.Popen(
        [sys.executable, "-c", "from harness.cli import main; main()", *grid_arguments("napper")]
        + ["--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )
    try:
        while not any(marks.iterdir()):
            assert process.poll() is None, process.communicate()[1].decode()
            threading.Event().wait(0.02)
        process.send_signal(signal.SIGTERM)
        _, stderr = process.communicate(timeout=PATIENCE)
    finally:
        process.kill()
    assert process.returncode == 128 + signal.SIGTERM, stderr.decode()
    assert harness.read_run(out)["state"] == "interrupted"
    assert not [path for path in out.rglob("*") if path.name.endswith(".tmp")]


class SelfInterruptingSolver(GreedySolver):
    """A plugin whose backend raises KeyboardInterrupt without any Ctrl-C."""

    name = "self-interrupting"

    def solve(self, problem, *, time_limit=None, seed=0):
        raise KeyboardInterrupt


@pytest.mark.usefixtures("pythons_sigint_handler")
def test_a_plugins_own_keyboard_interrupt_is_a_failed_solve_not_a_ctrl_c() -> None:
    with handle_stop_signals():
        solution = solvers.load(SelfInterruptingSolver).solve(_tiny_problem())
        assert stop_signal() is None
    assert solution.termination is packing.Termination.ERROR
    assert "self-interrupting: raised KeyboardInterrupt itself" in solution.message
    with pytest.raises(KeyboardInterrupt):  # under Python's own handler no one can tell: it is the user's
        solvers.load(SelfInterruptingSolver).solve(_tiny_problem())
    earlier = signal.signal(signal.SIGINT, signal.SIG_IGN)  # as in a solver worker process
    try:
        solution = solvers.load(SelfInterruptingSolver).solve(_tiny_problem())
    finally:
        signal.signal(signal.SIGINT, earlier)
    assert solution.termination is packing.Termination.ERROR


def test_stop_signals_raise_keyboard_interrupt_and_are_remembered() -> None:
    earlier = signal.getsignal(signal.SIGTERM)
    with handle_stop_signals():
        with pytest.raises(KeyboardInterrupt):
            signal.raise_signal(signal.SIGTERM)
        assert stop_signal() == signal.SIGTERM
    assert signal.getsignal(signal.SIGTERM) is earlier


def test_a_fault_of_the_program_is_a_short_traceback_and_a_request_to_report_it(monkeypatch, capsys) -> None:
    def broken(*_: object) -> None:
        raise ZeroDivisionError("a bug, not bad input")

    monkeypatch.setattr(harness, "expand_names", broken)
    with pytest.raises(SystemExit) as ended:
        main(["pack", "tiny", "--out", "unused"])
    stderr = capsys.readouterr().err
    assert ended.value.code == os.EX_SOFTWARE
    assert "Traceback" in stderr and "ZeroDivisionError: a bug, not bad input" in stderr
    assert "unexpected ZeroDivisionError" in stderr and "please report it" in stderr


def test_a_keyboard_interrupt_no_signal_raised_is_reported_as_a_fault(monkeypatch, capsys) -> None:
    def interrupting(*_: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(harness, "expand_names", interrupting)
    with pytest.raises(SystemExit) as ended:
        main(["pack", "tiny", "--out", "unused"])
    stderr = capsys.readouterr().err
    assert ended.value.code == os.EX_SOFTWARE and "unexpected KeyboardInterrupt" in stderr
    assert "interrupted" not in stderr


def test_a_run_into_the_folder_of_its_rig_file_is_refused(rig_file, tmp_path) -> None:
    folder = tmp_path / "rig"
    rigs.save(rigs.load(rig_file), folder, format="obj-folder")
    neutral = folder / "neutral.obj"
    assert neutral.is_file()
    result = invoke("run", "--rigs", neutral, "--warps", "none", "--solvers", "greedy", "--out", folder)
    assert_one_line_error(result, str(folder), "the input", "apart from the inputs")
    assert not (folder / MANIFEST_NAME).exists()


def test_a_stop_signal_in_a_deferred_block_arrives_as_the_block_ends() -> None:
    reached = []
    with handle_stop_signals(), pytest.raises(KeyboardInterrupt):
        with stop_signals_deferred():
            signal.raise_signal(signal.SIGTERM)
            reached.append("the block's end")
        reached.append("after the block")
    assert reached == ["the block's end"] and stop_signal() == signal.SIGTERM


def test_a_full_disk_anywhere_is_one_line_not_a_fault(monkeypatch) -> None:
    def full(*_: object) -> None:
        raise OSError(errno.ENOSPC, "No space left on device", "/somewhere/file")

    monkeypatch.setattr(harness, "expand_names", full)
    result = invoke("pack", "tiny", "--out", "unused")
    assert_one_line_error(result, "No space left on device", "/somewhere/file")


@pytest.mark.parametrize(("stopped_in", "state"), [("map", "interrupted"), ("close", "complete")])
def test_a_stop_while_the_workers_close_leaves_run_json_true(rig_file, tmp_path, stopped_in, state) -> None:
    """A Ctrl-C among the cells marks the run interrupted; one that comes as the workers close, every cell
    recorded, leaves it complete: never "running" after the process is gone."""
    from harness._grid import RunConfig
    from tests.harness.conftest import InlineExecutor

    class Stopping(InlineExecutor):
        def map(self, cells):
            for index, outcome in enumerate(super().map(cells)):
                if stopped_in == "map" and index == 1:
                    raise KeyboardInterrupt
                yield outcome

        def close(self):
            if stopped_in == "close":
                raise KeyboardInterrupt

    config = RunConfig(rigs=(str(rig_file),), warps=("none",), solvers=("greedy", "cpsat"), transfers=())
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        harness.run_grid(config, out, make_executor=lambda timeout: Stopping())
    assert harness.read_run(out)["state"] == state
    recorded = harness.read_records(out).query("kind == 'cell'")
    assert len(recorded) == (1 if stopped_in == "map" else 2)


@pytest.mark.parametrize(
    ("writer", "state", "resuming", "said"),
    [
        (None, None, False, "no cell was recorded"),
        ("other", "complete", False, "no cell was recorded"),  # (an earlier run, still in the folder)
        ("other", "interrupted", True, "before this run recorded anything; resume with"),
        ("this", "complete", False, "as its workers closed; the run is complete"),
        ("this", "incomplete", False, "finished cells are recorded; resume with"),
        ("this", "interrupted", True, "finished cells are recorded; resume with"),
    ],
)
def test_the_interrupted_line_speaks_of_this_run_only(monkeypatch, tmp_path, writer, state, resuming, said):
    import harness._cli_run as cli_run

    if writer is not None:
        (tmp_path / "run.json").write_text("{}")
        pid = os.getpid() if writer == "this" else os.getpid() + 1
        monkeypatch.setattr(cli_run, "read_run", lambda out: {"state": state, "execution": {"pid": pid}})
    assert said in cli_run._where_interrupted(tmp_path, resuming)
