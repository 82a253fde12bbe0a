"""A Markdown evaluation page with plots (matplotlib, headless Agg).

``write_report(evaluation, out_dir)`` writes ``report.md`` with the figures table
(pipeline and baseline side by side: pooled over all runs, and the spread of each
figure over runs, see :mod:`.spread`), per agent, and three kinds of PNG:

* ``tracks_seed<k>_floor<i>.png``: truth, estimate and baseline of the first runs over
  the floor plan, with 2-sigma position ellipses along the estimate;
* ``error_time.png``: horizontal error over time, every run and agent;
* ``error_cdf.png``: cumulative distribution of the pooled horizontal errors.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..figures import add_position_ellipse, pyplot, save_figure
from ..tracks import Track
from .metrics import KEYS
from .runs import Evaluation, RunEvaluation
from .seeds import describe_seeds
from .spread import Spread

_LABELS = {
    "rmse_m": "RMSE [m]", "mean_m": "mean [m]", "median_m": "median [m]", "p90_m": "90 % [m]",
    "p95_m": "95 % [m]", "max_m": "max [m]", "mean_pct_distance": "mean / distance [%]",
    "max_pct_distance": "max / distance [%]", "distance_m": "true distance [m]",
    "vertical_rmse_m": "vertical RMSE [m]", "floor_accuracy": "floor accuracy",
    "converge_s": "converged after [s]",
    "ellipse95_containment": "truth in 95 % ellipse", "nees_xy": "NEES (x, y; 2 if consistent)",
    "protection_containment": "error within protection radius",
    "trusted_fraction": "trusted", "trusted_off_fraction": "trusted while > 3 m off",
    "variance_converge_s": "converged (var_x + var_y < 3 m^2) after [s]",
    "rmse_after_convergence_m": "RMSE after convergence [m]",
    "converged_fraction": "tracks that converge",
}


def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        if v == np.inf:
            return "never"
        return f"{v:.3f}" if abs(v) < 10 else f"{v:.1f}"
    return str(v)


def fmt_spread(s: Spread) -> tuple[str, str]:
    """(``"min / median / max"``, ``"[low, high]"``) of a spread; "-" where it has none."""
    if s.n == 0:
        return "-", "-"
    mmm = f"{_fmt(s.min)} / {_fmt(s.median)} / {_fmt(s.max)}"
    ci = f"[{_fmt(s.ci_low)}, {_fmt(s.ci_high)}]" if s.ci_low is not None else "-"
    return mmm, ci


#: Header of :func:`figure_rows` (the baseline's three columns follow when there is one).
FIGURE_HEADER = ("figure", "pipeline pooled", "runs: min / median / max", "95 % CI of median")


def figure_rows(ev: Evaluation) -> list[list[str]]:
    """Every figure: pooled over all runs, and its spread over runs; then the baseline's."""
    spreads = ev.spread()
    base = ev.baseline
    base_spreads = base.spread() if base is not None else {}
    rows = []
    for k in KEYS:
        row = [_LABELS[k], _fmt(getattr(ev.overall, k)), *fmt_spread(spreads[k])]
        if base is not None:
            row += [_fmt(getattr(base.overall, k)), *fmt_spread(base_spreads[k])]
        rows.append(row)
    return rows


def figure_header(ev: Evaluation) -> list[str]:
    head = list(FIGURE_HEADER)
    if ev.baseline is not None:
        head += ["baseline pooled", "baseline runs", "baseline 95 % CI"]
    return head


def _track_plot(run: RunEvaluation, base: RunEvaluation | None, out: Path, label: str,
                base_label: str, every_s: float = 15.0) -> list[Path]:
    plt = pyplot()
    building = run.building
    floors = sorted({int(f) for tr in run.truth.values() for f in np.unique(tr.floor) if f >= 0}
                    or {0})
    paths = []
    for fl in floors:
        fig, ax = plt.subplots(figsize=(9, 6.5))
        if building is not None:
            from ..building.plot import draw_floor
            draw_floor(ax, building, fl)
        for agent, truth in run.truth.items():
            m = truth.floor == fl if (truth.floor >= 0).any() else np.ones(len(truth), bool)
            ax.plot(truth.position[m, 0], truth.position[m, 1], "k--", lw=0.9, alpha=0.7,
                    label=f"truth {agent}")
        for tracks, color, name in ((run.tracks, "#d62728", label),
                                    (base.tracks if base else {}, "#1f77b4", base_label)):
            for agent, tr in tracks.items():
                if len(tr) == 0:
                    continue
                m = _on_floor(tr, run.truth.get(agent), fl)
                ax.plot(tr.position[m, 0], tr.position[m, 1], "-", color=color, lw=1.1,
                        label=f"{name} {agent}")
                next_t = -np.inf
                for t, p, c in zip(tr.t[m], tr.position[m], tr.cov[m]):
                    if t >= next_t:
                        add_position_ellipse(ax, p[:2], c, color, lw=0.6)
                        next_t = t + every_s
        ax.set_aspect("equal")
        ax.set_xlabel("x east [m]")
        ax.set_ylabel("y north [m]")
        ax.set_title(f"seed {run.seed}, floor {fl} (ellipses: 2 sigma every {every_s:g} s)")
        ax.legend(fontsize=6, loc="best")
        paths.append(save_figure(fig, out / f"tracks_seed{run.seed}_floor{fl}.png"))
    return paths


def _on_floor(tr: Track, truth: Track | None, fl: int) -> np.ndarray:
    if (tr.floor >= 0).any():
        return tr.floor == fl
    if truth is not None and (truth.floor >= 0).any():
        idx = np.clip(np.searchsorted(truth.t, tr.t), 0, len(truth) - 1)
        return truth.floor[idx] == fl
    return np.ones(len(tr), bool)


def _error_plots(ev: Evaluation, out: Path) -> tuple[Path, Path]:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 4))
    series = [(ev, "#d62728", "pipeline")]
    if ev.baseline is not None:
        series.append((ev.baseline, "#1f77b4", "baseline"))
    for e, color, name in series:
        first = True
        for run in e.runs:
            for agent, err in run.errors.items():
                ax.plot(err.t, err.horizontal, "-", color=color, lw=0.7, alpha=0.5,
                        label=name if first else None)
                first = False
    ax.axhline(ev.bound_m, color="k", lw=0.6, ls=":", label=f"convergence bound {ev.bound_m:g} m")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("horizontal error [m]")
    ax.legend(fontsize=7)
    p_time = save_figure(fig, out / "error_time.png")
    fig, ax = plt.subplots(figsize=(6, 4))
    for e, color, name in series:
        errs = np.sort(np.concatenate([err.horizontal for r in e.runs for err in r.errors.values()]
                                      or [np.empty(0)]))
        if errs.size:
            ax.plot(errs, np.arange(1, errs.size + 1) / errs.size, color=color, label=name)
    ax.set_xlabel("horizontal error [m]")
    ax.set_ylabel("fraction of estimates")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    p_cdf = save_figure(fig, out / "error_cdf.png")
    return p_time, p_cdf


def write_report(ev: Evaluation, out_dir: str | Path, *, track_runs: int = 2) -> Path:
    """Write ``report.md`` and its plots under ``out_dir``; returns the Markdown path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    base = ev.baseline
    lines = [f"# Evaluation: {Path(ev.pipeline).name}", ""]
    lines += [f"- scenario: `{ev.scenario}`" if ev.scenario else "- recorded data",
              f"- seeds: {describe_seeds(ev.seeds)} ({len(ev.runs)} runs)",
              f"- evaluated stream: `{ev.stream}`; truth: {ev.truth_mode}; alignment: {ev.align}",
              f"- convergence: error stays below {ev.bound_m:g} m"]
    if base is not None:
        lines.append(f"- baseline: `{Path(base.pipeline).name}` stream `{base.stream}` "
                     "on the same seeds")
    head = figure_header(ev)
    lines += ["", "## Overall", "",
              "Pooled: all samples of all runs; runs: each run's figure (its agents pooled), "
              "min / median / max over runs and the distribution-free 95 % confidence "
              "interval of the median (needs >= 6 runs).", "",
              "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(row) + " |" for row in figure_rows(ev)]
    lines += ["", "## Per agent (all seeds pooled)", ""]
    head = ["agent", "RMSE [m]", "mean [m]", "p95 [m]", "max [m]", "mean/dist [%]",
            "vertical RMSE [m]", "floor acc.", "converged [s]"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, e in (("", ev), (" (baseline)", base)):
        if e is None:
            continue
        for agent, m in e.per_agent.items():
            lines.append("| " + " | ".join([agent + name] + [_fmt(v) for v in (
                m.rmse_m, m.mean_m, m.p95_m, m.max_m, m.mean_pct_distance, m.vertical_rmse_m,
                m.floor_accuracy, m.converge_s)]) + " |")
    p_time, p_cdf = _error_plots(ev, out)
    lines += ["", "## Error over time", "", f"![error over time]({p_time.name})", "",
              "## Error distribution", "", f"![error CDF]({p_cdf.name})", "", "## Tracks", ""]
    for run in ev.runs[:track_runs]:
        brun = next((b for b in base.runs if b.seed == run.seed), None) if base else None
        for p in _track_plot(run, brun, out, "pipeline", "baseline"):
            lines += [f"![tracks]({p.name})", ""]
    missing = sorted({a for r in ev.runs for a in r.missing_truth})
    outside = sum(r.outside_checkpoints for r in ev.runs)
    failed = [(name, f) for name, e in (("", ev), ("baseline ", base)) if e is not None
              for f in e.failed]
    if missing or outside or failed:
        lines += ["## Notes", ""]
        for name, f in failed:
            lines.append(f"- {name}seed {f.seed} FAILED after {f.attempts} attempts "
                         f"(not scored): {f.error}")
        if missing:
            lines.append(f"- no ground truth for agents: {', '.join(missing)} (not scored)")
        if outside:
            lines.append(f"- {outside} checkpoints fell outside the estimate's time span "
                         "(not scored)")
    path = out / "report.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
