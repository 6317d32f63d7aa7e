"""The timing probe: a script run in a child process against the code of the commit being measured.

``harness compare --commits`` and ``harness track`` measure other commits than the one running them, as
asv does: each commit's packages (``rigs``, ``packing``, ``solvers``, ``transfer``) are put on the child's
``PYTHONPATH`` from a git worktree of that commit, and this file, run with ``python -P`` so that its own
folder is not on the path, drives them. It imports nothing of the running harness, only the measured
commit's public names, so the same probe measures old and new code alike; a name a commit lacks is an
error of that measurement, never a crash of the controller.

The controller (`harness._bench_session`) speaks to the probe in JSON lines: one request on stdin, one
answer (after `ANSWER_MARK`) on the file descriptor that was stdout when the probe started (anything the
measured code prints goes to stderr instead). Requests:

``{"op": "prepare", "groups": [...], "solvers": [...], "transfers": [...]}``
    Load each group's rig (a preset name, generated with its seed, or a rig file), warp it, analyse it and
    run Algorithm 1 (Carrigan et al. 2020) with the group's reference solver, keeping each primary
    subproblem as the solver saw it (pickled before the call, so every timed solve starts from the same
    state). Answers the instances (digest, size, the shapes the reference used before it, the symmetry
    pairs), the solvers' availability and declared overlap, and any error per group.
``{"op": "solve", "instance": I, "solver": S, "number": N, "min_time": T}``
    One sample of ``N`` solves of instance ``I`` by solver ``S`` (a fresh unpickled copy of the problem per
    solve, made before the clock starts; garbage collection off while timing), after one untimed warm-up
    solve the first time this process solves that instance with that solver. With ``N`` 0 the probe
    calibrates it first, as asv does: the smallest of 1, 2, 5, 10, 20, 50, ... whose sample lasts at least
    ``T`` seconds of CPU. The sample has its wall seconds (``time.perf_counter``), the calling thread's CPU
    seconds (``time.thread_time``), the process's (``time.process_time``: every thread) and the CPU of its
    child processes (those it waited for, and live ones: a backend that solves in a process of its own),
    each for the whole sample of ``N`` solves. Answers the distinct answers seen (shapes, termination,
    objective, bound) so that the controller checks each one.
``{"op": "transfer", "group": G, "method": M, "settings": {...}, "j_values": [...], "scan_seed": S}``
    One sample: the group's rig transferred with method ``M`` trained on the reference sequence's first J
    expressions for every J (`transfer.Transfer.prefixes`), on scan-like training expressions of capture
    session ``S`` (a seed per sample, so that no sample reuses another's fitted expressions), made before
    the clock starts. The first call in this process, which also builds the method's set-up for the rig
    pair, is answered apart as the ``cold`` sample.
``{"op": "exit"}``
    End the probe.

Every answer is ``{"ok": true, ...}`` or ``{"ok": false, "error": "..."}``.
"""

from __future__ import annotations

import gc
import hashlib
import json
import os
import pickle
import sys
import time
import traceback
from typing import Any

#: What starts every answer line, so that what the measured code prints while it is imported, before the
#: probe moves its output aside, is told apart.
ANSWER_MARK = "\x1eharness-probe "
#: Sample sizes tried by calibration, times powers of ten (asv's and timeit's autorange).
_STEPS = (1, 2, 5)
#: Most solves in one sample (bounds the fresh copies held at once).
MAX_NUMBER = 2000


def _children_cpu() -> float:
    """CPU seconds of this process's child processes: those it waited for (``getrusage``) and its live
    descendants (psutil, when the measured environment has it)."""
    import resource

    waited = resource.getrusage(resource.RUSAGE_CHILDREN)
    total = waited.ru_utime + waited.ru_stime
    try:
        import psutil
    except ImportError:
        return total
    for child in psutil.Process().children(recursive=True):
        try:
            times = child.cpu_times()
        except psutil.Error:
            continue
        total += times.user + times.system
    return total


def _clocks() -> tuple[float, float, float, float]:
    return time.perf_counter(), time.thread_time(), time.process_time(), _children_cpu()


def _elapsed(before: tuple[float, ...], after: tuple[float, ...]) -> dict[str, float]:
    wall, thread, process, children = (b - a for a, b in zip(before, after, strict=True))
    return {"wall": wall, "thread": thread, "process": process, "children": children}


class Probe:
    """The measured commit's side of a timing session (see the module notes)."""

    def __init__(self) -> None:
        self.groups: list[dict[str, Any]] = []
        self.instances: list[bytes] = []
        self.solvers: dict[str, Any] = {}
        self.solver_specs: dict[str, dict[str, Any]] = {}
        self.warm: set[tuple[int, str]] = set()
        self.warm_transfers: set[tuple[int, str]] = set()

    # -- prepare -------------------------------------------------------------------------------------------

    def prepare(self, groups: list[dict], solvers: list[dict], transfers: list[dict]) -> dict:
        import solvers as solver_package

        self.solver_specs = {spec["label"]: spec for spec in solvers}
        found_solvers = {}
        for spec in solvers:
            try:
                solver = solver_package.get(spec["name"], **spec.get("settings", {}))
                self.solvers[spec["label"]] = solver
                found_solvers[spec["label"]] = {
                    "available": True,
                    "exact": bool(solver.capabilities.exact),
                    "max_overlap": float(getattr(solver.capabilities, "max_overlap", 0.0)),
                }
            except Exception as error:  # noqa: BLE001 - an unavailable solver is an answer
                found_solvers[spec["label"]] = {"available": False, "reason": _describe(error)}
        answered = []
        for number, group in enumerate(groups):
            try:
                answered.append(self._prepare_group(number, group))
            except Exception as error:  # noqa: BLE001 - a group this commit cannot build is an answer
                self.groups.append({})
                answered.append({"group": number, "error": _describe(error)})
        return {"groups": answered, "solvers": found_solvers, "versions": _versions()}

    def _prepare_group(self, number: int, group: dict) -> dict:
        import packing
        import rigs
        import solvers

        template = _rig(group["rig"], int(group.get("seed", 0)))
        warp = group.get("warp") or "none"
        target = template if warp == "none" else rigs.warp(template, warp)
        params = dict(group.get("params") or {})
        target_neutral = None if warp == "none" else target.neutral
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            analysis = packing.analyse(template, target_neutral, **params)
        reference = solvers.get(group.get("reference", "cpsat"))
        recorded: list[bytes] = []

        class Recorder:
            name = reference.name
            capabilities = reference.capabilities

            def availability(self):
                return reference.availability()

            def solve(self, problem, *, time_limit=None, seed=0):
                if problem.meta.get("stage", "primary") == "primary":
                    recorded.append(pickle.dumps(problem, protocol=pickle.HIGHEST_PROTOCOL))
                return reference.solve(problem, time_limit=time_limit, seed=seed)

        expressions = packing.sequence(
            template,
            solvers.load(Recorder()),
            analysis=analysis,
            jmax=group.get("jmax"),
            time_limit=group.get("time_limit"),
            seed=0,
        )
        used: list[str] = []
        instances = []
        for index, (blob, expression) in enumerate(zip(recorded, expressions, strict=False)):
            problem = pickle.loads(blob)
            instances.append(
                {
                    "instance": len(self.instances),
                    "index": index + 1,
                    "digest": _digest(problem),
                    "items": int(problem.n_items),
                    "used_before": list(used),
                    "reference": list(expression.shapes),
                }
            )
            self.instances.append(blob)
            used.extend(expression.shapes)
        self.groups.append(
            {"template": template, "target": target, "expressions": expressions, "group": group}
        )
        return {
            "group": number,
            "instances": instances,
            "pairs": [list(pair) for pair in analysis.pairs],
            "n_shapes": int(template.n_shapes),
            "n_vertices": int(template.n_vertices),
        }

    # -- solve ---------------------------------------------------------------------------------------------

    def solve(self, instance: int, solver: str, number: int, min_time: float) -> dict:
        blob = self.instances[instance]
        plugin = self.solvers[solver]
        seed = int(self.solver_specs[solver].get("seed", 0))
        time_limit = self.solver_specs[solver].get("time_limit")
        answers: dict[tuple, dict] = {}

        def sample(count: int) -> dict[str, float]:
            copies = [pickle.loads(blob) for _ in range(count)]
            solutions = []
            enabled = gc.isenabled()
            gc.disable()
            try:
                before = _clocks()
                for problem in copies:
                    solutions.append(plugin.solve(problem, time_limit=time_limit, seed=seed))
                after = _clocks()
            finally:
                if enabled:
                    gc.enable()
            for solution in solutions:
                key = (tuple(solution.shapes), str(solution.termination.value))
                answers.setdefault(key, _answer(solution))
            return {**_elapsed(before, after), "number": count}

        if (instance, solver) not in self.warm:
            sample(1)  # warm-up: imports, first model build
            self.warm.add((instance, solver))
        if number <= 0:
            number = _calibrate(sample, min_time)
        return {"sample": sample(number), "answers": list(answers.values())}

    # -- transfer ------------------------------------------------------------------------------------------

    def transfer(self, group: int, method: str, settings: dict, j_values: list[int], scan_seed: int) -> dict:
        import numpy as np

        import transfer

        state = self.groups[group]
        if not state:
            raise RuntimeError(f"group {group} was not prepared")
        template, target, expressions = state["template"], state["target"], state["expressions"]
        weights = np.zeros((len(expressions), template.n_shapes))
        for row, expression in zip(weights, expressions, strict=True):
            names = [*expression.shapes, *getattr(expression, "extra_examples", ())]
            row[template.indices(names)] = 1.0
        plugin = transfer.get(method, **settings)
        last = len(expressions)
        js = sorted({min(int(j), last) for j in j_values if last})

        def timed(seed: int) -> dict[str, float]:
            examples = transfer.scan_expressions(target, weights, seed=seed)
            gc.collect()
            before = _clocks()
            prefixes = plugin.prefixes(template, target.neutral, weights, examples)
            for j in js:
                prefixes(j)
            return {**_elapsed(before, _clocks()), "number": 1}

        answer = {}
        if (group, method) not in self.warm_transfers:
            answer["cold"] = timed(scan_seed + 10_000)
            self.warm_transfers.add((group, method))
        answer["sample"] = timed(scan_seed)
        return answer


def _calibrate(sample, min_time: float) -> int:
    """The smallest autorange sample size (1, 2, 5, 10, 20, ...) whose sample lasts ``min_time`` CPU
    seconds, at most `MAX_NUMBER`: guessed from one timed solve, then confirmed by a sample of that size
    (and grown while the sample falls short)."""
    one = sample(1)
    seconds = max(one["process"] + max(one["children"], 0.0), 1e-7)
    number = _autorange(min_time / seconds)
    while number < MAX_NUMBER:
        measured = sample(number)
        if measured["process"] + max(measured["children"], 0.0) >= min_time:
            return number
        number = _autorange(number + 1)
    return MAX_NUMBER


def _autorange(at_least: float) -> int:
    """The smallest of 1, 2, 5, 10, 20, 50, ... not below ``at_least``, capped at `MAX_NUMBER`."""
    scale = 1
    while True:
        for step in _STEPS:
            if step * scale >= at_least or step * scale >= MAX_NUMBER:
                return min(step * scale, MAX_NUMBER)
        scale *= 10


def _answer(solution: Any) -> dict:
    bound = getattr(solution, "bound", None)
    return {
        "shapes": list(solution.shapes),
        "termination": str(solution.termination.value),
        "objective": float(solution.objective),
        "bound": None if bound is None else float(bound),
        "message": str(getattr(solution, "message", "") or ""),
    }


def _digest(problem: Any) -> str:
    """What makes two commits' instances the same problem: item labels, weights to 12 digits, conflict
    sets and cap."""
    import numpy as np

    h = hashlib.sha256()
    h.update(json.dumps([problem.item_label(i) for i in range(problem.n_items)]).encode())
    h.update(" ".join(f"{w:.12g}" for w in np.asarray(problem.weights, float)).encode())
    rows = sorted(sorted(int(i) for i in clique) for clique in problem.cliques)
    h.update(json.dumps(rows).encode())
    h.update(repr(problem.cap).encode())
    return h.hexdigest()[:20]


def _rig(name: str, seed: int) -> Any:
    import rigs

    if os.path.exists(name):
        return rigs.load(name)
    if name in rigs.PRESETS:
        return rigs.generate(name, seed=seed)
    if name == "faceunits":
        return rigs.load_faceunits(download=False)
    raise ValueError(f"unknown rig {name!r}")


def _versions() -> dict[str, str]:
    import numpy

    return {"python": sys.version.split()[0], "numpy": numpy.__version__}


def _describe(error: BaseException) -> str:
    text = "".join(traceback.format_exception_only(error)).strip().splitlines()
    return text[-1] if text else type(error).__name__


def serve(requests, answer) -> None:
    """Answer each request line until ``exit`` or the end of input."""
    probe = Probe()
    for line in requests:
        if not line.strip():
            continue
        try:
            request = json.loads(line)
            op = request.pop("op")
            if op == "exit":
                answer({"ok": True})
                return
            result = getattr(probe, op)(**request)
            answer({"ok": True, **result})
        except Exception as error:  # noqa: BLE001 - every failure is an answer
            answer({"ok": False, "error": _describe(error)})


def main() -> None:
    """Serve requests on stdin; answers go to the original stdout, anything else printed to stderr."""
    channel = os.dup(1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr

    def answer(document: dict) -> None:
        data = (ANSWER_MARK + json.dumps(document) + "\n").encode()
        while data:
            data = data[os.write(channel, data) :]

    serve(sys.stdin, answer)


if __name__ == "__main__":
    main()
