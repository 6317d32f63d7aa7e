"""The constraints of a scanning session beyond the artist's pairs: shapes left out, and the anatomical rules.

``harness pack --exclude SHAPE`` leaves shapes out of the whole session; the anatomical rules shipped with
`packing` (``packing/face_rules.toml``: the two eyes look the same way, a closed lid hides the eye, the
tongue does not come out between closed lips, ...) apply by default to a rig whose names match
(`packing._face_rules`), unless ``--no-default-constraints``. The rules yield to the artist's own
``--together``/``--apart`` pairs and say so. The session packs the rig without the left-out shapes, with
the rules' pairs added to the artist's; ``expressions.json`` lists the rules applied under
``constraints`` and every left-out shape in ``excluded`` with its reason.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from harness import check_file_pairs
from registry import HarnessError

if TYPE_CHECKING:
    from rigs import Rig


@dataclass(frozen=True)
class SessionConstraints:
    """What the session packs, once shapes are left out and the rules added.

    Attributes
    ----------
    rig : Rig
        The rig without the left-out shapes.
    params : dict
        The packing parameters with the rules' together and apart pairs after the artist's.
    excluded : dict of str -> str
        Left-out shape -> why, in rig order.
    document : dict
        The ``constraints`` entry of ``expressions.json``: ``default`` (whether the rules were on),
        ``rules`` (``{"rule", "kind", "shapes", "why"}`` of every pair applied) and ``notes``.
    notes : list of str
        For the user: the rules applied, those that could not be, the shapes left out.
    """

    rig: Rig
    params: dict[str, Any]
    excluded: dict[str, str]
    document: dict[str, Any]
    notes: list[str] = field(default_factory=list)


def parse_exclusions(values: Iterable[str]) -> tuple[str, ...]:
    """``("a,b", "c")`` -> ``("a", "b", "c")``: the shapes of every ``--exclude`` (comma lists), each once."""
    return tuple(dict.fromkeys(name.strip() for value in values for name in value.split(",") if name.strip()))


def session_constraints(
    rig: Rig, params: Mapping[str, Any], *, exclude: Sequence[str] = (), default: bool = True
) -> SessionConstraints:
    """Leave the ``exclude`` shapes out of ``rig`` and add the anatomical rules (with ``default``).

    ``params`` may hold ``constraint_origins`` (`harness._cli_constraints.constraint_params`): the
    constraints file of each pair read from one, named when the pair names a shape the rig lacks; it is
    not a packing parameter and is left out of the session's.

    Raises
    ------
    ValueError
        For a shape the rig lacks (with close matches; naming the constraints file of a pair read from one),
        a left-out shape the artist also constrains, or a session left without shapes.
    """
    import packing
    from packing import match_rules, read_rules

    params = dict(params)
    check_file_pairs(rig, params, params.pop("constraint_origins", {}))
    for name in exclude:
        rig.index(name)  # RigError names the rig, the shape and close matches
    together, apart = tuple(params.get("together", ())), tuple(params.get("apart", ()))
    constrained = sorted({name for pair in (*together, *apart) for name in pair} & set(exclude))
    if constrained:
        raise HarnessError(f"--exclude {constrained[0]}: the shape is also in a --together or --apart pair")
    excluded = dict.fromkeys(exclude, "left out by --exclude")
    document: dict[str, Any] = {"default": default, "rules": [], "notes": []}
    if default:
        floor = params.get("noise_floor", packing.PackingParams.noise_floor)
        empty = packing.empty_shapes(rig, noise_floor=floor)
        matched = match_rules(
            rig.names,
            read_rules(),
            together=together,
            apart=apart,
            skip={*exclude, *empty},
            single=params.get("max_per_expression") == 1,
        )
        excluded.update(
            (name, f"left out by the default constraints: {why}") for name, why in matched.excluded.items()
        )
        params = {**params, "together": (*together, *matched.together), "apart": (*apart, *matched.apart)}
        document.update(rules=matched.applied, notes=matched.notes)
    kept = [name for name in rig.names if name not in excluded]
    source = rig.provenance.source or "the rig"
    if not rig.names:
        raise HarnessError(f"{source}: the rig has no blendshapes to pack")
    if not kept:
        by_rules = len(excluded) > len(set(exclude))
        what = {
            (True, False): "--exclude leaves",
            (True, True): "--exclude and the default constraints leave",
            (False, True): "the default constraints (--no-default-constraints turns them off) leave",
        }[(bool(exclude), by_rules)]
        raise HarnessError(f"{what} no shape of {source} to pack")
    excluded = {name: excluded[name] for name in rig.names if name in excluded}
    return SessionConstraints(
        rig.subset(kept) if excluded else rig, dict(params), excluded, document, _notes(document, excluded)
    )


def _notes(document: Mapping[str, Any], excluded: Mapping[str, str]) -> list[str]:
    if not document["default"]:
        notes = ["default constraints off"]
    elif document["rules"]:
        names = ", ".join(dict.fromkeys(entry["rule"] for entry in document["rules"]))
        notes = [
            f"default constraints: {len(document['rules'])} pairs of {names} "
            "(see expressions.json; off with --no-default-constraints)"
        ]
    else:
        notes = ["default constraints: no rule matches the rig's shape names"]
    notes += document["notes"]
    if excluded:
        listed = "; ".join(f"{name} ({why})" for name, why in excluded.items())
        shapes = "shape" if len(excluded) == 1 else "shapes"
        notes.append(f"{len(excluded)} {shapes} left out of the session: {listed}")
    return notes
