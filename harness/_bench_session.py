"""A timing session: commits measured alternately, on the same instances, in one job (asv ``continuous``).

Each *round* starts a fresh probe process per commit (`harness._probe`), so that what one process happens
to get (its memory layout, its core, a cold cache) is spread over rounds instead of fixed to one side.
Every probe builds the suite's instances with its own code; instances are matched across commits by group
and position in the reference sequence, and their digests say whether both commits solve the same problem.
Then each *job* (one instance and one solver, or one group and one transfer method) is measured on every
commit in turn, the order alternating from job to job and round to round, so a change of the machine's load
falls on both sides alike. A job's sample size is calibrated once, on its first measurement, and kept for
every commit and round: a sample of N solves lasts at least ``min_time`` seconds of CPU.

Nothing a commit answers is taken on trust. Every distinct answer a probe reports is checked here, in this
process, by `packing.check` on the rig as this harness reads it (no shared active vertex between two shapes
of one expression beyond the solver's declared overlap, symmetry pairs together, the cap held, maximal when
the solver ran to its end), and the exact solvers that proved optimality must choose the same shapes on the
same instance, whichever commit ran them. A sample of a job whose answer fails is kept but marked, and never
timed against anything.
"""

from __future__ import annotations

import datetime
import json
import os
import random
import selectors
import subprocess
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pandas as pd

from harness._bench_suites import Suite, solver_request
from harness._commits import CodeVersion
from harness._probe import ANSWER_MARK
from harness._settings import split_label
from registry import HarnessError

PROBE = Path(__file__).with_name("_probe.py")

#: Threads of the numerical libraries in a probe: one, so that idle BLAS threads spinning in the background
#: add no CPU time to a solve (a backend's own threads, CP-SAT's workers, are not affected).
_SINGLE_THREADED = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}

#: Terminations after which a solver had the chance to fill its expression (maximality is checked).
_RAN_TO_END = ("optimal", "completed")

#: Columns of `Measurement.samples`.
SAMPLE_COLUMNS = (
    "version",
    "commit",
    "round",
    "kind",
    "group",
    "instance",
    "case",
    "digest",
    "number",
    "wall",
    "thread",
    "process",
    "children",
    "cold",
    "valid",
)


class ProbeError(HarnessError):
    """A probe that died, answered nonsense or did not answer in time."""


class ProbeProcess:
    """One probe process running a commit's code, spoken to in JSON lines (`harness._probe`)."""

    def __init__(self, version: CodeVersion, scratch: Path) -> None:
        self.version = version
        self.log = tempfile.TemporaryFile(prefix=f"probe-{version.short}-")
        env = {
            **os.environ,
            **_SINGLE_THREADED,
            "PYTHONPATH": os.pathsep.join(version.path),
            "PYTHONDONTWRITEBYTECODE": "1",
        }
        env.pop("PYTHONSTARTUP", None)
        self.process = subprocess.Popen(
            [version.python, "-P", str(PROBE)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self.log,
            cwd=scratch,
            env=env,
            text=True,
            start_new_session=True,
        )
        self.selector = selectors.DefaultSelector()
        assert self.process.stdout is not None
        self.selector.register(self.process.stdout, selectors.EVENT_READ)

    def ask(self, request: dict, *, timeout: float) -> dict:
        """The probe's answer to ``request``.

        Raises
        ------
        ProbeError
            When the probe died, did not answer within ``timeout`` seconds (it is then killed), or
            answered ``ok: false`` (its error in the message).
        """
        assert self.process.stdin is not None and self.process.stdout is not None
        try:
            self.process.stdin.write(json.dumps(request) + "\n")
            self.process.stdin.flush()
        except (BrokenPipeError, OSError):
            raise ProbeError(self._death()) from None
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0 or not self.selector.select(left):
                self.kill()
                raise ProbeError(
                    f"{self.version.name}: no answer to {request['op']} in {timeout:g} s; killed"
                )
            line = self.process.stdout.readline()
            if not line:
                raise ProbeError(self._death())
            if line.startswith(ANSWER_MARK):  # else printed by the measured code before the probe took over
                break
        try:
            answer = json.loads(line[len(ANSWER_MARK) :])
        except ValueError:
            self.kill()
            raise ProbeError(f"{self.version.name}: the probe answered {line[:80]!r}") from None
        if not answer.get("ok"):
            raise ProbeError(f"{self.version.name}: {answer.get('error', 'failed')}")
        return answer

    def _death(self) -> str:
        code = self.process.wait(timeout=10)
        self.log.seek(0)
        tail = self.log.read().decode("utf-8", "replace").strip().splitlines()[-1:]
        return f"{self.version.name}: the probe ended (exit {code}){': ' + tail[0] if tail else ''}"

    def close(self) -> None:
        """Ask the probe to end, and kill it if it does not."""
        try:
            self.ask({"op": "exit"}, timeout=10)
            self.process.wait(timeout=10)
        except (ProbeError, subprocess.TimeoutExpired):
            self.kill()
        finally:
            self.selector.close()
            self.log.close()

    def kill(self) -> None:
        """Kill the probe and whatever it started."""
        try:
            os.killpg(self.process.pid, 9)
        except ProcessLookupError:
            pass
        self.process.wait()


@dataclass
class Measurement:
    """What a timing session measured and checked.

    Attributes
    ----------
    samples : DataFrame
        One row per sample (`SAMPLE_COLUMNS`): the version and its commit, the round, the job's ``kind``
        (``solve`` or ``transfer``), group label, instance (position in the reference sequence; 0 for a
        transfer), ``case`` (``rig/warp/solver`` or ``rig/warp/transfer:method``), the instance digest, the
        sample size ``number`` and its seconds of wall, calling-thread CPU, process CPU and child-process
        CPU (for the whole sample), ``cold`` (a transfer's first call, set-up included) and ``valid``
        (every answer of the job on this commit passed the check).
    answers : DataFrame
        Every distinct answer: version, group, instance, solver, shapes, termination, objective, bound and
        ``problem`` (the check's message, empty when it passed).
    instances : DataFrame
        Version, group, instance, digest and items of every instance each commit built.
    errors : list of str
        What could not be measured, with the reason (a group a commit cannot build, a solver it lacks, a
        probe that died).
    """

    versions: tuple[CodeVersion, ...]
    suite: Suite
    samples: pd.DataFrame
    answers: pd.DataFrame
    instances: pd.DataFrame
    errors: list[str] = field(default_factory=list)
    rounds: int = 0
    seconds: float = 0.0
    started: str = ""


@dataclass(frozen=True)
class _Job:
    """One thing measured on every version: a solver on an instance, or a transfer method on a group."""

    kind: str
    group: int
    instance: int
    name: str

    @property
    def key(self) -> tuple:
        return (self.kind, self.group, self.instance, self.name)


@dataclass
class _Prepared:
    """What one probe built in one round: its groups, its solvers, and its instances by (group, position)."""

    groups: list[dict]
    solvers: dict[str, dict]
    instances: dict[tuple[int, int], dict] = field(default_factory=dict)

    def pairs(self, group: int) -> list[list[str]]:
        """The symmetry pairs the probe's analysis of ``group`` found."""
        return next((g.get("pairs", []) for g in self.groups if g.get("group") == group), [])


Progress = Callable[[str, int, int], None]


def measure(
    versions: list[CodeVersion],
    suite: Suite,
    *,
    scratch: Path,
    rounds: int = 3,
    repeat: int = 3,
    min_time: float = 0.01,
    budget: float | None = None,
    min_rounds: int = 2,
    timeout: float = 600.0,
    seed: int = 0,
    progress: Progress | None = None,
) -> Measurement:
    """Measure ``versions`` alternately on ``suite`` (module notes).

    Parameters
    ----------
    versions : list of CodeVersion
        The commits; one for a history point, two for an A/B comparison.
    suite : Suite
    scratch : Path
        A folder for the probes' logs (their working directory).
    rounds : int
        Rounds of fresh probe processes, at most.
    repeat : int
        Samples per job, commit and round.
    min_time : float
        Least CPU seconds of one sample (asv's ``min_time``): fast solves are repeated within a sample.
    budget : float, optional
        Seconds the whole session may take: no round starts that would end past it (judged from the rounds
        so far) once ``min_rounds`` rounds are done, and a round after the first stops taking samples when
        the budget is spent (its jobs are shuffled, so the jobs it leaves out are a random few), so that a
        loaded machine shortens the session instead of lengthening it.
    timeout : float
        Seconds a probe may take over one request before it is killed.
    seed : int
        Seed of the job order.
    progress : callable, optional
        Called with (what, done, total) after every job.

    Returns
    -------
    Measurement
    """
    if len({version.name for version in versions}) != len(versions):
        raise HarnessError("the versions measured together need names of their own")
    started = time.monotonic()
    when = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    labels = suite.solver_labels()
    session = _Session(suite, min_time=min_time, timeout=timeout)
    done = 0
    for round_ in range(rounds):
        elapsed = time.monotonic() - started
        if budget is not None and done >= min_rounds and elapsed / done * (done + 1) > budget:
            break
        shift = round_ % len(versions)
        order = [*range(shift, len(versions)), *range(shift)]
        probes: dict[int, ProbeProcess] = {}
        try:
            for side in order:
                probes[side] = ProbeProcess(versions[side], scratch)
            prepared = {side: session.prepare(probes[side], labels, first=round_ == 0) for side in order}
            jobs = session.jobs(labels, list(prepared.values()))
            random.Random(seed * 1_000_003 + round_).shuffle(jobs)
            for position, job in enumerate(jobs):
                if budget is not None and round_ > 0 and time.monotonic() - started > budget:
                    break
                for sample in range(repeat):
                    sides = order if (position + sample) % 2 == 0 else order[::-1]
                    taken = [
                        session.sample(job, probes[side], prepared[side], round_=round_, sample=sample)
                        for side in sides
                    ]
                    if not all(taken):
                        break
                if progress is not None:
                    progress(f"round {round_ + 1}", position + 1, len(jobs))
        except ProbeError as error:
            session.errors.append(str(error))
        finally:
            for probe in probes.values():
                probe.close()
        done += 1
    measurement = Measurement(
        tuple(versions),
        suite,
        pd.DataFrame(session.samples, columns=list(SAMPLE_COLUMNS)),
        pd.DataFrame(list(session.answers.values())),
        pd.DataFrame(session.instances),
        session.errors,
        done,
        time.monotonic() - started,
        when,
    )
    verify(measurement)
    return measurement


class _Session:
    """What one `measure` call gathers: every sample, answer, instance and error, and each job's sample
    size, calibrated on its first measurement and kept for every version and round."""

    def __init__(self, suite: Suite, *, min_time: float, timeout: float) -> None:
        self.suite, self.min_time, self.timeout = suite, min_time, timeout
        self.samples: list[dict] = []
        self.answers: dict[tuple, dict] = {}
        self.instances: list[dict] = []
        self.errors: list[str] = []
        self.numbers: dict[tuple, int] = {}

    def prepare(self, probe: ProbeProcess, labels: list[str], *, first: bool) -> _Prepared:
        """Ask ``probe`` to build the suite; in the first round, keep its instances and what it lacks."""
        answer = probe.ask(
            {
                "op": "prepare",
                "groups": [group.request() for group in self.suite.groups],
                "solvers": [solver_request(label) for label in labels],
                "transfers": [],
            },
            timeout=self.timeout,
        )
        prepared = _Prepared(answer["groups"], answer["solvers"])
        for group in answer["groups"]:
            for instance in group.get("instances", []):
                prepared.instances[(group["group"], instance["index"])] = instance
        if first:
            self._keep(probe.version, prepared)
        return prepared

    def _keep(self, version: CodeVersion, prepared: _Prepared) -> None:
        """The instances a version built, and the groups and solvers it lacks."""
        for (group, index), facts in sorted(prepared.instances.items()):
            label = self.suite.groups[group].label
            self.instances.append(
                {"version": version.name, "group": label, "instance": index, "digest": facts["digest"],
                 "items": facts["items"]}
            )  # fmt: skip
        self.errors += [
            f"{version.name}: {self.suite.groups[group['group']].label}: {group['error']}"
            for group in prepared.groups
            if "error" in group
        ]
        self.errors += [
            f"{version.name}: solver {label}: {facts.get('reason', 'unavailable')}"
            for label, facts in prepared.solvers.items()
            if not facts.get("available")
        ]

    def jobs(self, labels: list[str], sides: list[_Prepared]) -> list[_Job]:
        """The jobs every version can run: instances all of them built, solvers all of them have."""
        common = set.intersection(*(set(side.instances) for side in sides))
        usable = [
            label for label in labels if all(side.solvers.get(label, {}).get("available") for side in sides)
        ]
        jobs = [
            _Job("solve", group, instance, label)
            for (group, instance) in sorted(common)
            for label in usable
            if self.suite.groups[group].times(label)
        ]
        built = set.intersection(*({g["group"] for g in side.groups if "error" not in g} for side in sides))
        for number, group in enumerate(self.suite.groups):
            if group.transfers and number in built:
                jobs += [_Job("transfer", number, 0, method) for method in self.suite.transfer_labels()]
        return jobs

    def sample(
        self, job: _Job, probe: ProbeProcess, prepared: _Prepared, *, round_: int, sample: int
    ) -> bool:
        """One sample of ``job`` on the probe's version; False when the probe reported an error for it
        (kept in `errors`).

        Raises
        ------
        ProbeError
            When the probe died or did not answer in time: the round cannot go on.
        """
        group = self.suite.groups[job.group]
        try:
            if job.kind == "solve":
                digest, timed, cold = self._solve(job, probe, prepared)
                case = f"{group.label}/{job.name}"
            else:
                digest, timed, cold = self._transfer(job, probe, round_, sample)
                case = f"{group.label}/transfer:{job.name}"
        except ProbeError as error:
            if "killed" in str(error) or "ended" in str(error):
                raise
            self.errors.append(f"{probe.version.name}: {group.label} {job.kind} {job.name}: {error}")
            return False
        base = {
            "version": probe.version.name,
            "commit": probe.version.commit,
            "round": round_,
            "kind": job.kind,
            "group": group.label,
            "instance": job.instance,
            "case": case,
            "digest": digest,
        }
        for timing, is_cold in [*((t, False) for t in timed), *((t, True) for t in cold)]:
            self.samples.append({**base, **timing, "cold": is_cold, "valid": True})
        return True

    def _solve(self, job: _Job, probe: ProbeProcess, prepared: _Prepared) -> tuple[str, list, list]:
        """One sample of a solver on an instance (sized on the job's first), its answers kept."""
        facts = prepared.instances[(job.group, job.instance)]
        answer = probe.ask(
            {"op": "solve", "instance": facts["instance"], "solver": job.name,
             "number": self.numbers.get(job.key, 0), "min_time": self.min_time},
            timeout=self.timeout,
        )  # fmt: skip
        self.numbers.setdefault(job.key, answer["sample"]["number"])
        solver, label = prepared.solvers[job.name], self.suite.groups[job.group].label
        for found in answer["answers"]:
            identity = (probe.version.name, label, job.instance, job.name, tuple(found["shapes"]))
            self.answers.setdefault(
                identity,
                {"version": probe.version.name, "group": label, "group_index": job.group,
                 "instance": job.instance, "solver": job.name, "exact": bool(solver.get("exact")),
                 "max_overlap": float(solver.get("max_overlap", 0.0)), "used_before": facts["used_before"],
                 "pairs": prepared.pairs(job.group), **found, "problem": ""},
            )  # fmt: skip
        return facts["digest"], [answer["sample"]], []

    def _transfer(self, job: _Job, probe: ProbeProcess, round_: int, sample: int) -> tuple[str, list, list]:
        """One sample of a transfer method (and its cold first call, the first time in this probe)."""
        name, settings = split_label(job.name)
        answer = probe.ask(
            {"op": "transfer", "group": job.group, "method": name, "settings": dict(settings),
             "j_values": list(self.suite.j_values), "scan_seed": 1000 * round_ + sample},
            timeout=self.timeout,
        )  # fmt: skip
        return "", [answer["sample"]], [answer["cold"]] if "cold" in answer else []


def verify(measurement: Measurement) -> None:
    """Check every answer in this process and mark the samples of jobs whose answers fail (module notes).

    ``measurement.answers`` gets its ``problem`` column filled, and ``measurement.samples`` its ``valid``
    column: False for every sample of a (commit, instance, solver) with an answer that failed.
    """
    frame = measurement.answers
    if frame.empty:
        return
    import packing
    import rigs

    problems = [""] * len(frame)
    rigs_by_group: dict[int, Any] = {}
    for position, row in enumerate(frame.itertuples(index=False)):
        group = measurement.suite.groups[row.group_index]
        if row.group_index not in rigs_by_group:
            rigs_by_group[row.group_index] = rigs.resolve(group.rig, seed=group.seed)
        bound = None if row.bound is None or pd.isna(row.bound) else float(row.bound)
        expression = SimpleNamespace(
            shapes=tuple(row.shapes), objective=row.objective, bound=bound, termination=row.termination
        )
        try:
            packing.check(
                rigs_by_group[row.group_index],
                [expression],
                pairs=[tuple(pair) for pair in row.pairs],
                overlap=row.max_overlap,
                maximal=row.termination in _RAN_TO_END,
                rejected={1: row.used_before},
            )
        except packing.CheckError as error:
            problems[position] = str(error).split(": ", 1)[-1]
    frame["problem"] = problems
    _exact_agreement(frame, measurement.instances)
    bad = frame.loc[frame["problem"] != "", ["version", "group", "instance", "solver"]]
    if bad.empty or measurement.samples.empty:
        return
    keys = set(bad.itertuples(index=False, name=None))
    samples = measurement.samples
    solver = samples["case"].str.rpartition("/")[2]
    marked = [
        (version, group, instance, name) in keys
        for version, group, instance, name in zip(
            samples["version"], samples["group"], samples["instance"], solver, strict=True
        )
    ]
    samples["valid"] = ~pd.Series(marked, index=samples.index) | (samples["kind"] != "solve")


def _exact_agreement(frame: pd.DataFrame, instances: pd.DataFrame) -> None:
    """Mark the optimal answers of exact solvers that differ from another's on the same instance (the
    same digest, whichever commit): with packing's tie-break the optimum is unique."""
    digests = {
        (row.version, row.group, row.instance): row.digest for row in instances.itertuples(index=False)
    }
    optimal = frame[frame["exact"] & (frame["termination"] == "optimal") & (frame["problem"] == "")]
    chosen: dict[str, dict[tuple, list[int]]] = {}
    for position, row in optimal.iterrows():
        digest = digests.get((row["version"], row["group"], row["instance"]), "")
        chosen.setdefault(digest, {}).setdefault(tuple(sorted(row["shapes"])), []).append(position)
    for answers in chosen.values():
        if len(answers) < 2:
            continue
        majority = max(answers, key=lambda shapes: len(answers[shapes]))
        for shapes, positions in answers.items():
            if shapes == majority:
                continue
            other = frame.loc[answers[majority][0]]
            for position in positions:
                frame.loc[position, "problem"] = (
                    f"proved optimal with other shapes than {other['solver']} ({other['version']}) on the "
                    f"same instance: {', '.join(shapes)} against {', '.join(majority)}"
                )
