"""Independent verification of an expression sequence against a rig's raw deltas."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from packing._binary import rig_masks
from packing._params import params_from
from packing._solution import Termination
from packing._symmetry import detect_pairs
from registry import HarnessError
from rigs import Rig

#: Terminations after which a solver had the chance to fill its expression (a record's string compares
#: equal to its enum member).
_RAN_TO_END = (Termination.OPTIMAL, Termination.COMPLETED)


class CheckError(HarnessError):
    """An expression sequence breaks a rule of the method.

    Attributes
    ----------
    kind : str
        ``unknown`` (a name the rig lacks), ``duplicate`` (a shape twice in one expression), ``empty``
        (an empty shape packed), ``repeat`` (a shape the primary example of two expressions),
        ``extra`` (an extra example not used before, or also primary), ``pair`` (a symmetry pair
        split), ``together`` (an artist's together pair split), ``apart`` (an artist's apart pair in one
        expression), ``cap`` (too many shapes), ``overlap`` (two shapes share an active vertex), ``bound``
        (a solver's bound below its objective), ``infeasible`` (a solver's verdict that the expression's
        problem has no solution), ``maximal`` (an unused item still fits).
    expression : int
        1-based index of the offending expression.
    """

    def __init__(self, message: str, *, kind: str, expression: int) -> None:
        super().__init__(f"expression {expression}: {message}")
        self.kind = kind
        self.expression = expression


def check(
    rig: Rig,
    expressions: Iterable[Any],
    *,
    pairs: Iterable[tuple[str, str]] | None = None,
    overlap: float = 0.0,
    maximal: bool = False,
    rejected: Mapping[int, Iterable[str]] | None = None,
    **params: Any,
) -> None:
    """Verify an expression sequence from the rig's raw deltas, not from any packing model.

    The binary blendshapes are recomputed here from ``rig.deltas`` with the given ``mu`` (eq. 2, by
    `packing._binary.rig_masks`, the definition the analysis uses), and
    the symmetry pairs are detected again with the given parameters unless ``pairs`` are given. For
    each expression in order, the first violation raises:

    1. every name is a blendshape of the rig (``unknown``);
    2. no shape appears twice in the expression, primary or extra (``duplicate``);
    3. no empty shape is packed (``empty``);
    4. every shape is the primary example of at most one expression (``repeat``);
    5. extra examples (sec. 6) were primary examples of an earlier expression (``extra``; a shape both
       primary and extra in one expression is a ``duplicate``);
    6. both shapes of a symmetry pair appear together, both primary or both extra (``pair``, eq. 3d),
       and so do the artist's together pairs (``together``);
    7. no artist's apart pair shares the expression (``apart``);
    8. the expression holds at most ``max_per_expression`` shapes, extras included (``cap``, sec. 6);
    9. no two of its shapes share an active vertex (``overlap``, eq. 3b), except the two shapes of a
       symmetry pair: the pair is one item whose vertex set is their union (sec. 4.4), so overlap
       between its own shapes is allowed. With ``overlap > 0`` (Algorithm 2 with allowed overlap),
       the items must instead admit an order of addition in which each overlaps the items before it
       by at most ``floor(overlap * |b_item|)`` active vertices;
    10. a solver's bound is not below its objective (``bound``), for expressions that carry both, and
        no solver answered that the expression's problem is infeasible (``infeasible``): eq. 3 always
        has a solution (choosing nothing, and any one available item alone satisfies eq. 3b-3d), so
        that verdict is false, and an empty answer would end the sequence with shapes left unused;
    11. with ``maximal``, an expression whose solver ran to its end (termination ``optimal`` or
        ``completed``) leaves no unused packable item that would still fit beside its primary shapes
        (``maximal``): every item has positive weight, so an optimum is maximal, and Algorithm 2 only
        drops an item that does not fit. Shapes the artist ``rejected`` for that expression are not
        counted as fitting.

    Parameters
    ----------
    rig : Rig
    expressions : iterable
        Each an object with ``.shapes`` (and optionally ``.extra_examples``, ``.objective``, ``.bound``,
        ``.termination``), a mapping with the keys ``"shapes"`` (and ``"extra_examples"``) as in
        ``expressions.json``, or a sequence of names.
    pairs : iterable of (str, str), optional
        The symmetry pairs to enforce; default: detected again with ``params``.
    overlap : float in [0, 1)
        Fraction of an item's active vertices allowed to overlap (greedy with overlap, sec. 4.5.2);
        0 is the strict packing of eq. 3b. Pass the solver's declared ``capabilities.max_overlap``.
    maximal : bool
        Also require maximal expressions (rule 11).
    rejected : mapping of int to names, optional
        1-based expression number -> shapes the artist rejected there (sec. 4.5.3).
    **params
        The `PackingParams` of the run (``mu``, ``symmetry``, ``max_per_expression``, ``together``,
        ``apart``, ...).

    Raises
    ------
    CheckError
        With the first violation, naming the expression, the shapes and the vertex.
    ValueError
        For bad parameters.
    """
    settings = params_from(**params)
    if not 0.0 <= overlap < 1.0:
        raise ValueError(f"overlap must be a fraction in [0, 1), got {overlap!r}")
    lengths, empty, active = rig_masks(rig, settings.mu, settings.noise_floor)
    if pairs is None:
        found = detect_pairs(rig, lengths, active, empty, settings).pairs
        pairs = [(rig.names[a], rig.names[b]) for a, b in found]
    rules = _Rules(
        position={name: k for k, name in enumerate(rig.names)},
        partner=_partners([*pairs, *settings.together]),
        together=set(map(frozenset, settings.together)),
        apart=[frozenset(pair) for pair in settings.apart],
        empty=empty,
        active=active,
        cap=settings.max_per_expression,
        overlap=overlap,
    )
    rejected = {int(k): set(v) for k, v in (rejected or {}).items()}
    primary_before: set[str] = set()
    for number, expression in enumerate(expressions, start=1):
        primary, extra = _shapes_of(expression)
        rules.check_expression(number, primary, extra, primary_before)
        _check_bound(number, expression)
        _check_feasible(number, expression)
        if maximal and getattr(expression, "termination", None) in _RAN_TO_END:
            rules.check_maximal(number, primary, primary_before, rejected.get(number, set()))
        primary_before.update(primary)


def _partners(pairs: Iterable[tuple[str, str]]) -> dict[str, str]:
    partner: dict[str, str] = {}
    for a, b in pairs:
        partner[a], partner[b] = b, a
    return partner


def _check_bound(number: int, expression: Any) -> None:
    """Rule 10: a bound at least the objective (to 1e-9 relative, the backends' double precision)."""
    bound, objective = getattr(expression, "bound", None), getattr(expression, "objective", None)
    if bound is None or objective is None:
        return
    if not float(bound) >= float(objective) - 1e-9 * max(1.0, abs(float(objective))):
        raise CheckError(f"the solver's bound {bound!r} is below its objective {objective!r}", kind="bound",
                         expression=number)  # fmt: skip


def _check_feasible(number: int, expression: Any) -> None:
    """Rule 10, second half: no expression's problem is declared infeasible."""
    if getattr(expression, "termination", None) == Termination.INFEASIBLE:
        raise CheckError(
            "the solver answered infeasible, but a packing problem always has a solution (choosing "
            "nothing; any one available item alone)",
            kind="infeasible",
            expression=number,
        )


@dataclass(frozen=True)
class _Rules:
    """What every expression of one sequence is checked against."""

    position: Mapping[str, int]
    partner: Mapping[str, str]
    together: set[frozenset[str]]
    apart: list[frozenset[str]]
    empty: np.ndarray
    active: np.ndarray
    cap: int | None
    overlap: float

    def check_expression(
        self, number: int, primary: tuple[str, ...], extra: tuple[str, ...], primary_before: set[str]
    ) -> None:
        """Rules 1-9 for one expression."""

        def fail(kind: str, message: str) -> None:
            raise CheckError(message, kind=kind, expression=number)

        position, partner = self.position, self.partner
        shapes = primary + extra
        for name in shapes:
            if name not in position:
                fail("unknown", f"no blendshape named {name!r} in the rig")
        seen: set[str] = set()
        for name in shapes:
            if name in seen:
                fail("duplicate", f"{name!r} appears twice")
            seen.add(name)
        for name in shapes:
            if self.empty[position[name]]:
                fail("empty", f"{name!r} is an empty blendshape and cannot be packed")
        for name in primary:
            if name in primary_before:
                fail("repeat", f"{name!r} was already the primary example of an earlier expression")
        for name in extra:
            if name not in primary_before:
                fail("extra", f"extra example {name!r} was not the primary example of an earlier expression")
        for group, label in ((primary, "primary"), (extra, "extra")):
            members = set(group)
            for name in group:
                if name in partner and partner[name] not in members:
                    kind = "together" if frozenset((name, partner[name])) in self.together else "pair"
                    what = "together partner" if kind == "together" else "symmetry partner"
                    fail(kind, f"{name!r} is {label} without its {what} {partner[name]!r}")
        for pair in self.apart:
            if pair <= seen:
                a, b = sorted(pair)
                fail("apart", f"{a!r} and {b!r} are to be kept apart but share the expression")
        if self.cap is not None and len(shapes) > self.cap:
            fail("cap", f"{len(shapes)} blendshapes exceed max_per_expression={self.cap}")
        if len(shapes) < 2:
            return
        masks = self.active[np.array([position[name] for name in shapes])]
        if self.overlap == 0:
            shared = masks.astype(np.float64) @ masks.T.astype(np.float64)
            for i, j in zip(*np.nonzero(np.triu(shared, k=1)), strict=True):
                a, b = shapes[i], shapes[j]
                if partner.get(a) == b:
                    continue
                vertex = int(np.flatnonzero(masks[i] & masks[j])[0])
                fail(
                    "overlap",
                    f"{a!r} and {b!r} share {int(shared[i, j])} active vertices (first: vertex {vertex})",
                )
            return
        stuck = _unorderable_items(shapes, masks, partner, self.overlap)
        if stuck:
            fail(
                "overlap",
                f"no order of adding {', '.join(map(repr, stuck))} keeps each item's overlap with the items "
                f"before it within overlap={self.overlap:g} of its active vertices",
            )

    def check_maximal(
        self, number: int, primary: tuple[str, ...], primary_before: set[str], rejected: set[str]
    ) -> None:
        """Rule 11: no unused, unrejected packable item fits beside the primary shapes."""
        if any(name not in self.position for name in primary):
            return  # rule 1 has already failed for such an expression
        occupied = self.active[[self.position[name] for name in primary]].any(axis=0)
        room = None if self.cap is None else self.cap - len(primary)
        members = set(primary)
        for name, k in self.position.items():
            mate = self.partner.get(name)
            if self.empty[k] or name in primary_before or name in members or name in rejected:
                continue
            if mate is not None and (mate < name or mate in primary_before or mate in rejected):
                continue  # the pair is visited from its first name; a used or rejected half blocks it
            item = [name] if mate is None else [name, mate]
            if room is not None and len(item) > room:
                continue
            if any(pair <= members | set(item) and not pair <= set(item) for pair in self.apart):
                continue
            mask = self.active[[self.position[n] for n in item]].any(axis=0)
            allowed = np.floor(self.overlap * np.count_nonzero(mask) + 1e-9)
            if np.count_nonzero(mask & occupied) <= allowed:
                raise CheckError(
                    f"{'+'.join(item)} is unused and still fits beside {', '.join(primary) or 'nothing'}",
                    kind="maximal",
                    expression=number,
                )


def _unorderable_items(
    shapes: tuple[str, ...], masks: np.ndarray, partner: Mapping[str, str], overlap: float
) -> list[str]:
    """Items left when peeling off, one by one, any item whose overlap with the rest is allowed.

    An order of addition in which every item overlaps the items before it by at most
    ``floor(overlap * |b_item|)`` vertices (Algorithm 2 with allowed overlap) exists iff peeling
    empties the expression: an item's overlap with the others only shrinks as items are removed.
    """
    labels: list[str] = []
    rows: list[np.ndarray] = []
    for i, name in enumerate(shapes):
        if name in partner and partner[name] in shapes[:i]:
            continue
        mate = shapes.index(partner[name]) if partner.get(name) in shapes else None
        labels.append(name if mate is None else f"{name}+{partner[name]}")
        rows.append(masks[i] if mate is None else masks[i] | masks[mate])
    items = np.array(rows)
    allowed = np.floor(overlap * items.sum(axis=1) + 1e-9)
    left = list(range(len(labels)))
    while left:
        cover = items[left].sum(axis=0)
        overlaps = (items[left] & (cover > 1)).sum(axis=1)
        free = [item for item, count in zip(left, overlaps, strict=True) if count <= allowed[item]]
        if not free:
            break
        left.remove(free[0])
    return [labels[item] for item in left]


def _shapes_of(expression: Any) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Primary and extra shape names of an Expression, a mapping or a plain sequence of names."""
    if isinstance(expression, Mapping):
        return tuple(expression.get("shapes", ())), tuple(expression.get("extra_examples", ()) or ())
    if hasattr(expression, "shapes"):
        return tuple(expression.shapes), tuple(getattr(expression, "extra_examples", ()) or ())
    if isinstance(expression, Sequence) and not isinstance(expression, str):
        return tuple(expression), ()
    raise TypeError(
        f"cannot read the shapes of {expression!r}: need .shapes, a 'shapes' key or a list of names"
    )
