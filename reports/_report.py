"""Assembling the report of a run: tables, figures and contact sheets, written as HTML and Markdown."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pandas as pd

import harness
import rigs
from registry import claim
from reports._agreement import agreement_counts
from reports._animation import (
    ALM,
    ANACONDAR,
    RANDOM,
    STIFF_ALM,
    STIFF_ANACONDAR,
    animation_figure,
    shown_errors,
    shown_paired,
)
from reports._claims import claims_table
from reports._contact import contact_sheet
from reports._document import Image, Section, write_documents
from reports._figures import coverage_figure, distribution_figure, profile_figure, rms_figure
from reports._layout import REPORT_DIR
from reports._png import jpeg_bytes, png_bytes
from reports._summary import SHIFT, TIE_TOLERANCE, common_table, outcome_table, sequence_table, solve_outcomes
from reports._tables import (
    BASELINE_SOLVER,
    GROUP_COLUMNS,
    REFERENCE_TRANSFERS,
    SETTING_COLUMNS,
    agreement_table,
    expression_count_table,
    expression_rows,
    ok_cells,
    problem_table,
    rig_labels,
    rms_table,
    separation_table,
    setting_label,
    timing_table,
    varying_settings,
    worst_shapes_table,
)

_EXAMPLES = {
    "scan": "scan-like (transfer.scan_expressions: correctives where combined shapes meet, scanner noise, "
    "head motion removed by rigid alignment; each repetition is another capture session).",
    "ideal": "ideal (the exact linear sums of the target's ground-truth blendshapes, as in the paper).",
    "random": "random (random 0/1 expressions of the target, exact sums, instead of the sequence: Wagner "
    "et al. 2024, Fig. 10).",
}


def _slug(*parts: object) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "-", "-".join(str(part) for part in parts)).strip("-").lower()


def _run_summary(run: dict, records: pd.DataFrame, live: bool) -> list[str]:
    """The run's command, state, cells, commit and machine; ``live`` when a harness run holds its folder."""
    cells = records[records["kind"] == "cell"]
    counts = ", ".join(
        f"{count} {status}" for status, count in cells["status"].value_counts().sort_index().items()
    )
    missing = int(run.get("n_cells") or 0) - len(cells)
    if missing > 0 and live:
        counts = f"{counts or 'none'}; {missing} of the grid's {run['n_cells']} still to come (running)"
    elif missing > 0:  # (an interrupted or incomplete run: its grid's other cells were never recorded)
        counts = f"{counts or 'none'}; {missing} of the grid's {run['n_cells']} not run (resume the run)"
    git = run.get("git") or {}
    machine = run.get("machine") or {}
    solvers = (run.get("versions") or {}).get("solvers") or {}
    solver_versions = ", ".join(
        f"{name} {info.get('version') or '?'}" if info.get("available") else f"{name} unavailable"
        for name, info in sorted(solvers.items())
    )
    examples = (run.get("config") or {}).get("examples") or ()
    trained = " and ".join(_EXAMPLES.get(mode, mode) for mode in examples) or "not recorded"
    return [
        f"Command: {' '.join(run.get('command', [])) or 'not recorded'}",
        f"Training expressions: {trained}",
        f"State: {run.get('state', 'unknown')}; started {run.get('started', '?')}, "
        + ("not finished yet." if live else f"finished {run.get('finished', '?')}."),
        f"Cells: {counts or 'none'}. Git commit: {git.get('commit') or 'none'}"
        f"{' (dirty)' if git.get('dirty') else ''}. Machine: {machine.get('hostname', '?')}, "
        f"{machine.get('cpu_count', '?')} CPUs, {machine.get('platform', '?')}.",
        f"Solvers: {solver_versions or 'not recorded'}.",
    ]


def _contact_sheets(records: pd.DataFrame, expressions: int) -> list[Image | str]:
    """One contact sheet per rig, warp and setting that every solver of the rig ran (first repetition;
    the settings only the claims' solvers ran are left out); identical sequences share a row."""
    rows = expression_rows(records)
    rows = rows[rows["repetition"] == rows["repetition"].min()]
    solvers_of = rows.groupby(["rig", "rig_seed"])["solver"].transform("nunique")
    settings = varying_settings(records)
    labels = rig_labels(records["rig"])
    blocks: list[Image | str] = []
    for (rig_name, rig_seed), of_rig in rows.groupby(["rig", "rig_seed"], sort=True):
        try:
            rig = rigs.resolve(rig_name, seed=int(rig_seed))
        except (OSError, ValueError) as error:
            blocks.append(f"No contact sheet for rig {labels[rig_name]}: it could not be rebuilt ({error}).")
            continue
        keys = [c for c in GROUP_COLUMNS if c not in ("rig", "rig_seed", "repetition", "permutation")]
        for _, group in of_rig.groupby(keys, sort=True, dropna=False):
            if group["solver"].nunique() < solvers_of.loc[group.index].iloc[0]:
                continue
            sequences = {
                solver: [list(shapes) for shapes in cell.sort_values("expression")["shapes"]]
                for solver, cell in group.groupby("solver", sort=True)
            }
            first = group.iloc[0]
            title = ", ".join(
                filter(None, [labels[rig_name], f"warp {first['warp']}", setting_label(first, settings)])
            )
            figure = contact_sheet(
                rig, sequences, expressions=expressions, mu=float(first["mu"]), title=title
            )
            blocks.append(
                Image(
                    _slug("contact", labels[rig_name], first["warp"], setting_label(first, settings)),
                    jpeg_bytes(figure),
                    f"First {expressions} expressions of every solver on {title}; solvers with identical "
                    "expressions share a row. Active vertices (eq. 2) of each shape in its colour.",
                    format="jpeg",
                )
            )
    return blocks


def _claims_blocks(records: pd.DataFrame) -> list[str | pd.DataFrame]:
    return [
        "Each claim of Carrigan et al. 2020 (sec. 5.2) decided from this run's records by the rule in "
        "reports._claims (ebfr transfer; optimal = the first exact solver of the run, cpsat preferred); "
        "'not measured' names the cells the run lacks (harness run --variations claims adds them).",
        claims_table(records),
    ]


def _reference_blocks(records: pd.DataFrame) -> list[str | pd.DataFrame]:
    """The RMS tables: absolute (with the references' rows) and divided by each reference."""
    blocks: list[str | pd.DataFrame] = [
        "Per-vertex RMS over all shapes at each J (median over repetitions); solvers with identical values "
        "share a row. The references ignore the training expressions: dt transfers every template shape "
        "by deformation transfer, delta copies the template's displacements.",
        rms_table(records),
    ]
    for reference in REFERENCE_TRANSFERS:
        table = rms_table(records, reference)
        if table.empty:
            blocks.append(f"The run has no {reference} transfer: no RMS relative to it.")
            continue
        blocks += [
            f"RMS divided by the {reference} RMS of the same cell and J (below 1: the training expressions "
            "helped).",
            table,
        ]
    for part in ("rms_covered", "rms_uncovered"):
        table = rms_table(records, "dt", part)
        if not table.empty:
            which = "covered by" if part == "rms_covered" else "in none of"
            blocks += [
                f"RMS of the shapes {which} the J expressions, divided by the dt RMS over all shapes.",
                table,
            ]
    return blocks


def _animation_blocks(records: pd.DataFrame) -> list[str | pd.DataFrame | Image]:
    """Fig. 10 of Wagner et al. 2024 and its packing counterpart, from the ``frames_l2`` records."""
    errors = shown_errors(records)
    if errors.empty:
        return ["The run judges no retargeted frames (harness run --preset fig10, or --frames F)."]
    blocks: list[str | pd.DataFrame | Image] = [
        Image(
            "animation",
            png_bytes(animation_figure(records)),
            "Mean vertex L2 error of the retargeted source frames against the number of target examples J, "
            "mean over the seeds (faces, actors, draws) with its 95% t interval. Top row: trained on J "
            "random examples (Wagner et al.'s Fig. 10); each further row: one transfer trained on random "
            "examples or on the first J expressions of a solver's packing.",
        ),
        "Mean vertex L2 error of the retargeted frames (rig units), mean over seeds [95% t interval]; "
        "choice = random examples or the solver whose packed expressions trained the transfer.",
        errors,
    ]
    comparisons = [
        ((RANDOM, ANACONDAR), (RANDOM, ALM), "AnaConDaR against ALM on random examples (Fig. 10)"),
        (
            (RANDOM, STIFF_ANACONDAR),
            (RANDOM, STIFF_ALM),
            "The same, ridge 900 (Table 3's read in face diagonals)",
        ),
    ]
    for transfer in (ANACONDAR, STIFF_ANACONDAR, "ebfr"):
        for solver in ("cpsat", "greedy"):
            comparisons.append(
                (
                    (solver, transfer),
                    (RANDOM, transfer),
                    f"{transfer}: {solver}'s packing against random examples",
                )
            )
    for first, second, title in comparisons:
        table = shown_paired(records, first, second)
        if not table.empty:
            blocks += [
                f"{title}: difference seed by seed, mean [95% t interval], relative to the second.",
                table,
            ]
    return blocks


def _separation_blocks(records: pd.DataFrame) -> list[str | pd.DataFrame]:
    table = separation_table(records)
    if table.empty:
        return ["The run has no transfer records of a method that uses the training expressions."]
    return [
        "Spread of the RMS across packings (solver and setting; median over repetitions) against the "
        "run-to-run noise (pooled standard deviation over repetitions; with scan-like examples every "
        "repetition is another capture session). A spread of a few noise levels or more tells the packings "
        "apart; one repetition gives no noise estimate.",
        table,
    ]


def _solver_section(run: dict, records: pd.DataFrame) -> Section:
    """Shifted geometric means, outcome counts, wins and performance profiles across instances."""
    config = run.get("config") or {}
    limit = config.get("time_limit") or config.get("timeout")
    solves = solve_outcomes(records, limit)
    if solves.empty:
        return Section("Solvers across instances", ["The run has no solves."])
    shift = f"{SHIFT * 1e3:g} ms"
    return Section(
        "Solvers across instances",
        [
            "An instance is one expression's problem: rig, warp, packing settings, repetition, expression "
            "index and the shapes chosen before it. A solve's time is model build + solve (ms); a solve that "
            "ended in a time limit, infeasible or an error, and expression 1 of a failed cell, is charged at "
            "the time limit. sgm = shifted geometric mean (SCIP's check.awk; shift "
            f"{shift}, about the call overhead of a trivial solve; SCIP uses 10 s for MIP).",
            outcome_table(solves),
            "Common instances: problems every compared solver was given (expression 1 of each group, and "
            "later expressions where the earlier choices agree; sequences of different solvers diverge "
            "after expression 1, so each solver's own instances above differ). Exact solvers solve an "
            "instance by proving it optimal; every solver also counts a heuristic's completed solve. Wins: "
            f"fastest among the solvers that solved the instance, ties within {TIE_TOLERANCE:.0%} a win "
            "each; the sgm charges unsolved instances at the limit.",
            common_table(solves),
            Image(
                "performance-profile",
                png_bytes(profile_figure(solves)),
                "Performance profiles (Dolan and More 2002) on the common instances: the fraction each "
                "solver solved within a factor tau of the fastest solver's time; unsolved instances never "
                "count.",
            ),
            Image(
                "solve-times",
                png_bytes(distribution_figure(solves)),
                "Build + solve time per expression of each solver over all its instances (n solves; log "
                "scale; boxes: quartiles, whiskers 1.5 IQR); red crosses: solves not ended optimal or "
                "completed, drawn at the limit they are charged.",
            ),
            f"Whole sequences (Algorithm 1) per cell, sgm with shift {shift}; a failed cell (error, timeout, "
            "invalid, inconsistent) is charged at the run's cell timeout. Each solver's sequence holds its "
            "own problems.",
            sequence_table(records, config.get("timeout")),
        ],
    )


def report_sections(run_dir: Path, *, expressions: int = 5) -> list[Section]:
    """The sections of the report of the run in ``run_dir`` (see `build_report`)."""
    run = harness.read_run(run_dir)
    records = harness.read_records(run_dir)
    finished = ok_cells(records)
    rigs_shown = sorted(expression_rows(records)["rig"].unique())
    transfer_rigs = sorted(
        records[(records["kind"] == "transfer") & (records["status"] == "ok") & records["rms"].notna()][
            "rig"
        ].unique()
    )
    constant = [c for c in SETTING_COLUMNS if c not in varying_settings(records)]
    labels = rig_labels(records["rig"])
    shared = finished.iloc[0] if not finished.empty else None
    sections = [
        Section(
            "Run",
            _run_summary(run, records, harness.in_progress(run_dir))
            + (
                [f"Settings shared by every cell: {setting_label(shared, constant)}."]
                if shared is not None and constant
                else []
            ),
        ),
        Section("The paper's claims", _claims_blocks(records)),
        _solver_section(run, records),
        Section(
            "Transfer error (paper Figs. 9 and 10)",
            [
                Image(
                    _slug("rms", labels[rig]),
                    png_bytes(rms_figure(records, rig)),
                    "Per-vertex RMS error of the transferred blendshapes against ground truth on "
                    f"{labels[rig]}, against the number of training expressions J: over all shapes, over "
                    "the shapes the J expressions cover and over the others. Solvers whose curves agree "
                    "share a line marked identical; horizontal lines are the references "
                    f"({', '.join(REFERENCE_TRANSFERS)}); y axes start at 0.",
                )
                for rig in transfer_rigs
            ]
            or ["The run has no transfer records."],
        ),
        Section("Transfer error against the references", _reference_blocks(records)),
        Section("Retargeted frames (Wagner et al. 2024, Fig. 10)", _animation_blocks(records)),
        Section("Does the evaluation tell packings apart?", _separation_blocks(records)),
        Section(
            "Agreement of chosen shapes (paper Table 3, its 'overlap')",
            [
                "a/b (shared): distinct shapes chosen by solver a and by solver b in their first 5, 10 "
                "and 20 expressions, and how many both chose; [x/y expr.] when a sequence is shorter.",
                agreement_table(agreement_counts(records)),
            ],
        ),
        Section(
            "Coverage",
            [
                Image(
                    _slug("coverage", labels[rig]),
                    png_bytes(coverage_figure(records, rig)),
                    f"Shapes covered against the number of expressions on {labels[rig]}.",
                )
                for rig in rigs_shown
            ],
        ),
        Section(
            "Timings per rig and solver (paper Table 2)",
            [
                "Seconds on this machine, median over repetitions; spread = max - min over repetitions. "
                "First expression = presolve + model build + solve of expression 1; sequence = all "
                f"expressions. The column first / {BASELINE_SOLVER} divides by {BASELINE_SOLVER} (the "
                "paper's formulation) in the same run. The paper's rows give its published times (PuLP "
                "with CPLEX, and greedy) on its own rigs.",
                timing_table(records),
            ],
            folded=True,
        ),
        Section(
            "Worst transferred shapes",
            [
                "Per solver, the shapes with the largest per-vertex RMS error after transfer with all J "
                "training expressions of its sequence (rig length units).",
                worst_shapes_table(records),
            ],
            folded=True,
        ),
        Section(
            "Expression counts",
            [
                "Expressions in each solver's sequence (+: stopped at jmax before covering every "
                "non-empty shape), against packing's lower bound (the largest conflict clique) and the "
                "exact minimum when recorded.",
                expression_count_table(records),
            ],
            folded=True,
        ),
        Section(
            "Contact sheets",
            _contact_sheets(records, expressions) or ["No finished expressions."],
            folded=True,
        ),
    ]
    problems = problem_table(records)
    if not problems.empty:
        sections.append(Section("Cells that did not finish", [problems]))
    return sections


def build_report(
    run_dir: str | os.PathLike, *, expressions: int = 5, force: bool = True
) -> tuple[Path, Path]:
    """Write the report of a run to ``RUN_DIR/report/index.html`` and ``RUN_DIR/report/report.md``.

    Parameters
    ----------
    run_dir : path
        A run directory written by ``harness run`` (``run.json``, ``records/``).
    expressions : int
        How many leading expressions each contact-sheet row shows.
    force : bool
        Replace an earlier report (``harness report`` passes its ``--force``); the ``report`` folder is
        claimed by `registry.claim` (kind ``report``) before the report is made, so an earlier one
        without ``force``, or a folder holding anything else, is refused first.

    Returns
    -------
    (index.html, report.md) paths. The HTML page is self-contained (figures inline, no network); the
    Markdown references PNG files in ``report/figures/``. Same records, same bytes.

    Raises
    ------
    FileNotFoundError
        When ``run_dir`` holds no run or no records.
    registry.OutputFolderError
        When ``RUN_DIR/report`` may not be written (see ``force``).
    """
    run_dir = Path(run_dir)
    harness.read_run(run_dir)  # (no run: FileNotFoundError before any folder is made)
    with claim(run_dir / REPORT_DIR, kind="report", force=force):
        pass
    sections = report_sections(run_dir, expressions=expressions)
    return write_documents(
        f"Expression packing report: {run_dir.resolve().name}", sections, run_dir / REPORT_DIR
    )
