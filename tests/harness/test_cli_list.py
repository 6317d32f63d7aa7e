"""``harness list``: a one-line description of every solver and transfer, in the table and in ``--json``."""

from __future__ import annotations

import json

from click.testing import CliRunner

from harness._plugins import describe
from harness.cli import cli


def _listed(*arguments: str) -> str:
    result = CliRunner(env={"COLUMNS": "400"}).invoke(cli, ["list", *arguments])
    assert result.exit_code == 0, result.output
    return result.output


def test_every_loaded_plugin_has_a_description_with_its_overlap_or_examples() -> None:
    found = json.loads(_listed("--json"))
    solvers = {item["name"]: item for item in found["solvers"] if item["capabilities"]}
    transfers = {item["name"]: item for item in found["transfers"] if item["available"]}
    assert {"cpsat", "greedy", "greedy-overlap"} <= set(solvers) and {"delta", "ebfr"} <= set(transfers)
    for item in solvers.values():
        overlap = item["capabilities"]["max_overlap"]
        clause = "never overlap" if overlap == 0 else f"may overlap: up to {overlap:.0%}"
        assert clause in item["description"], item
        assert len(item["description"]) > len(clause) + 20, item  # what it is, from its class
    for item in transfers.values():
        clause = "Uses the" if item["capabilities"]["uses_examples"] else "Ignores the"
        assert f"{clause} training examples." in item["description"], item
    assert solvers["cpsat"]["description"].startswith("Eq. 3 as a CP-SAT model")
    assert transfers["ebfr"]["description"].startswith("Example-based facial rigging")


def test_the_table_shows_the_descriptions() -> None:
    listing = _listed()
    assert "what it is, can do and takes" in listing
    assert "Shapes in one expression may overlap: up to 10%" in listing
    assert "Ignores the training examples." in listing


def test_the_table_reads_at_80_columns() -> None:
    result = CliRunner(env={"COLUMNS": "80"}).invoke(cli, ["list"])
    assert result.exit_code == 0, result.output
    assert max(len(line) for line in result.output.splitlines()) <= 80
    words = " ".join(line.strip() for line in result.output.splitlines())
    assert "what it is, can do and takes" in words and "available" in words  # headers whole, not cut
    assert "settings: workers=1: an integer in" in words  # cpsat's setting, folded at a space


def test_a_third_party_solver_is_described_from_its_docstring(test_plugins) -> None:
    found = {item["name"]: item for item in json.loads(_listed("--json"))["solvers"]}
    assert found["sleepy"]["description"] == (
        "Greedy, after sleeping HARNESS_TEST_SLEEP seconds on the test sheet rig (not on warm-up problems). "
        "Shapes in one expression never overlap."
    )
    # no docstring of its own: only what its capabilities say, not the docstring of the class it extends
    assert found["raising"]["description"] == "Shapes in one expression never overlap."


class _Documented:
    """First line of the summary,
    continued here.

    Details that are not shown.
    """


class _Described(_Documented):
    """Not this."""

    description = "  The plugin's own words.  "


class _Inheriting(_Documented):
    pass


def test_describe_prefers_the_description_then_the_own_docstring() -> None:
    assert describe(_Documented) == "First line of the summary, continued here."  # the whole first paragraph
    assert describe(_Described) == "The plugin's own words."
    assert describe(_Described()) == "The plugin's own words."  # an instance is described by its class
    assert describe(_Inheriting) == ""
