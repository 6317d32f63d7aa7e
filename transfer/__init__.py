"""Blendshape transfer: what a choice of training expressions is worth (Carrigan et al. 2020, sec. 5).

Methods are plugins in the ``harness.transfers`` entry-point group, each a callable
``(template, target_neutral, weights, examples) -> (K, N, 3) deltas``:

- ``delta``: copy the template's displacements;
- ``dt``: deformation transfer (Sumner & Popovic 2004);
- ``ebfr``: example-based facial rigging in gradient space with known 0/1 weights (Li et al. 2010, step A);
- ``ebfr-full``: the same alternating with weight re-estimation (Li et al. 2010, steps A and B);
- ``plbs``: patchwise linear blendshapes plus deformation transfer of the residual (Wagner et al. 2024).

``method.prefixes(template, target_neutral, weights, examples)`` gives the method trained on the first J
expressions as a function of J (Carrigan et al. 2020, sec. 5.2 evaluate sequences by their first J);
``ebfr`` then fits each expression once, and ``dt`` and ``ebfr`` share one prepared set-up per rig pair.

Training expressions come ideal (`training_expressions`, the linear sum of the target's ground truth, as in
the paper) or scan-like (`scan_expressions` with a `ScanModel`: correctives, scanner noise, head motion
removed by rigid alignment).

``transfer.get("ebfr", beta="gcv")`` chooses Li et al.'s balance ``beta`` from the examples by generalized
cross-validation; `beta_curve` shows the RMS error against ground truth over ``beta`` beside that choice.
"""

from transfer._base import Transfer
from transfer._expressions import training_expressions
from transfer._metrics import TransferMetrics, metrics, rms
from transfer._registry import add_file, availability, get, info, names
from transfer._scan import ScanModel, scan_expressions
from transfer._sweep import BetaCurve, beta_curve

__all__ = [
    "BetaCurve",
    "ScanModel",
    "Transfer",
    "TransferMetrics",
    "add_file",
    "availability",
    "beta_curve",
    "get",
    "info",
    "metrics",
    "names",
    "rms",
    "scan_expressions",
    "training_expressions",
]
