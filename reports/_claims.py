"""The paper's claims (Carrigan et al. 2020, sec. 5.2), held or not, computed from a run's records.

Each claim names the cells it compares, the numbers it reads from them and the rule that decides it; a run
without the cells a claim needs reports it as ``not measured`` and says which cells are missing. Values are
medians over repetitions; cells are compared only with cells of the same rig, seed, warp and other settings.

Every claim follows one rule (`reports._evidence`): the unit of evidence is a face (a rig and its seed,
``--seeds``); each face's points reduce to one effect, and the verdict follows from the t interval of the
mean effect over faces against the region the claim names: *held* inside, *not held* outside, else
*inconclusive*.

============================ ==========================================================================
claim                        a face's effect, and the region it must lie in (constants of this module)
============================ ==========================================================================
greedy/optimal agreement     mean over its first 5, 10, 20 expressions (Table 3) of the shapes both
                             chose / shapes the optimal solver chose, within `SHARED_RANGE` (63%-98%);
                             points where the optimal solver had used every shape already are left out
optimal below greedy         median over (warp, J) of the relative difference of ``ebfr`` RMS with the
                             optimal solver's expressions to greedy's, at most -`LEAST_CHANGE`
importance lowers RMS        the same, optimal solver with importance against without (Fig. 9)
alpha = 0.5 best or near     excess of the mean RMS over J at alpha 0.5 over the best alpha's (Fig. 9),
                             at most `ALPHA_NEAR`
20 expressions cover         distance of the share of shapes covered after 20 expressions (optimal and
                             greedy) to the paper's 67% (female), 86% (male), 95% (toon), at most
                             `COVERAGE_TOLERANCE`
symmetry barely matters      median relative change of the optimal solver's RMS without symmetry, at
                             most `SYMMETRY_CHANGE`
excess distortion            (not the paper's; sec. 4.3) ``ebfr`` RMS with eq. 6's excess ``s_t - 2``
                             against the paper's ``s_t``, as "optimal below greedy"
scan examples matter         (not the paper's) ``ebfr`` RMS with ideal examples against scan-like ones (the
                             same packings; ``--examples both``), as "optimal below greedy"
evaluation sanity            (not the paper's) with every shape in an expression of its own and every
                             expression a training example (``--preset sanity``), ``ebfr`` RMS / ``dt``'s
                             with ideal examples, at most `SANITY_RATIO`; scan-like examples, ebfr's fixed
                             betas (where fitting noise begins) and the other transfers (anacondar) are
                             shown beside it
packing beats random draws   (not the paper's) ``anacondar``'s ``frames_l2`` (Wagner et al.'s Fig. 10
                             error, ``--preset fig10``) with the optimal solver's first J expressions
                             against J random examples', at J in `PACKING_J`, as "optimal below greedy";
                             greedy's packing and `ANIMATION_BESIDE` are judged beside it
============================ ==========================================================================
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

from harness import settings_text, split_label
from reports._agreement import agreement_counts
from reports._evidence import HELD, INCONCLUSIVE, NOT_HELD, NOT_MEASURED, UNIT, Region, judge

#: The transfer the claims read (the paper's example-based facial rigging).
CLAIM_TRANSFER = "ebfr"
#: The paper's greedy solver (Algorithm 2).
GREEDY = "greedy"
#: Exact solvers, the first present in a run standing for "optimal".
OPTIMAL_SOLVERS: tuple[str, ...] = ("cpsat", "highs", "scip", "cbc-pulp", "cbc-mip", "naive-pulp-cbc")
#: The paper's default importance mix (eq. 4) and the settings of its main comparisons.
PAPER_ALPHA = 0.5
#: Table 3: between 63% (Female, 5 ex.: 34 of 54) and 98% (Toon, 20 ex.: 61 of 62) of the optimal method's
#: shapes were also chosen by greedy.
SHARED_RANGE = (0.63, 0.98)
#: The least relative change of an error that a claim of "lower" means: a face whose error drops by less
#: shows no gain worth a claim (ties, rounding, one shape more or less in an expression).
LEAST_CHANGE = 0.01
#: "alpha = 0.5 was found to be the best trade-off": near means at most this much above the best alpha.
ALPHA_NEAR = 0.02
#: Sec. 5.2: with 20 expressions both methods covered about 67% (Female), 86% (Male) and 95% (Toon).
PAPER_COVERAGE = {"female": 0.67, "male": 0.86, "toon": 0.95}
COVERAGE_TOLERANCE = 0.05
COVERAGE_EXPRESSIONS = 20
#: "adding the symmetry constraint to the optimal solution had basically no influence on the RMS-error".
SYMMETRY_CHANGE = 0.02

#: With every shape scanned alone and exactly, example-based rigging has the target's own shapes as
#: examples: it must recover most of what deformation transfer misses.
SANITY_RATIO = 0.35

#: Packed against random examples (Wagner et al.'s Fig. 10 draws): the transfer judged, the ones shown
#: beside it (with the optimal solver's and greedy's packings), and the numbers of examples compared.
ANIMATION_TRANSFER = "anacondar"
ANIMATION_BESIDE: tuple[str, ...] = ("anacondar[lambda_reg=900]", CLAIM_TRANSFER)
PACKING_J: tuple[int, ...] = (5, 10, 20)
RANDOM_EXAMPLES = "random"

__all__ = ["HELD", "INCONCLUSIVE", "NOT_HELD", "NOT_MEASURED", "claims_table"]

CLAIM_COLUMNS: tuple[str, ...] = ("claim", "paper", "measured", "verdict")

#: Columns that pair cells across solvers or settings (everything but the compared field and solver).
_CASE = ("rig", "rig_seed", "warp", "mu", "beta", "cap", "jmax", "time_limit", "examples")


@dataclass(frozen=True)
class Claim:
    """One row of the claims table."""

    claim: str
    paper: str
    measured: str
    verdict: str


def claims_table(records: pd.DataFrame) -> pd.DataFrame:
    """The paper's claims as a table of ``claim``, ``paper``, ``measured`` and ``verdict``.

    Parameters
    ----------
    records : DataFrame
        A run's records (`harness.read_records`).

    Returns
    -------
    DataFrame with `CLAIM_COLUMNS`, one row per claim in the order of the module documentation; the
    verdict is ``held``, ``not held``, ``inconclusive`` or ``not measured``.
    """
    checks: list[Callable[[pd.DataFrame], Claim]] = [
        _shared_shapes,
        _optimal_below_greedy,
        _importance_lowers_rms,
        _alpha_best,
        _coverage,
        _symmetry_barely_matters,
        _excess_distortion,
        _scan_matters,
        _sanity,
        _packing_beats_random,
    ]
    return pd.DataFrame([vars(check(records)) for check in checks], columns=list(CLAIM_COLUMNS))


def _optimal_solver(records: pd.DataFrame) -> str | None:
    cells = records[(records["kind"] == "cell") & (records["status"] == "ok")]
    present = set(cells["solver"])
    return next((solver for solver in OPTIMAL_SOLVERS if solver in present), None)


def _paper_setting(rows: pd.DataFrame, **changes: object) -> pd.DataFrame:
    """Rows with the paper's setting (importance and symmetry on, alpha 0.5, the paper's distortion), some
    fields changed. Records without a ``distortion`` value were made before it could change: the paper's."""
    wanted: dict[str, object] = {
        "importance": True,
        "symmetry": True,
        "alpha": PAPER_ALPHA,
        "distortion": "paper",
        **changes,
    }
    mask = np.ones(len(rows), dtype=bool)
    for column, value in wanted.items():
        if value is not None:
            values = rows[column] if column in rows else pd.Series(None, index=rows.index, dtype=object)
            values = (
                values.astype(object).fillna("paper") if column == "distortion" else values.astype(object)
            )
            mask &= values.to_numpy() == value
    return rows[mask]


def _rms(records: pd.DataFrame, solver: str | None, **changes: object) -> pd.Series:
    """Median ``ebfr`` RMS over repetitions per case and J, for one solver and setting."""
    rows = records[
        (records["kind"] == "transfer")
        & (records["status"] == "ok")
        & (records["transfer"] == CLAIM_TRANSFER)
        & records["rms"].notna()
        & (records["solver"] == solver)
    ]
    rows = _paper_setting(rows, **changes)
    if rows.empty:
        return pd.Series(dtype=float)
    return rows.groupby([*_CASE, "j"], dropna=False)["rms"].median().astype(float)


def _percent(value: float) -> str:
    return f"{value:.0%}"


def _relative(better: pd.Series, worse: pd.Series) -> pd.Series:
    """``(better - worse) / worse`` at the points both measured."""
    both = pd.concat([better, worse], axis=1, keys=["a", "b"], join="inner").dropna()
    return (both["a"] - both["b"]) / both["b"]


def _lower(relative: pd.Series) -> tuple[str, str]:
    """The verdict and text of a claim that one error is lower than another: each face's effect is the
    median of its points' relative differences (`reports._evidence`), below -`LEAST_CHANGE`."""
    region = Region(high=-LEAST_CHANGE)
    judged = judge(relative.groupby(level=list(UNIT)).median(), region)
    below, ties = int((relative < 0).sum()), int((relative == 0).sum())
    text = f"{judged.text(region)}; lower at {below} of {len(relative)} (seed, rig, warp, J) points" + (
        f", {ties} tied" if ties else ""
    )
    return judged.verdict, text


def _compare(
    title: str, paper: str, better: pd.Series, worse: pd.Series, names: tuple[str, str], missing: str
) -> Claim:
    """Whether ``better`` is lower than ``worse`` by the rule of `_lower`."""
    relative = _relative(better, worse)
    if relative.empty:
        return Claim(title, paper, missing, NOT_MEASURED)
    verdict, text = _lower(relative)
    return Claim(title, paper, f"{names[0]} against {names[1]}: {text}", verdict)


def _shared_shapes(records: pd.DataFrame) -> Claim:
    title = "greedy and optimal choose similar, not identical shapes"
    paper = "Table 3: 67%-98% of the optimal method's shapes also chosen by greedy (first 5, 10, 20 expr.)"
    optimal = _optimal_solver(records)
    agreement = agreement_counts(records)
    if optimal is None or agreement.empty:
        return Claim(title, paper, f"needs ok cells of {GREEDY} and an optimal solver", NOT_MEASURED)
    pairs = agreement[
        (agreement["solver_a"].isin([optimal, GREEDY]))
        & (agreement["solver_b"].isin([optimal, GREEDY]))
        & (agreement["solver_a"] != agreement["solver_b"])
    ]
    pairs = _paper_setting(pairs)
    pairs = pairs[pairs["repetition"] == pairs["repetition"].min()] if not pairs.empty else pairs
    if pairs.empty:
        return Claim(title, paper, f"needs {GREEDY} and {optimal} on the same rigs", NOT_MEASURED)
    chosen = np.where(pairs["solver_a"] == optimal, pairs["shapes_a"], pairs["shapes_b"]).astype(float)
    cells = records[(records["kind"] == "cell") & (records["status"] == "ok")]
    packable = (
        (cells["n_shapes"].astype(float) - cells["n_empty"].astype(float).fillna(0.0))
        .groupby(cells["rig"])
        .max()
    )
    # Once the optimal solver has used every shape, greedy shares them all: no evidence either way.
    open_points = chosen < pairs["rig"].map(packable).to_numpy(dtype=float)
    pairs, chosen = pairs[open_points], chosen[open_points]
    if pairs.empty:
        return Claim(title, paper, "every compared sequence had used every shape already", NOT_MEASURED)
    share = pd.Series(
        pairs["shared"].to_numpy(dtype=float) / np.where(chosen > 0, chosen, np.nan),
        index=pd.MultiIndex.from_frame(pairs[list(UNIT)]),
    )
    region = Region(*SHARED_RANGE)
    judged = judge(share.groupby(level=list(UNIT)).mean(), region)
    measured = (
        f"{GREEDY}/{optimal}: {judged.text(region, _percent)}; single values "
        f"{share.min():.0%} to {share.max():.0%} of {len(share)}"
    )
    return Claim(title, paper, measured, judged.verdict)


def _optimal_below_greedy(records: pd.DataFrame) -> Claim:
    title = "optimal expressions transfer better than greedy's"
    paper = "Fig. 10: ebfr RMS lower with the optimal solver's training expressions"
    optimal = _optimal_solver(records)
    return _compare(
        title,
        paper,
        _rms(records, optimal),
        _rms(records, GREEDY),
        (optimal or "optimal", GREEDY),
        f"needs {CLAIM_TRANSFER} records of {GREEDY} and an optimal solver",
    )


def _importance_lowers_rms(records: pd.DataFrame) -> Claim:
    title = "importance weights lower the transfer error"
    paper = "Fig. 9: ebfr RMS lower with importance (alpha 0.5) than without"
    optimal = _optimal_solver(records)
    return _compare(
        title,
        paper,
        _rms(records, optimal),
        _rms(records, optimal, importance=False, alpha=None),
        ("importance", "none"),
        "needs cells without importance (--variations claims or --importance both)",
    )


def _alpha_best(records: pd.DataFrame) -> Claim:
    title = "alpha = 0.5 is the best importance mix or near it"
    paper = "Fig. 9: weighting displacement and distortion equally (alpha 0.5) is the best trade-off"
    optimal = _optimal_solver(records)
    by_alpha = _rms(records, optimal, alpha=None)
    if by_alpha.empty:
        return Claim(title, paper, "needs ebfr records of an optimal solver", NOT_MEASURED)
    rows = records[
        (records["kind"] == "transfer")
        & (records["solver"] == optimal)
        & (records["transfer"] == CLAIM_TRANSFER)
        & records["rms"].notna()
    ]
    rows = _paper_setting(rows, alpha=None)
    alphas = sorted(set(rows["alpha"].astype(float)))
    if PAPER_ALPHA not in alphas or len(alphas) < 2:
        return Claim(
            title, paper, "needs alpha 0.5 and other alphas (--variations claims or --alpha)", NOT_MEASURED
        )
    table = (
        rows[rows["status"] == "ok"]
        .groupby([*_CASE, "j", "alpha"], dropna=False)["rms"]
        .median()
        .astype(float)
        .unstack("alpha")
        .dropna()
    )
    if table.empty:
        return Claim(title, paper, "no J value with every alpha", NOT_MEASURED)
    means = table.groupby(level=[*UNIT, "warp"]).mean()
    excess = means[PAPER_ALPHA] / means.min(axis=1) - 1.0
    best = means.idxmin(axis=1).value_counts().sort_index()
    region = Region(high=ALPHA_NEAR)
    judged = judge(excess.groupby(level=list(UNIT)).mean(), region)
    measured = (
        f"alpha 0.5 above the best alpha: {judged.text(region)}; best alpha "
        + ", ".join(f"{alpha:g} on {count}" for alpha, count in best.items())
        + f" of {len(means)} (seed, rig, warp)"
    )
    return Claim(title, paper, measured, judged.verdict)


def _coverage(records: pd.DataFrame) -> Claim:
    title = f"{COVERAGE_EXPRESSIONS} expressions cover most shapes"
    paper = "Sec. 5.2: about 67% (female), 86% (male), 95% (toon) of the shapes with 20 expressions"
    optimal = _optimal_solver(records)
    ok = records[(records["kind"] == "cell") & (records["status"] == "ok")]["cell"]
    rows = records[
        (records["kind"] == "expression")
        & records["cell"].isin(ok)
        & records["solver"].isin([GREEDY, optimal])
        & records["rig"].isin(list(PAPER_COVERAGE))
    ]
    rows = _paper_setting(rows)
    if rows.empty:
        return Claim(title, paper, "needs expressions of female, male or toon", NOT_MEASURED)
    rows = rows[rows["expression"] <= COVERAGE_EXPRESSIONS]
    last = rows.sort_values("expression").groupby("cell").tail(1)
    share = last.groupby([*UNIT, "warp", "solver"])["coverage"].median().astype(float)
    paper_share = share.index.get_level_values("rig").map(PAPER_COVERAGE).to_numpy(dtype=float)
    region = Region(high=COVERAGE_TOLERANCE)
    judged = judge((share - paper_share).groupby(level=list(UNIT)).mean().abs(), region)
    by_rig = share.groupby(level=["rig", "solver"]).median()
    measured = f"distance to the paper's share: {judged.text(region, _percent)}; median " + ", ".join(
        f"{rig} {solver} {value:.0%}" for (rig, solver), value in by_rig.items()
    )
    return Claim(title, paper, measured, judged.verdict)


def _symmetry_barely_matters(records: pd.DataFrame) -> Claim:
    title = "symmetry barely changes the optimal solver's transfer error"
    paper = "Sec. 5.2: the symmetry constraint had basically no influence on the optimal RMS"
    optimal = _optimal_solver(records)
    both = pd.concat(
        [_rms(records, optimal), _rms(records, optimal, symmetry=False)],
        axis=1,
        keys=["on", "off"],
        join="inner",
    ).dropna()
    if both.empty:
        return Claim(
            title,
            paper,
            "needs cells without symmetry (--variations claims or --symmetry both)",
            NOT_MEASURED,
        )
    change = ((both["off"] - both["on"]) / both["on"]).abs()
    region = Region(high=SYMMETRY_CHANGE)
    judged = judge(change.groupby(level=list(UNIT)).median(), region)
    measured = (
        f"change without symmetry: {judged.text(region, '{:.1%}'.format)}; largest {change.max():.1%} "
        f"of {len(change)} (seed, rig, warp, J) points"
    )
    return Claim(title, paper, measured, judged.verdict)


def _excess_distortion(records: pd.DataFrame) -> Claim:
    title = "the excess distortion transfers better than the paper's"
    paper = "not a claim of the paper: eq. 6 as printed (s_t >= 2) against its excess s_t - 2"
    optimal = _optimal_solver(records)
    return _compare(
        title,
        paper,
        _rms(records, optimal, distortion="excess"),
        _rms(records, optimal),
        ("excess", "paper"),
        "needs cells with the excess distortion (--variations claims or --distortion both)",
    )


def _scan_matters(records: pd.DataFrame) -> Claim:
    title = "scan-like examples cost accuracy that ideal ones do not"
    paper = "evaluation check, not a claim of the paper: the scan model (correctives, noise, head motion)"
    rms = _rms(records, _optimal_solver(records))
    modes = set(rms.index.get_level_values("examples")) if not rms.empty else set()

    def of(mode: str) -> pd.Series:
        return rms.xs(mode, level="examples") if mode in modes else pd.Series(dtype=float)

    return _compare(
        title,
        paper,
        of("ideal"),
        of("scan"),
        ("ideal", "scan"),
        "needs both kinds of examples (--examples both)",
    )


def _sanity(records: pd.DataFrame) -> Claim:
    title = "every shape scanned alone: ebfr recovers the target"
    paper = (
        f"evaluation sanity, not a claim of the paper: ebfr RMS <= {SANITY_RATIO:g} x dt with exact examples"
    )
    cells = records[(records["kind"] == "cell") & (records["status"] == "ok")]
    isolated = cells[(cells["cap"].astype("Float64") == 1) & (cells["symmetry"] == False)]  # noqa: E712
    rows = records[
        (records["kind"] == "transfer")
        & (records["status"] == "ok")
        & records["cell"].isin(isolated["cell"])
        & records["rms"].notna()
    ]
    if rows.empty:
        return Claim(title, paper, "needs cells with --cap 1 --no-symmetry (--preset sanity)", NOT_MEASURED)
    rows = rows[rows["j"] == rows.groupby("cell")["j"].transform("max")]  # every expression trained on
    table = (
        rows.groupby([*UNIT, "warp", "examples", "transfer"], dropna=False)["rms"]
        .median()
        .unstack("transfer")
    )
    if "ebfr" not in table or "dt" not in table:
        return Claim(title, paper, "needs the ebfr and dt transfers of those cells", NOT_MEASURED)
    ratios = table.div(table["dt"], axis=0).drop(columns="dt")
    examples = ratios.index.get_level_values("examples")
    if "ideal" not in set(examples):
        return Claim(title, paper, f"{_sanity_text(ratios)}; needs ideal examples", NOT_MEASURED)
    region = Region(high=SANITY_RATIO)
    ideal = ratios[examples == "ideal"]["ebfr"]
    judged = judge(ideal.groupby(level=list(UNIT)).median(), region)
    measured = f"ebfr/dt with ideal examples: {judged.text(region, '{:.3f}'.format)}; {_sanity_text(ratios)}"
    return Claim(title, paper, measured, judged.verdict)


def _sanity_text(ratios: pd.DataFrame) -> str:
    """Per rig, warp and kind of examples: the median ratio to ``dt`` of ebfr and of the others beside it."""
    medians = ratios.groupby(level=["rig", "warp", "examples"], dropna=False).median()
    parts = []
    for (rig, warp, examples), row in medians.iterrows():
        swept = ", ".join(
            f"{settings_text(split_label(name)[1]) or name} {value:.2f}"
            for name, value in row.items()
            if name != "ebfr" and not pd.isna(value)
        )
        parts.append(f"{rig}/{warp} {examples}: ebfr/dt {row['ebfr']:.3f}" + (f" ({swept})" if swept else ""))
    return "; ".join(parts)


def _frames_l2(records: pd.DataFrame, transfer: str, choice: str | None) -> pd.Series:
    """Median ``frames_l2`` per case and J in `PACKING_J` (`_CASE` but the examples) of one transfer
    trained on one solver's packed expressions, or on random examples (``choice`` `RANDOM_EXAMPLES`:
    they do not depend on the cell's solver, so the median over the solvers that drew them)."""
    rows = records[
        (records["kind"] == "transfer")
        & (records["status"] == "ok")
        & (records["transfer"] == transfer)
        & records["frames_l2"].notna()
        & records["j"].isin(PACKING_J)
    ]
    random = rows["examples"] == RANDOM_EXAMPLES
    rows = _paper_setting(rows[random if choice == RANDOM_EXAMPLES else ~random & (rows["solver"] == choice)])
    if rows.empty:
        return pd.Series(dtype=float)
    keys = [column for column in _CASE if column != "examples"]
    return rows.groupby([*keys, "j"], dropna=False)["frames_l2"].median().astype(float)


def _packing_beats_random(records: pd.DataFrame) -> Claim:
    title = "packed expressions train anacondar better than random ones"
    paper = (
        f"not a claim of either paper: {ANIMATION_TRANSFER}'s Fig. 10 error (Wagner et al. 2024) with the "
        f"first J packed expressions against J random examples, J = {', '.join(map(str, PACKING_J))}"
    )
    optimal = _optimal_solver(records)
    found = _compare(
        title,
        paper,
        _frames_l2(records, ANIMATION_TRANSFER, optimal),
        _frames_l2(records, ANIMATION_TRANSFER, RANDOM_EXAMPLES),
        (optimal or "optimal", RANDOM_EXAMPLES),
        "needs frames_l2 records of packed and of random examples (--preset fig10)",
    )
    if found.verdict == NOT_MEASURED:
        return found
    beside = []
    pairs = [
        (ANIMATION_TRANSFER, GREEDY),
        *((name, solver) for name in ANIMATION_BESIDE for solver in (optimal, GREEDY)),
    ]
    for transfer, solver in pairs:
        relative = _relative(
            _frames_l2(records, transfer, solver), _frames_l2(records, transfer, RANDOM_EXAMPLES)
        )
        if not relative.empty:
            verdict, text = _lower(relative)
            beside.append(f"{transfer} {solver} against random ({verdict}): {text}")
    measured = f"{ANIMATION_TRANSFER} {found.measured}" + "".join(f". {part}" for part in beside)
    return Claim(title, paper, measured, found.verdict)
