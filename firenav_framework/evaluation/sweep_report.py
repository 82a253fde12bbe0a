"""A sweep's results: the ranking of settings, the tidy table and the Markdown report.

Everything here is computed from the journal (``results.jsonl``) alone, so the table
and the report of a resumed sweep are the same as those of an uninterrupted one.
"""
from __future__ import annotations

import csv
import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..scaleout import Journal
from .metrics import KEYS, TIME_KEYS
from .report import _LABELS, fmt_spread
from .seeds import describe_seeds
from .spread import Spread, spread

if TYPE_CHECKING:
    from .sweep import Cell, PipelineEntry, Setting, Sweep

log = logging.getLogger("firenav.sweep")


@dataclass
class Ranked:
    """A (pipeline, setting) over its tuning runs."""

    pipeline: "PipelineEntry"
    setting: "Setting"
    objective: Spread
    ok: int
    failed: int

    @property
    def eligible(self) -> bool:
        """Only a setting whose every run succeeded can be chosen."""
        return self.failed == 0 and self.objective.median is not None


def pooled_row(record: dict | None) -> dict | None:
    """The agent-``all`` row of a successful run's record."""
    if not record or not record.get("ok"):
        return None
    return next((row for row in record["rows"] if row["agent"] == "all"), None)


def rank(sweep: "Sweep", cells: list["Cell"], journal: Journal) -> list[Ranked]:
    """Every (pipeline, setting), best first by the median of its per-run objective."""
    groups: dict[tuple[str, str], list[dict | None]] = {}
    for c in cells:
        groups.setdefault((c.pipeline, c.setting.id), []).append(journal.records.get(c.key))
    entries = {p.label: p for p in sweep.pipelines}
    settings = {s.id: s for s in sweep.settings}
    out = []
    for (label, sid), recs in groups.items():
        rows = [pooled_row(r) for r in recs]
        vals = [row[sweep.metric] for row in rows if row is not None]
        ok = sum(1 for row in rows if row is not None)
        out.append(Ranked(entries[label], settings[sid],
                          spread(vals, none_is_inf=(sweep.metric in TIME_KEYS)),
                          ok=ok, failed=len(recs) - ok))
    sign = -1.0 if sweep.goal == "max" else 1.0

    def order(r: Ranked) -> tuple:
        med = r.objective.median
        return (not r.eligible, math.inf if med is None else sign * med)
    return sorted(out, key=order)


def table_rows(sweep: "Sweep", cells: list["Cell"], journal: Journal) -> list[dict[str, Any]]:
    """The tidy table: one row per run and agent; a failed run is one row with its error."""
    rows = []
    for c in cells:
        rec = journal.records.get(c.key)
        if rec is None:
            continue
        params = dict(c.setting.params)
        head = {"phase": c.phase, "pipeline": c.pipeline, "setting": c.setting.id,
                **{k: params.get(k) for k in sweep.param_keys},
                "scenario": c.scenario or "", "seed": c.run.seed, "ok": rec["ok"],
                "attempts": rec["attempts"], "error": rec["error"] or ""}
        if rec["ok"]:
            rows += [{**head, **row} for row in rec["rows"]]
        else:
            rows.append({**head, "agent": "all"})
    return rows


def write_table(rows: list[dict[str, Any]], out_dir: Path) -> list[Path]:
    """``results.csv``, and ``results.parquet`` when pyarrow is installed."""
    cols: list[str] = []
    for r in rows:
        cols += [k for k in r if k not in cols]
    paths = [out_dir / "results.csv"]
    with paths[0].open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=cols, restval="")
        w.writeheader()
        w.writerows(rows)
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return paths
    try:
        pq.write_table(pa.Table.from_pylist([{c: r.get(c) for c in cols} for r in rows]),
                       out_dir / "results.parquet")
    except (pa.ArrowInvalid, pa.ArrowTypeError) as exc:   # e.g. a parameter of mixed types
        log.warning("results.parquet not written (%s); results.csv has everything", exc)
        return paths
    return paths + [out_dir / "results.parquet"]


def _params_text(setting: "Setting") -> str:
    return ", ".join(f"`{k}={_value(v)}`" for k, v in setting.params) or "(pipeline as is)"


def _value(v: Any) -> str:
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def _spread_cells(s: Spread) -> str:
    mmm, ci = fmt_spread(s)
    return f"{mmm} {ci}" if ci != "-" else mmm


def _phase_spreads(cells: list["Cell"], journal: Journal) -> tuple[dict[str, Spread], int, int]:
    rows = [pooled_row(journal.records.get(c.key)) for c in cells]
    got = [r for r in rows if r is not None]
    return ({k: spread([r[k] for r in got], none_is_inf=(k in TIME_KEYS)) for k in KEYS},
            len(got), len(rows) - len(got))


def write_report(sweep: "Sweep", ranked: list[Ranked], report_cells: dict[str, list["Cell"]],
                 baseline_cells: list["Cell"], all_cells: list["Cell"], journal: Journal,
                 out_dir: Path) -> Path:
    """``report.md``: the ranking on the tuning seeds, the best on the report seeds."""
    s = sweep.spec
    goal = "lowest" if sweep.goal == "min" else "highest"
    scenarios = ", ".join(f"`{x}`" for x in s.scenarios) if s.scenarios else "each pipeline's own"
    report_seeds = describe_seeds(sweep.report_seeds) if sweep.report_seeds else "none"
    lines = [f"# Sweep: {sweep.name}", "",
             f"- sweep file: `{sweep.file}`",
             f"- pipelines: {', '.join(f'`{p.label}`' for p in sweep.pipelines)}",
             f"- scenarios: {scenarios}",
             f"- fixed overrides: {', '.join(f'`{x}`' for x in s.set) or 'none'}",
             f"- {len(sweep.settings)} settings ({'random search' if s.random else 'grid'})",
             f"- tuning seeds: {describe_seeds(sweep.tuning_seeds)}",
             f"- report seeds: {report_seeds}",
             f"- objective: {goal} median over the tuning runs of each run's "
             f"{_LABELS[sweep.metric]} (each run's agents pooled)", "",
             "Settings are chosen on the tuning seeds only; the report seeds are run for the "
             "chosen settings after the choice, and their figures are the ones to report.", "",
             f"## Ranking on the tuning seeds ({_LABELS[sweep.metric]})", "",
             "| rank | pipeline | setting | values | runs | failed | min / median / max "
             "[95 % CI of median] |", "|---|---|---|---|---|---|---|"]
    for i, r in enumerate(ranked, 1):
        lines.append(f"| {i if r.eligible else '-'} | {r.pipeline.label} | {r.setting.id} | "
                     f"{_params_text(r.setting)} | {r.ok} | {r.failed} | "
                     f"{_spread_cells(r.objective)} |")
    if any(not r.eligible for r in ranked):
        lines += ["", "A setting with a failed run is not ranked (`-`)."]
    if report_cells:
        base_sp = _phase_spreads(baseline_cells, journal) if baseline_cells else None
        lines += ["", f"## Best on the report seeds ({describe_seeds(sweep.report_seeds)})", "",
                  "Each run's figure (its agents pooled): min / median / max over runs "
                  "[distribution-free 95 % confidence interval of the median]."]
        for label, cells in report_cells.items():
            r = next(x for x in ranked if f"{x.pipeline.label} {x.setting.id}" == label)
            sp, ok, failed = _phase_spreads(cells, journal)
            head = f"| figure | {label} ({ok} runs{f', {failed} failed' if failed else ''}) |"
            sep = "|---|---|"
            if base_sp is not None:
                head += f" baseline `{sweep.baseline.label}` ({base_sp[1]} runs) |"
                sep += "---|"
            lines += ["", f"### {label}: {_params_text(r.setting)}", "",
                      "Use with: " + (" ".join(f"`--set {o}`" for o in r.setting.overrides())
                                      or "the pipeline as is"), "", head, sep]
            for k in KEYS:
                row = f"| {_LABELS[k]} | {_spread_cells(sp[k])} |"
                if base_sp is not None:
                    row += f" {_spread_cells(base_sp[0][k])} |"
                lines.append(row)
    failures = [(c, journal.records[c.key]) for c in all_cells
                if c.key in journal.records and not journal.records[c.key]["ok"]]
    if failures:
        lines += ["", "## Failed runs (after one retry)", "",
                  "| phase | pipeline | setting | scenario | seed | attempts | error |",
                  "|---|---|---|---|---|---|---|"]
        for c, rec in failures:
            err = str(rec["error"]).replace("|", "\\|").replace("\n", " ")
            lines.append(f"| {c.phase} | {c.pipeline} | {c.setting.id} | {c.scenario or ''} | "
                         f"{c.run.seed} | {rec['attempts']} | {err} |")
    lines += ["", "Every run: `results.csv` (one row per run and agent; agent `all` pools "
              "the run's agents)."]
    path = out_dir / "report.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path

