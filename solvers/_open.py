"""An expression being filled one item at a time: what a heuristic plugin needs to stay valid.

Eq. 3b (no vertex active in two chosen items, or at most the declared overlap of sec. 4.5.2), the cap of
sec. 6 and the artist's apart pairs, checked per item in O(|b_k|) so that a heuristic is a loop over items
in its own order.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from packing import PackingProblem


class OpenExpression:
    """The items chosen so far for one expression of ``problem``, and whether another one fits.

    Parameters
    ----------
    problem : PackingProblem
    overlap : float in [0, 1)
        Share of an item's active vertices that may already be active in the expression when it joins
        (Algorithm 2 with allowed overlap, sec. 4.5.2); 0 is eq. 3b.

    Examples
    --------
    First fit in index order, a complete heuristic:

    >>> import numpy as np
    >>> from packing import problem_from_incidence
    >>> problem = problem_from_incidence(np.array([[1, 1, 0], [0, 1, 1], [0, 0, 1]]), [0.5, 0.9, 0.4])
    >>> expression = OpenExpression(problem)
    >>> for item in range(problem.n_items):
    ...     if expression.fits(item):
    ...         expression.add(item)
    >>> expression.items
    (0, 2)
    """

    def __init__(self, problem: PackingProblem, overlap: float = 0.0) -> None:
        if not 0.0 <= overlap < 1.0:
            raise ValueError(f"overlap must be a fraction in [0, 1), got {overlap!r}")
        self.problem = problem
        self._indptr, self._indices = problem.incidence.indptr, problem.incidence.indices
        self._allowed = np.floor(overlap * problem.item_active_counts + 1e-9).astype(np.int64)
        self._active = np.zeros(problem.incidence.shape[1], dtype=bool)
        self._barred = np.zeros(problem.n_items, dtype=bool)  # apart from a chosen item
        self._partners: dict[int, list[int]] = {}
        for a, b in problem.apart:
            self._partners.setdefault(a, []).append(b)
            self._partners.setdefault(b, []).append(a)
        self._room = np.inf if problem.cap is None else problem.cap
        self._items: list[int] = []

    @property
    def items(self) -> tuple[int, ...]:
        """The chosen items, in the order they were added."""
        return tuple(self._items)

    def fits(self, item: int) -> bool:
        """Whether ``item`` can join: not chosen, room under the cap, no apart partner chosen, and its
        active vertices already active here at most the allowed overlap."""
        if self._barred[item] or self.problem.item_shape_counts[item] > self._room:
            return False
        vertices = self._indices[self._indptr[item] : self._indptr[item + 1]]
        return np.count_nonzero(self._active[vertices]) <= self._allowed[item]

    def add(self, item: int) -> None:
        """Choose ``item`` (check `fits` first; adding an item that does not fit raises ValueError)."""
        if not self.fits(item):
            raise ValueError(f"item {item} does not fit the expression {self.items}")
        self._active[self._indices[self._indptr[item] : self._indptr[item + 1]]] = True
        self._barred[item] = True
        self._barred[self._partners.get(item, [])] = True
        self._room -= int(self.problem.item_shape_counts[item])
        self._items.append(int(item))
