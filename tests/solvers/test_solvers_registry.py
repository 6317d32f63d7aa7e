"""Entry-point discovery: lazy listing, availability with reasons, load errors, duplicates."""

import importlib.metadata
import json
import subprocess
import sys

import pytest

import registry
import solvers
from solvers import _registry
from solvers._base import Availability, AvailabilityStatus, package_availability
from solvers.highs import HighsSolver

BACKEND_MODULES = ("ortools", "highspy", "mip", "pulp", "pyscipopt")


@pytest.fixture
def fake_plugins():
    def install(*specs):
        points = [importlib.metadata.EntryPoint(name, value, _registry.GROUP) for name, value in specs]
        _registry.SOLVERS.refresh()
        _registry.SOLVERS.__dict__["_points"] = registry.collect(points, "solver")

    yield install
    _registry.SOLVERS.refresh()


def test_all_built_in_plugins_are_registered():
    assert {"cbc-mip", "cbc-pulp", "cpsat", "highs", "scip", "naive-pulp-cbc", "greedy", "greedy-overlap",
            "greedy-swap"} <= set(solvers.names())  # fmt: skip
    assert solvers.names() == sorted(solvers.names())


def test_listing_and_availability_never_import_a_backend():
    code = (
        "import sys, json, solvers\n"
        "solvers.names(available_only=True)\n"
        "rows = [row.as_dict() for row in solvers.info()]\n"
        f"print(json.dumps([m for m in {BACKEND_MODULES!r} if m in sys.modules]))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert json.loads(result.stdout) == []


def test_info_is_json_ready_with_reasons_and_capabilities():
    rows = [row.as_dict() for row in solvers.info()]
    json.dumps(rows)
    by_name = {row["name"]: row for row in rows}
    assert by_name["highs"]["capabilities"]["exact"] is True
    assert by_name["greedy"]["capabilities"]["exact"] is False
    assert by_name["greedy-overlap"]["capabilities"]["strict"] is False
    assert by_name["cbc-mip"]["capabilities"]["isolated_process"] is True
    for row in rows:
        assert row["available"] or row["reason"], row


def test_unknown_name_lists_the_valid_ones():
    with pytest.raises(
        solvers.UnknownSolverError, match=r"unknown solver 'gurobi'; valid names: .*cpsat.*highs"
    ):
        solvers.get("gurobi")


def test_get_passes_parameters_and_rejects_unknown_ones():
    assert solvers.get("greedy-overlap", overlap=0.3).plugin.overlap == 0.3
    assert solvers.get("greedy-overlap", overlap=0.3).capabilities.max_overlap == 0.3
    with pytest.raises(
        ValueError, match=r"highs has no setting 'workers' \(its settings: presolve, mip_heur"
    ):
        solvers.get("highs", workers=4)
    with pytest.raises(TypeError, match="does not take parameters"):
        solvers.get("greedy", overlap=0.3)
    with pytest.raises(ValueError, match=r"overlap must be a number in \[0, 1\), got 1.5"):
        solvers.get("greedy-overlap", overlap=1.5)


def test_plugin_that_fails_to_import_is_listed_unavailable(fake_plugins):
    fake_plugins(("broken", "no_such_module_anywhere:Solver"), ("greedy", "solvers.greedy:GreedySolver"))
    assert solvers.names() == ["broken", "greedy"]
    assert solvers.names(available_only=True) == ["greedy"]
    found = solvers.availability("broken")
    assert found.status is AvailabilityStatus.LOAD_ERROR and not found
    assert "no_such_module_anywhere" in found.reason
    with pytest.raises(solvers.SolverUnavailableError, match="load_error"):
        solvers.get("broken")
    assert solvers.get("greedy").name == "greedy"


def test_object_that_is_not_a_solver_is_a_load_error(fake_plugins):
    fake_plugins(("numpy-sum", "numpy:sum"), ("renamed", "solvers.greedy:GreedySolver"))
    assert "is not a Solver" in solvers.availability("numpy-sum").reason
    assert "declares name 'greedy'" in solvers.availability("renamed").reason


def test_duplicate_names_warn_and_keep_the_first():
    points = [
        importlib.metadata.EntryPoint("greedy", "solvers.greedy:GreedySolver", _registry.GROUP),
        importlib.metadata.EntryPoint("greedy", "other_pkg:Greedy", _registry.GROUP),
        importlib.metadata.EntryPoint("greedy", "solvers.greedy:GreedySolver", _registry.GROUP),
    ]
    with pytest.warns(
        RuntimeWarning,
        match="solver .greedy. is registered twice: solvers.greedy:GreedySolver .* other_pkg:Greedy",
    ):
        found = registry.collect(points, "solver")
    assert found["greedy"].value == "solvers.greedy:GreedySolver"


def test_missing_package_says_which_and_how_to_install():
    found = package_availability("surely-not-installed-dist", hint="pip install it")
    assert not found and found.status is AvailabilityStatus.MISSING_PACKAGE
    assert found.reason == "package 'surely-not-installed-dist' is not installed; pip install it"


def test_missing_backend_is_unavailable_and_skipped(fake_plugins, monkeypatch):
    class NeedsMissing(HighsSolver):
        name = "needs-missing"

        @classmethod
        def availability(cls):
            return package_availability("surely-not-installed-dist")

    monkeypatch.setattr(sys.modules[__name__], "NeedsMissing", NeedsMissing, raising=False)
    fake_plugins(("needs-missing", f"{__name__}:NeedsMissing"))
    info = solvers.info()[0]
    assert (info.available, info.status) == (False, "missing_package")
    assert solvers.names(available_only=True) == []
    with pytest.raises(solvers.SolverUnavailableError, match="surely-not-installed-dist"):
        solvers.get("needs-missing")


def test_highspy_that_cannot_load_beside_ortools_is_a_version_mismatch(monkeypatch):
    real = importlib.metadata.version
    monkeypatch.setattr(
        importlib.metadata, "version", lambda dist: "1.15.1" if dist == "highspy" else real(dist)
    )
    found = HighsSolver.availability()
    assert found.status is AvailabilityStatus.VERSION_MISMATCH
    assert "pip install highspy==1.12.0" in found.reason


def test_availability_is_truthy_only_when_available():
    assert Availability.available("1.0")
    assert not Availability.missing_binary("cbc")
    assert not Availability.load_error(ImportError("boom"))
    assert Availability.load_error(ImportError("boom")).reason == "ImportError: boom"
