"""``harness track publish``: a static site of a store's timings across commits.

``index.html`` shows, per case, its figure across the measured commits (CPU seconds per solve, the geometric
mean over the suite's instances, with each commit's interval over its rounds) with every step marked, then
per commit the shifted geometric mean of each solver over the instances and the solvers' performance
profile at the last commit. Every point is a link: ``commits/<commit>.html`` holds that commit's
per-instance table (median CPU seconds per solve of every solver, its samples, whether every answer passed
the independent check), its shifted geometric means and performance profile, and its problems. The pages
are self-contained (figures as inline SVG, no script, nothing loaded from elsewhere), written into a folder
claimed as the tool's (`registry.claim`, kind ``dashboard``).
"""

from __future__ import annotations

import html
import io
import math
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from registry import claim  # noqa: E402
from reports._paired import clock_of, per_solve  # noqa: E402
from reports._steps import Step  # noqa: E402
from reports._summary import SHIFT, performance_profile, performance_ratios, shifted_geometric_mean  # noqa: E402
from reports._tracking import Tracker  # noqa: E402

_CSS = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1200px; padding: 0 1em; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.85em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: right; }
th { background: #f0f0f0; } td.text { text-align: left; }
.bad { color: #b00; } .step-up { color: #a60; } .step-down { color: #06a; }
svg { max-width: 100%; height: auto; }
"""
_POLICY = "default-src 'none'; img-src data:; style-src 'unsafe-inline'"


def commit_page(commit: str) -> str:
    """The relative path of a commit's page."""
    return f"commits/{commit}.html"


def case_anchor(case: str) -> str:
    """The fragment naming a case on a commit page."""
    return "case-" + re.sub(r"[^A-Za-z0-9]+", "-", case).strip("-")


def write_site(
    tracker: Tracker, order: list[str], out: Path, *, threshold: float, alpha: float, force: bool
) -> Path:
    """Write the dashboard of ``tracker``'s store over the commits of ``order`` into ``out`` (module notes);
    returns the index page.

    Raises
    ------
    registry.HarnessError
        When the store holds nothing for this machine and suite over ``order``, or ``out`` may not be used.
    """
    from registry import HarnessError

    samples = tracker.samples()
    series = tracker.series(order)
    if series.empty:
        raise HarnessError(
            f"{tracker.store.url}: no samples of suite {tracker.suite.name} on machine {tracker.machine_id} "
            "for these commits; run `harness track RANGE` first"
        )
    steps = tracker.steps(order, threshold=threshold, alpha=alpha)
    commits = [commit for commit in order if commit in set(series["commit"])]
    pages = {"index.html": _index(tracker, series, steps, samples, commits)}
    for commit in commits:
        pages[commit_page(commit)] = _commit(tracker, commit, samples[samples["commit"] == commit])
    with claim(out, kind="dashboard", force=force, lock=True) as folder:
        written = folder.replace(pages)
    return written[0]


def _page(title: str, body: str, *, depth: int = 0) -> str:
    home = "../" * depth + "index.html"
    return (
        f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
        f'<meta http-equiv="Content-Security-Policy" content="{_POLICY}">'
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>"
        f'<p><a href="{home}">dashboard</a></p><h1>{html.escape(title)}</h1>{body}</body></html>'
    )


def _svg(figure) -> str:
    buffer = io.StringIO()
    figure.savefig(buffer, format="svg", bbox_inches="tight")
    plt.close(figure)
    text = buffer.getvalue()
    return text[text.index("<svg") :].replace(' target="_blank"', "")  # a point opens its page here


def _index(
    tracker: Tracker, series: pd.DataFrame, steps: list[Step], samples: pd.DataFrame, commits: list[str]
) -> str:
    position = {commit: index for index, commit in enumerate(commits)}
    anchor = html.escape(tracker.names_of(tracker.anchor)) if tracker.anchor else "none"
    parts = [
        f"<p>Store {html.escape(tracker.store.url)}, machine {html.escape(tracker.machine_id)} "
        f"({html.escape(str(samples['machine_name'].iloc[0]) if len(samples) else '')}), suite "
        f"{html.escape(tracker.suite.name)}: {len(commits)} commits measured, each beside the anchor "
        f"{anchor}; a commit's figure of a case is its CPU time per solve as a ratio to the anchor's, "
        "measured in the same moments (bars: two standard errors over its rounds). Every point links to that "
        "commit's per-instance table.</p>",
        _steps_table(steps, tracker.names),
    ]
    for case, rows in series.groupby("case", sort=True):
        case_steps = [step for step in steps if step.case == case]
        parts.append(f'<h2 id="{case_anchor(case)}">{html.escape(case)}</h2>')
        parts.append(_case_figure(case, rows, case_steps, position, tracker.names))
    parts.append("<h2>Solvers per commit</h2>")
    parts.append(
        f"<p>Shifted geometric mean (shift {SHIFT * 1e3:g} ms) over the suite's instances of each solver's "
        "median CPU seconds per solve, as measured: unlike the ratios above, these move with the machine's "
        "load at the moment each commit was measured.</p>"
    )
    parts.append(_sgm_figure(samples, commits, tracker.names))
    if commits:
        parts.append(
            f"<h2>Performance profile at {html.escape(tracker.names.get(commits[-1], commits[-1]))}</h2>"
        )
        parts.append(_profile(samples[samples["commit"] == commits[-1]]))
    return _page(f"{tracker.suite.name}: timings across commits", "".join(parts))


def _steps_table(steps: list[Step], names: dict[str, str]) -> str:
    if not steps:
        return "<p>No steps.</p>"
    rows = "".join(_step_row(step, names) for step in steps)
    return (
        "<h2>Steps</h2><table><tr><th>case</th><th>first commit</th><th>ratio</th><th>interval</th>"
        f"<th>first commit named</th></tr>{rows}</table>"
    )


def _step_row(step: Step, names: dict[str, str]) -> str:
    direction = "step-up" if step.ratio > 1 else "step-down"
    name = html.escape(names.get(step.commit, step.commit))
    where = "yes" if step.exact else f"no: between {html.escape(step.previous[:10])} and it"
    return (
        f'<tr class="{direction}"><td class="text">{html.escape(step.case)}</td>'
        f'<td class="text"><a href="{commit_page(step.commit)}">{name}</a></td>'
        f"<td>x{step.ratio:.3f}</td><td>[{step.low:.3f}, {step.high:.3f}]</td>"
        f'<td class="text">{where}</td></tr>'
    )


def _case_figure(
    case: str, rows: pd.DataFrame, steps: list[Step], position: dict[str, int], names: dict[str, str]
) -> str:
    figure, axes = plt.subplots(figsize=(9, 2.6))
    x = np.array([position[commit] for commit in rows["commit"]])
    y = rows["value"].to_numpy(float)
    spread = np.nan_to_num(rows["log_se"].to_numpy(float)) * 2.0
    axes.errorbar(x, y, yerr=[y - y * np.exp(-spread), y * np.exp(spread) - y], fmt="none", ecolor="#999")
    points = axes.scatter(x, y, s=18, zorder=3)
    points.set_urls([f"{commit_page(commit)}#{case_anchor(case)}" for commit in rows["commit"]])
    for step in steps:
        axes.axvline(position[step.commit] - 0.5, color="#a60" if step.ratio > 1 else "#06a", linestyle="--")
        axes.annotate(
            f"x{step.ratio:.2f}",
            (position[step.commit] - 0.5, axes.get_ylim()[1]),
            fontsize=8,
            ha="right",
            va="top",
        )
    axes.set_ylabel(f"{rows['clock'].iloc[0]} CPU time\nper solve / anchor's")
    axes.set_ylim(bottom=0)
    _commit_ticks(axes, sorted(position.items(), key=lambda item: item[1]), names)
    return _svg(figure)


def _commit_ticks(axes, commits: list[tuple[str, int]], names: dict[str, str], most: int = 12) -> None:
    step = max(1, math.ceil(len(commits) / most))
    shown = commits[::step]
    axes.set_xticks(
        [index for _, index in shown], [commit[:7] for commit, _ in shown], rotation=45, fontsize=7
    )


def _instance_times(samples: pd.DataFrame) -> pd.DataFrame:
    """Median CPU seconds per solve per (group, instance) and solver, each solver by its own clock."""
    solves = samples[(samples["kind"] == "solve") & samples["valid"].astype(bool)]
    frames = []
    for case, rows in solves.groupby("case"):
        seconds = per_solve(rows, clock_of(rows))
        solver = case.rpartition("/")[2]
        frames.append(rows.assign(solver=solver, seconds=seconds))
    if not frames:
        return pd.DataFrame()
    joined = pd.concat(frames)
    return joined.groupby(["group", "instance", "solver"])["seconds"].median().unstack("solver")


def _sgm_figure(samples: pd.DataFrame, commits: list[str], names: dict[str, str]) -> str:
    figure, axes = plt.subplots(figsize=(9, 3))
    table = {
        commit: _instance_times(samples[samples["commit"] == commit]).apply(
            lambda column: shifted_geometric_mean(column.dropna()) if column.notna().any() else math.nan
        )
        for commit in commits
    }
    frame = pd.DataFrame(table).T
    for solver in frame.columns:
        values = frame[solver].to_numpy(float) * 1e3
        x = np.arange(len(commits))
        axes.plot(x, values, label=solver, linewidth=1)
        points = axes.scatter(x, values, s=10)
        points.set_urls([commit_page(commit) for commit in commits])
    axes.set_ylabel("SGM CPU ms per solve")
    axes.set_ylim(bottom=0)
    axes.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    _commit_ticks(axes, [(commit, index) for index, commit in enumerate(commits)], names)
    return _svg(figure)


def _profile(samples: pd.DataFrame) -> str:
    times = _instance_times(samples)
    if times.empty:
        return "<p>No solves.</p>"
    profile = performance_profile(performance_ratios(times))
    figure, axes = plt.subplots(figsize=(6, 3))
    for solver in profile.columns:
        axes.step(profile.index, profile[solver], where="post", label=solver, linewidth=1)
    axes.set_xscale("log")
    axes.set_xlabel("tau: time within this factor of the fastest solver")
    axes.set_ylabel("share of instances")
    axes.set_ylim(0, 1.02)
    axes.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return _svg(figure)


def _commit(tracker: Tracker, commit: str, samples: pd.DataFrame) -> str:
    name = tracker.names.get(commit, commit)
    parts = []
    if len(samples):
        first = samples.iloc[0]
        parts.append(
            f"<p>Committed {html.escape(str(first['commit_date']))}; measured "
            f"{html.escape(str(first['measured']))} on {html.escape(str(first['machine_name']))}; "
            f"{samples['session'].nunique()} sessions, "
            f"{samples['round'].nunique()} rounds, {len(samples)} samples.</p>"
        )
        problems = sorted({line for text in samples["problems"] for line in str(text).splitlines() if line})
        if problems:
            listed = "".join(f"<li>{html.escape(line)}</li>" for line in problems)
            parts.append(f'<h2 class="bad">Problems</h2><ul class="bad">{listed}</ul>')
    parts.append("<h2>Per instance</h2>")
    parts.append(_instance_table(samples))
    times = _instance_times(samples)
    if not times.empty:
        sgm = times.apply(
            lambda column: shifted_geometric_mean(column.dropna()) if column.notna().any() else math.nan
        )
        cells = "".join(
            f"<tr><td class='text'>{html.escape(s)}</td><td>{v * 1e3:.4g}</td></tr>" for s, v in sgm.items()
        )
        parts.append(
            "<h2>Shifted geometric means</h2><table><tr><th>solver</th><th>CPU ms per solve</th></tr>"
            f"{cells}</table>"
        )
        parts.append("<h2>Performance profile</h2>" + _profile(samples))
    return _page(name, "".join(parts), depth=1)


def _instance_table(samples: pd.DataFrame) -> str:
    """One row per case and instance: its clock's median CPU seconds per solve, samples, sample size and
    whether every answer passed the check; the rows of a case under an anchor of its own."""
    rows = []
    for (case, cold), of_case in samples.groupby(["case", "cold"], sort=True):
        name = f"{case} (first call)" if cold else case
        clock = clock_of(of_case)
        seconds = of_case.assign(seconds=per_solve(of_case, clock))
        for index, (instance, of_instance) in enumerate(seconds.groupby("instance", sort=True)):
            anchor = f' id="{case_anchor(name)}"' if index == 0 else ""
            valid = bool(of_instance["valid"].astype(bool).all())
            checked = "<td class='text'>yes</td>" if valid else "<td class='text bad'>no: see problems</td>"
            rows.append(
                f"<tr{anchor}><td class='text'>{html.escape(name)}</td><td>{instance}</td>"
                f"<td>{of_instance['seconds'].median() * 1e3:.4g}</td><td>{clock}</td>"
                f"<td>{len(of_instance)}</td><td>{int(of_instance['number'].median())}</td>{checked}</tr>"
            )
    return (
        "<table><tr><th>case</th><th>instance</th><th>CPU ms per solve (median)</th><th>clock</th>"
        "<th>samples</th><th>solves per sample</th><th>answers checked</th></tr>" + "".join(rows) + "</table>"
    )
