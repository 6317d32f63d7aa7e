"""The expression sequence (Algorithm 1) with a small exact solver, and the sec. 6 extensions."""

from __future__ import annotations

import dataclasses
import typing
import warnings

import numpy as np
import pytest

import packing
import rigs
from packing import Expression, Solution, SolutionStatus, Termination


@pytest.fixture(autouse=True)
def _quiet():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", packing.MissingTargetWarning)
        yield


@pytest.fixture
def crowded(kit):
    """Fourteen overlapping shapes (three mirror pairs among them) on a small face."""
    rng = np.random.default_rng(7)
    bumps = []
    for k in range(3):
        right = kit.Bump(
            f"side{k}_R", (rng.uniform(0.2, 0.6), rng.uniform(-0.6, 0.6)), (0.25, 0.2), (1.0, 0.5, k)
        )
        bumps += [right, kit.mirrored(right, f"side{k}_L")]
    for k in range(8):
        centre = (rng.uniform(-0.5, 0.5), rng.uniform(-0.6, 0.6))
        bumps.append(
            kit.Bump(f"blob{k}", centre, (0.3, 0.25), tuple(rng.normal(size=3)), rng.uniform(0.5, 1.5))
        )
    return kit.face_rig(bumps, side=25, regions={})


def test_sequence_uses_every_shape_once_with_optimal_expressions(crowded, kit, exact_solver):
    target = crowded.neutral * [1.3, 1.0, 0.8]
    expressions = packing.sequence(crowded, exact_solver, target_neutral=target)
    analysis = packing.analyse(crowded, target)
    shapes = [name for e in expressions for name in e.shapes]
    assert sorted(shapes) == sorted(crowded.names)
    assert [e.index for e in expressions] == list(range(1, len(expressions) + 1))
    assert len(expressions) >= packing.expression_lower_bound(analysis).lower
    used: list[str] = []
    for expression in expressions:
        problem = analysis.problem_for(used)
        conflicts = [set() for _ in range(problem.n_items)]
        dense = problem.incidence.toarray()
        for a in range(problem.n_items):
            for b in range(problem.n_items):
                if a != b and (dense[a] & dense[b]).any():
                    conflicts[a].add(b)
        best, _ = kit.best_packing(problem.weights, conflicts, problem.item_shape_counts, None)
        assert expression.objective == pytest.approx(problem.unperturbed_objective(best), rel=1e-12)
        assert expression.items == tuple(problem.item_label(i) for i in best)
        assert expression.status is SolutionStatus.OPTIMAL and expression.termination is Termination.OPTIMAL
        assert expression.n_items == problem.n_items
        assert expression.vertex_rows == problem.n_vertex_rows and expression.clique_rows == len(
            problem.cliques
        )
        assert expression.backend == "test-exact"
        used.extend(expression.shapes)
    packing.check(crowded, expressions)


def test_an_expression_reads_its_solution_through(crowded, exact_solver):
    """Every attribute of the solution the expression does not derive itself reads through, with the
    solution's annotation (the records columns are typed by it)."""
    expression = packing.sequence(crowded, exact_solver, jmax=1)[0]
    own = {field.name for field in dataclasses.fields(Expression)}
    hints = typing.get_type_hints(Solution)
    read_through = {field.name: hints[field.name] for field in dataclasses.fields(Solution)}
    read_through["status"] = typing.get_type_hints(Solution.status.fget)["return"]
    assert own & read_through.keys() == {"items", "shapes", "objective"}
    for name, annotation in read_through.items():
        if name not in own:
            assert getattr(expression, name) == getattr(expression.solution, name), name
            assert typing.get_type_hints(getattr(Expression, name).fget)["return"] == annotation, name


def test_shapes_items_and_objective_are_the_sequences_own(crowded, exact_solver):
    """The sequence names the chosen items and evaluates eq. 3a on its own problem; what the solver claims
    stays in the solution."""

    class Boasting:
        def solve(self, problem, *, time_limit=None, seed=0):
            found = exact_solver.solve(problem, time_limit=time_limit, seed=seed)
            return dataclasses.replace(found, shapes=("nonsense",), objective=1e9)

    honest = packing.sequence(crowded, exact_solver)
    boasted = packing.sequence(crowded, Boasting())
    assert [e.shapes for e in boasted] == [e.shapes for e in honest]
    assert [e.items for e in boasted] == [e.items for e in honest]
    assert [e.objective for e in boasted] == [e.objective for e in honest]
    assert {e.solution.objective for e in boasted} == {1e9}


def test_jmax_stops_early(crowded, exact_solver):
    assert len(packing.sequence(crowded, exact_solver, jmax=2)) == 2
    assert packing.sequence(crowded, exact_solver, jmax=0) == []
    with pytest.raises(ValueError, match="jmax must be a non-negative integer or None, got -1"):
        packing.sequence(crowded, exact_solver, jmax=-1)


def test_importance_is_recomputed_from_the_used_shapes(crowded, exact_solver):
    seen = []

    class Recording:
        def solve(self, problem, *, time_limit=None, seed=0):
            seen.append(problem)
            return exact_solver.solve(problem, time_limit=time_limit, seed=seed)

    expressions = packing.sequence(crowded, Recording(), beta=0.5)
    analysis = packing.analyse(crowded, beta=0.5)
    used: list[str] = []
    for expression, problem in zip(expressions, seen, strict=True):
        expected = analysis.item_shapes @ packing.importance(crowded, beta=0.5, used=used)
        kept = problem.meta["item_index"]
        assert problem.unperturbed_objective(range(problem.n_items)) == pytest.approx(expected[kept].sum())
        used.extend(expression.shapes)
    assert len(seen) > 2


def _same_problem(derived, fresh):
    assert derived.items == fresh.items
    assert derived.weights.tolist() == fresh.weights.tolist()
    assert derived.tie_break.tolist() == fresh.tie_break.tolist()
    assert [c.tolist() for c in derived.cliques] == [c.tolist() for c in fresh.cliques]
    assert derived.n_vertex_rows == fresh.n_vertex_rows
    assert derived.incidence.shape == fresh.incidence.shape
    assert (derived.incidence != fresh.incidence).nnz == 0
    assert derived.item_shape_counts.tolist() == fresh.item_shape_counts.tolist()
    assert derived.item_active_counts.tolist() == fresh.item_active_counts.tolist()
    assert derived.cap == fresh.cap
    assert derived.meta["item_index"].tolist() == fresh.meta["item_index"].tolist()
    assert derived.meta["used"] == fresh.meta["used"]


@pytest.mark.parametrize("params", [{}, {"beta": 0.5}, {"max_per_expression": 3, "importance": False}])
def test_each_problem_of_the_sequence_equals_the_problem_from_the_used_shapes(crowded, exact_solver, params):
    """The sequence derives each problem from the previous one (`Analysis.next_problem`); it must be
    exactly the problem built for the shapes used so far (`Analysis.problem_for`)."""
    seen = []

    class Recording:
        def solve(self, problem, *, time_limit=None, seed=0):
            seen.append(problem)
            return exact_solver.solve(problem, time_limit=time_limit, seed=seed)

    analysis = packing.analyse(crowded, **params)
    expressions = packing.sequence(crowded, Recording(), analysis=analysis)
    used: list[str] = []
    for expression, problem in zip(expressions, seen, strict=True):
        _same_problem(problem, analysis.problem_for(used))
        assert expression.vertex_rows == problem.n_vertex_rows
        used.extend(expression.shapes)
    assert len(seen) > 2


def test_next_problem_on_a_generated_rig_follows_problem_for(exact_solver):
    rig = rigs.generate("arkit52", seed=0)
    analysis = packing.analyse(rig, beta=0.3)
    problem, used = analysis.problem_for(), []
    while problem.n_items:
        chosen = exact_solver.solve(problem).items
        used.extend(problem.shapes_of(chosen))
        problem = analysis.next_problem(problem, chosen, used)
        _same_problem(problem, analysis.problem_for(used))


def test_next_problem_refuses_problems_it_cannot_continue(crowded):
    analysis = packing.analyse(crowded)
    problem = analysis.problem_for()
    with pytest.raises(ValueError, match=r"chosen items must be in 0..\d+, got \[-1\]"):
        analysis.next_problem(problem, [-1])
    with pytest.raises(ValueError, match="without excluded shapes"):
        analysis.next_problem(analysis.problem_for(exclude=["blob0"]), [0])
    with pytest.raises(ValueError, match="problem of this analysis"):
        analysis.next_problem(packing.problem_from_incidence(np.eye(2, dtype=bool), [1.0, 1.0]), [0])


def test_the_analysis_is_done_once(crowded, exact_solver, monkeypatch):
    from packing._presolve import ConflictSets

    calls = []
    original = ConflictSets.from_incidence
    monkeypatch.setattr(
        ConflictSets, "from_incidence", classmethod(lambda cls, m: calls.append(1) or original(m))
    )
    expressions = packing.sequence(crowded, exact_solver)
    assert len(expressions) > 2 and len(calls) == 1


def test_a_shared_analysis_gives_the_same_sequence(crowded, exact_solver):
    analysis = packing.analyse(crowded, mu=0.4)
    shared = packing.sequence(crowded, exact_solver, analysis=analysis)
    assert [e.shapes for e in shared] == [e.shapes for e in packing.sequence(crowded, exact_solver, mu=0.4)]
    with pytest.raises(ValueError, match="either analysis or target_neutral/params"):
        packing.sequence(crowded, exact_solver, analysis=analysis, mu=0.4)
    other = rigs.generate("tiny", seed=0)
    with pytest.raises(ValueError, match="analysis was made for rig 'face_rig', not for 'generated:tiny'"):
        packing.sequence(other, exact_solver, analysis=analysis)


def test_cap_and_extra_examples(crowded, exact_solver):
    expressions = packing.sequence(crowded, exact_solver, max_per_expression=3, extra_examples=True)
    assert all(len(e.shapes) + len(e.extra_examples) <= 3 for e in expressions)
    assert any(e.extra_examples for e in expressions)
    primary = set()
    for expression in expressions:
        assert set(expression.extra_examples) <= primary
        primary.update(expression.shapes)
    packing.check(crowded, expressions, max_per_expression=3)
    plain = packing.sequence(crowded, exact_solver, max_per_expression=3)
    assert [e.shapes for e in plain] == [e.shapes for e in expressions]


def test_a_solver_that_returns_nothing_ends_the_sequence(crowded):
    class Failing:
        def solve(self, problem, *, time_limit=None, seed=0):
            return Solution((), (), 0.0, None, Termination.ERROR, backend="broken", message="licence expired")

    expressions = packing.sequence(crowded, Failing())
    assert len(expressions) == 1
    assert expressions[0].status is SolutionStatus.NONE and expressions[0].message == "licence expired"


def test_a_solver_answer_outside_the_problem_is_refused(crowded):
    class Wrong:
        def solve(self, problem, *, time_limit=None, seed=0):
            return Solution((problem.n_items,), (), 0.0, None, Termination.COMPLETED, backend="wrong")

    with pytest.raises(ValueError, match="solver wrong returned items .* outside 0..13"):
        packing.sequence(crowded, Wrong(), symmetry=False)


def test_time_limit_and_seed_reach_the_solver(crowded, exact_solver):
    received = []

    class Spy:
        def solve(self, problem, *, time_limit=None, seed=0):
            received.append((time_limit, seed))
            return exact_solver.solve(problem)

    packing.sequence(crowded, Spy(), jmax=1, time_limit=2.5, seed=11)
    assert received == [(2.5, 11)]


@pytest.mark.parametrize("preset", ["tiny", "arkit52"])
def test_generated_rigs_pack_completely_and_verify(preset, exact_solver):
    rig = rigs.generate(preset, seed=0)
    analysis = packing.analyse(rig, rig.neutral * [1.2, 1.0, 1.0])
    expressions = packing.sequence(rig, exact_solver, analysis=analysis)
    shapes = [name for e in expressions for name in e.shapes]
    assert sorted(shapes) == sorted(set(rig.names) - set(analysis.empty_names))
    assert len(expressions) >= packing.expression_lower_bound(analysis).lower
    packing.check(rig, expressions, pairs=analysis.pairs)
    packing.check(rig, expressions)
    assert repr(analysis).startswith(f"Analysis(rig='generated:{preset}', K={rig.n_shapes}")
