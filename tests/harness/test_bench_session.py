"""Timing sessions (`harness.measure`): the probe that runs a commit's code, samples calibrated as asv's,
two versions measured alternately, and every answer checked in the harness's own process."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

import harness
from harness import CodeVersion, Group, Suite
from harness._bench_session import ProbeError, ProbeProcess
from reports import compare_measurement
from tests.plugin_distribution import write_distribution

ROOT = Path(__file__).resolve().parents[2]
TINY = Suite("test", (Group("tiny", "none"),), ("greedy", "cpsat"), ("delta",))


def _here(name: str, *extra: Path) -> CodeVersion:
    """This checkout's code, as a commit's worktree would run."""
    return CodeVersion(name, "0" * 40, sys.executable, (str(ROOT), *map(str, extra)))


@pytest.fixture(scope="module")
def liars(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder that registers `timing_solvers` the way an installed plugin is registered."""
    site = tmp_path_factory.mktemp("site")
    entry_points = "[harness.solvers]\nliar-overlap = timing_solvers:OverlapLiar\n"
    entry_points += "wrong-optimum = timing_solvers:WrongOptimum\n"
    write_distribution(site, "timing_solvers", entry_points)
    (site / "timing_solvers.py").write_text(Path(__file__).with_name("timing_solvers.py").read_text())
    return site


def test_the_probe_builds_the_instances_and_calibrates_its_samples(tmp_path):
    probe = ProbeProcess(_here("here"), tmp_path)
    try:
        prepared = probe.ask(
            {"op": "prepare", "groups": [Group("tiny", "none").request()],
             "solvers": [{"label": "greedy", "name": "greedy"}, {"label": "nosuch", "name": "nosuch"}],
             "transfers": []},
            timeout=120,
        )  # fmt: skip
        (group,) = prepared["groups"]
        assert len(group["instances"]) >= 2 and all(len(i["digest"]) == 20 for i in group["instances"])
        assert group["instances"][1]["used_before"] == group["instances"][0]["reference"]
        assert prepared["solvers"]["greedy"]["available"] and not prepared["solvers"]["nosuch"]["available"]
        assert "nosuch" in prepared["solvers"]["nosuch"]["reason"]
        answer = probe.ask(
            {"op": "solve", "instance": 0, "solver": "greedy", "number": 0, "min_time": 0.005}, timeout=60
        )
        sample = answer["sample"]
        assert sample["number"] >= 2  # a greedy solve of tiny takes well under 5 ms
        assert sample["process"] >= 0.005 and sample["thread"] > 0 and sample["wall"] > 0
        assert answer["answers"][0]["termination"] == "completed" and answer["answers"][0]["shapes"]
        transfer = probe.ask(
            {
                "op": "transfer",
                "group": 0,
                "method": "delta",
                "settings": {},
                "j_values": [1, 2],
                "scan_seed": 0,
            },
            timeout=120,
        )
        assert set(transfer) >= {"cold", "sample"}
        with pytest.raises(ProbeError, match="KeyError"):
            probe.ask(
                {"op": "solve", "instance": 0, "solver": "nosuch", "number": 1, "min_time": 0.0}, timeout=60
            )
    finally:
        probe.close()


def test_what_the_measured_code_prints_does_not_garble_the_answers(tmp_path):
    chatty = tmp_path / "chatty"
    chatty.mkdir()
    (chatty / "sitecustomize.py").write_text("print('hello from a commit'); print('{\"ok\": false}')\n")
    probe = ProbeProcess(_here("chatty", chatty), tmp_path)
    try:
        answer = probe.ask({"op": "prepare", "groups": [], "solvers": [], "transfers": []}, timeout=60)
        assert answer["groups"] == [] and answer["ok"]
    finally:
        probe.close()


def test_two_versions_of_the_same_code_are_measured_alternately_and_judged_alike(tmp_path):
    found = harness.measure([_here("a"), _here("b")], TINY, scratch=tmp_path, rounds=2, repeat=2)
    samples = found.samples
    assert found.rounds == 2 and found.errors == []
    assert set(samples["version"]) == {"a", "b"} and samples["valid"].all()
    assert set(samples["kind"]) == {"solve", "transfer"} and samples["cold"].sum() == 4  # delta, 2 per side
    per_job = samples[samples["kind"] == "solve"].groupby(["case", "instance"])["number"].nunique()
    assert (per_job == 1).all()  # one calibrated sample size per job, whatever the side and round
    assert (found.answers["problem"] == "").all()
    comparison = compare_measurement(found)
    assert comparison.problems == []
    assert not {"slower", "faster"} & {case.test.verdict for case in comparison.cases}


def test_an_answer_is_checked_where_the_plugin_cannot_reach(tmp_path, liars):
    suite = Suite("test", (Group("tiny", "none"),), ("liar-overlap", "wrong-optimum", "cpsat"))
    found = harness.measure([_here("a", liars)], suite, scratch=tmp_path, rounds=1, repeat=1)
    problems = found.answers.set_index("solver")["problem"]
    # it disabled packing.check, in its own process; the last instance's items share no vertex
    assert problems.loc["liar-overlap"].str.contains("share").sum() >= 2
    assert problems.loc["wrong-optimum"].str.contains("proved optimal with other shapes").any()
    assert (problems.loc["cpsat"] == "").all()
    invalid = found.samples[~found.samples["valid"]]
    assert set(invalid["case"].str.rpartition("/")[2]) == {"liar-overlap", "wrong-optimum"}


def test_a_budget_ends_the_rounds_after_the_least(tmp_path):
    suite = Suite("test", (Group("tiny", "none"),), ("greedy",))
    found = harness.measure([_here("a")], suite, scratch=tmp_path, rounds=5, repeat=1, budget=0.001)
    assert found.rounds == 2
    # The first round is whole; the second stops taking samples once the budget is spent (here at once).
    rounds = found.samples.groupby("round").size()
    assert rounds.loc[0] > 0 and rounds.get(1, 0) == 0
