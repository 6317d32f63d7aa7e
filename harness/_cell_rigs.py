"""A cell's rigs and packing parameters: its template rig (checked against the digest the run's cell ids were
made from), the target (the template warped), both cached per process, and the keyword arguments of
`packing.analyse` and `packing.check` its packing settings give.

Every process that handles a cell reads them here: the worker that runs it (`harness._cell`), the process
that re-checks its answer (`harness._verify`), the run's parameter check (`harness._run`) and the export of
a run's reference sequences (`harness._instances_source`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

import rigs
from harness._grid import NO_WARP, CellSpec, rig_digest
from registry import BoundedMemo

if TYPE_CHECKING:
    from rigs import Rig

#: This process's last template and warped rigs, by (rig, digest, seed, warp).
_RIGS: BoundedMemo[Rig] = BoundedMemo(4)


class RigChangedError(RuntimeError):
    """The rig file's content is no longer the one the run's cell ids were made from."""


#: Identifies a cell's template rig: (rig argument, content digest, seed).
TemplateKey = tuple[str, str, int]


def template_key(spec: CellSpec) -> TemplateKey:
    """The key of a cell's template rig: cells with one key share one template."""
    return spec.rig, spec.rig_digest, spec.rig_seed


def generated(spec: CellSpec) -> bool:
    """Whether a cell's template rig is generated from a preset's name and seed (it reads no file)."""
    return not rigs.is_rig_path(spec.rig) and spec.rig in rigs.PRESETS


def verified_template(spec: CellSpec) -> Rig:
    """The template rig of a cell, after checking that its content still has the cell's digest (a rig file
    is read once: the rig returned is the content checked).

    Raises
    ------
    RigChangedError
        When a rig file no longer has the content digest of ``spec.rig_digest``.
    """
    if not (spec.rig_digest and rigs.is_rig_path(spec.rig)):
        return rigs.resolve(spec.rig, seed=spec.rig_seed)
    rig, inputs = rigs.load_with_inputs(spec.rig)
    found = rig_digest(spec.rig, spec.rig_seed, inputs)
    if found != spec.rig_digest:
        raise RigChangedError(
            f"rig {spec.rig} changed since the run started (content {found[:19]}..., "
            f"the run's cells were made for {spec.rig_digest[:19]}...)"
        )
    return rig


def template_rig(spec: CellSpec, given: Rig | None = None) -> Rig:
    """A cell's template rig, cached per process: ``given`` (its content as the harness read it), else read
    from ``spec.rig`` (`verified_template`)."""
    key = (*template_key(spec), NO_WARP)
    return _RIGS.get_or_build(key, lambda: verified_template(spec) if given is None else given)


def rig_pair(spec: CellSpec, template: Rig | None = None) -> tuple[Rig, Rig]:
    """Template rig and target rig (the template warped by ``spec.warp``) of a cell, cached per process.

    ``template``, when given, is the template's content read by the harness (`verified_template`), used
    instead of reading ``spec.rig`` here.

    Raises
    ------
    RigChangedError
        When a rig file no longer has the content digest of ``spec.rig_digest``.
    """
    source = template_rig(spec, template)
    if spec.warp == NO_WARP:
        return source, source
    return source, _RIGS.get_or_build((*template_key(spec), spec.warp), lambda: rigs.warp(source, spec.warp))


def packing_params(spec: CellSpec) -> dict[str, object]:
    """Keyword arguments of `packing.analyse` / `packing.check` for a cell (`packing.PackingParams`)."""
    params: dict[str, object] = {
        "mu": spec.mu,
        "alpha": spec.alpha,
        "beta": spec.beta,
        "symmetry": spec.symmetry,
        "importance": spec.importance,
        "max_per_expression": spec.cap,
        "distortion": spec.distortion,
        "together": spec.together,
        "apart": spec.apart,
    }
    if spec.regions:
        params["regions"] = {name: np.asarray(indices, dtype=np.int64) for name, indices in spec.regions}
    return params
