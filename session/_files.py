"""The files of a scanning session folder, besides ``expressions.json``.

* ``neutral.obj`` and ``expression_XX.obj`` (`session._mesh`), and with a target
  ``on_target/expression_XX.obj``; ``materials.mtl`` beside them for a glTF rig with materials;
* ``expressions.glb`` (``glb``): the template with one morph target per expression (its summed
  deltas), named ``expression_XX``, for tools that take glTF;
* ``pictures/expression_XX_front.png``, ``..._front_pose.png`` and ``..._three_quarter_pose.png``: the
  expression from the front with its shapes coloured and named, and its bare pose from the front and
  at three-quarters (`session._pictures`);
* ``session.html``: the scan sheet (`session._sheet`).

Each expression of the document gains ``files``: the names of its mesh, target mesh and pictures.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from concurrent.futures import Future
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from render import shape_colours
from session._mesh import ON_TARGET, TargetMesh, expression_name, expression_poses, session_meshes
from session._picture_set import Legend
from session._pictures import Scene, session_pictures
from session._sheet import Card, scan_sheet
from session._words import plain_words

if TYPE_CHECKING:
    from rigs import Rig

GLB_FILE = "expressions.glb"
SHEET_FILE = "session.html"


def session_files(
    rig: Rig,
    document: dict[str, Any],
    *,
    target: TargetMesh | None = None,
    pictures: bool = True,
    glb: bool = False,
    notes: Sequence[str] = (),
    scene: Future[Scene] | None = None,
) -> Iterator[tuple[str, str | bytes]]:
    """(file name relative to the folder, content) of every session file, made one at a time so that the
    writer stores each before the next is made (`registry.OutputFolder.replace`);
    ``document["expressions"]`` entries gain their ``files`` as they are made.

    Parameters
    ----------
    rig : rigs.Rig
        The template the expressions were packed from.
    document : dict
        ``expressions.json`` (``params.mu`` colours the active vertices, eq. 2; ``pairs`` groups the
        legend's colours).
    target : TargetMesh, optional
    pictures : bool
        Render the pictures (the scan sheet is written either way, with pictures when there are).
    glb : bool
        Also write ``expressions.glb``.
    notes : sequence of str
        What packing noted and warned: the scan sheet's page for the TD (`session._notes.td_notes`).
    scene : Future of Scene, optional
        The pictures' `Scene` of ``rig`` at the document's ``mu``, prepared ahead
        (`session._pictures.prepare_scene`).
    """
    expressions = document["expressions"]
    for index, expression in enumerate(expressions, start=1):
        name = expression_name(index, len(expressions))
        expression["files"] = {"mesh": f"{name}.obj"}
        if target is not None:
            expression["files"]["on_target"] = f"{ON_TARGET}/{name}.obj"
    legends = [_legend(expression, document.get("pairs", ())) for expression in expressions]
    mu = float(document["params"]["mu"])
    rendering = (
        session_pictures(rig, expressions, legends, mu, scene=scene) if pictures and expressions else None
    )
    try:  # the pictures render while the meshes are written
        yield from session_meshes(rig, expressions, target)
        if glb:
            yield GLB_FILE, _glb(rig, expressions)
        if rendering is not None:
            yield from rendering
    finally:
        if rendering is not None:
            rendering.close()
    cards: list[Card] = []
    for expression, legend in zip(expressions, legends, strict=True):
        cards.append(
            {
                "files": expression["files"],
                "objective": expression["objective"],
                "legend": legend,
            }
        )
    title = str(document.get("rig", rig.provenance.label))
    yield SHEET_FILE, scan_sheet(document, cards, title=title, notes=notes)


def _legend(expression: Mapping[str, Any], pairs: Sequence[Sequence[str]]) -> Legend:
    """``(plain words, name, colour, extra?)`` of each shape of an expression, symmetry pairs side by side
    (the two tones of one hue), then the extra examples."""
    partner = {a: b for a, b in pairs} | {b: a for a, b in pairs}
    groups: list[list[tuple[str, bool]]] = []
    for names, extra in ((expression["shapes"], False), (expression.get("extra_examples", ()), True)):
        placed: set[str] = set()
        for name in names:
            if name in placed:
                continue
            group = [name]
            if partner.get(name) in names and partner[name] not in placed:
                group.append(partner[name])
            placed.update(group)
            groups.append([(member, extra) for member in group])
    colours = shape_colours([len(group) for group in groups])
    flat = [member for group in groups for member in group]
    return [
        (plain_words(name), name, colour, extra) for (name, extra), colour in zip(flat, colours, strict=True)
    ]


def _glb(rig: Rig, expressions: Sequence[Mapping[str, Any]]) -> bytes:
    """The template with one morph target per expression."""
    from rigs import glb_bytes

    names = tuple(expression_name(index, len(expressions)) for index in range(1, len(expressions) + 1))
    posed = replace(rig, deltas=expression_poses(rig, expressions), names=names, regions={})
    return glb_bytes(posed, mesh_name=rig.provenance.mesh or "face")
