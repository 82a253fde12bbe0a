"""A parameter sweep: choose settings on the tuning seeds, check the best on report seeds.

A sweep file (YAML, paths relative to it; docs/scale-out.md has the full format)::

    name: pf-sigma
    pipelines: [../pipelines/search-pattern-pf.yaml]     # or {path, stream, label}
    scenarios: [search_flat_right, search_flat_left]     # default: each pipeline's own
    set: ["estimators.pf.init=truth"]                    # fixed overrides of every run
    grid:                                                # every combination ...
      estimators.pf.constraints.search_pattern_icp.sigma: [0.1, 0.2, 0.3]
    # random: {samples: 20, seed: 0, params: {KEY: {log_uniform: [0.05, 1.0]}}}  # ... or these
    seeds: {tuning: tuning, report: report}
    objective: {metric: rmse_m, goal: min}              # median over the tuning runs
    best: 1                                              # settings checked on report seeds
    baseline: {path: ../pipelines/search-pattern-pf.yaml, stream: ins.pose}

Phase 1 runs every (pipeline, setting) on every scenario and tuning seed; each setting is
ranked by the median of its per-run objective (a setting with a failed run is not
eligible). Phase 2 runs the ``best`` settings, and the baseline, on the report seeds.
Every run is one task on the executor (:mod:`firenav_framework.scaleout`); its figures
are appended to ``results.jsonl`` as it finishes, so a sweep started again with the
same output folder only runs what is missing. The tidy table (``results.csv``, and
``results.parquet`` when pyarrow is installed) has one row per run and agent (agent
``all``: the run's agents pooled) and ``report.md`` the ranking and the spreads.
"""
from __future__ import annotations

import hashlib
import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from ..pipeline import pydantic_message
from ..scaleout import Executor, Journal, Progress, SerialExecutor, Task
from ..yaml_locations import ConfigError, LocatedDocument, load
from .metrics import CONVERGE_BOUND_M, KEYS
from .runs import TRUTH_MODES, EvaluationError, RunSpec, plan_evaluation, run_one
from .seeds import SeedError, describe_seeds, parse_seeds
from .sweep_report import Ranked, rank, table_rows, write_report, write_table

#: Figures where larger is better (every other figure is an error or a time).
MAXIMISE = frozenset({"floor_accuracy"})


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class PipelineEntry(_Strict):
    """A pipeline of the sweep (or its baseline): file, evaluated stream, own overrides."""

    path: str
    stream: str | None = None
    label: str | None = None
    set: list[str] = Field(default_factory=list)


class Distribution(_Strict):
    """One random-search parameter: exactly one of the four forms."""

    uniform: tuple[float, float] | None = None
    log_uniform: tuple[float, float] | None = None
    integers: tuple[int, int] | None = None
    choice: list[Any] | None = None

    @model_validator(mode="after")
    def _one(self) -> "Distribution":
        given = [k for k in ("uniform", "log_uniform", "integers", "choice")
                 if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError("give exactly one of uniform, log_uniform, integers, choice")
        if self.log_uniform is not None and min(self.log_uniform) <= 0:
            raise ValueError("log_uniform bounds must be positive")
        return self

    def draw(self, rng: np.random.Generator) -> Any:
        if self.uniform is not None:
            return float(rng.uniform(*self.uniform))
        if self.log_uniform is not None:
            lo, hi = self.log_uniform
            return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))
        if self.integers is not None:
            return int(rng.integers(self.integers[0], self.integers[1] + 1))
        return self.choice[int(rng.integers(len(self.choice)))]


class RandomSearch(_Strict):
    """``samples`` settings drawn from ``params`` with a generator seeded by ``seed``."""

    samples: int = Field(gt=0)
    seed: int = 0
    params: dict[str, Distribution]


class SeedSets(_Strict):
    """Seed expressions (:mod:`.seeds`) of the two phases; ``report: null`` skips phase 2."""

    tuning: str | int = "tuning"
    report: str | int | None = "report"


class Objective(_Strict):
    """The figure settings are ranked by (median over runs) and which way is better."""

    metric: str = "rmse_m"
    goal: Literal["min", "max"] | None = None


class SweepFile(_Strict):
    """The sweep file (module docstring; docs/scale-out.md)."""

    name: str | None = None
    pipelines: list[PipelineEntry | str] = Field(min_length=1)
    scenarios: list[str] | None = None
    set: list[str] = Field(default_factory=list)
    grid: dict[str, list[Any]] = Field(default_factory=dict)
    random: RandomSearch | None = None
    seeds: SeedSets = SeedSets()
    objective: Objective = Objective()
    best: int = Field(1, ge=1)
    baseline: PipelineEntry | str | None = None
    truth: str = "auto"
    align: str = "none"
    converge_bound_m: float = Field(CONVERGE_BOUND_M, gt=0)

    @model_validator(mode="after")
    def _check(self) -> "SweepFile":
        if self.grid and self.random is not None:
            raise ValueError("give either grid or random, not both")
        if any(not v for v in self.grid.values()):
            raise ValueError("every grid parameter needs at least one value")
        if self.objective.metric not in KEYS:
            raise ValueError(f"objective metric '{self.objective.metric}' must be one of "
                             f"{', '.join(KEYS)}")
        if self.truth not in TRUTH_MODES:
            raise ValueError(f"truth must be one of {', '.join(TRUTH_MODES)}")
        return self


@dataclass(frozen=True)
class Setting:
    """One point of the search: its id and the parameter values (``--set`` overrides)."""

    id: str
    params: tuple[tuple[str, Any], ...]

    def overrides(self) -> list[str]:
        return [f"{k}={json.dumps(v)}" for k, v in self.params]


@dataclass
class Sweep:
    """A read and checked sweep file: everything but the runs themselves."""

    file: Path
    name: str
    spec: SweepFile
    pipelines: list[PipelineEntry]
    baseline: PipelineEntry | None
    settings: list[Setting]
    tuning_seeds: list[int]
    report_seeds: list[int]
    goal: str
    param_keys: list[str] = field(default_factory=list)

    @property
    def metric(self) -> str:
        return self.spec.objective.metric


def _entry(item: PipelineEntry | str, base: Path) -> PipelineEntry:
    e = PipelineEntry(path=item) if isinstance(item, str) else item
    p = Path(e.path).expanduser()
    p = p if p.is_absolute() else base / p
    return e.model_copy(update={"path": str(p.resolve()), "label": e.label or p.stem})


def settings_of(spec: SweepFile) -> list[Setting]:
    """The grid's combinations (in file order), or the random search's samples."""
    if spec.random is not None:
        rng = np.random.default_rng(spec.random.seed)
        keys = list(spec.random.params)
        return [Setting(f"s{i + 1:03d}", tuple((k, spec.random.params[k].draw(rng))
                                                for k in keys))
                for i in range(spec.random.samples)]
    if not spec.grid:
        return [Setting("default", ())]
    keys = list(spec.grid)
    return [Setting(f"s{i + 1:03d}", tuple(zip(keys, values)))
            for i, values in enumerate(itertools.product(*(spec.grid[k] for k in keys)))]


def load_sweep(path: str | Path) -> Sweep:
    """Read and check a sweep file; problems come with file:line:col (ConfigError)."""
    path = Path(path)
    doc = load(path)
    if not isinstance(doc.data, dict):
        raise ConfigError([doc.problem((), "a sweep file is a mapping (pipelines, grid, "
                                       "seeds, ...)")])
    try:
        spec = SweepFile.model_validate(doc.data)
    except ValidationError as exc:
        raise ConfigError([_located(doc, err) for err in exc.errors()]) from None
    base = path.resolve().parent
    try:
        tuning = parse_seeds(str(spec.seeds.tuning))
        report = parse_seeds(str(spec.seeds.report)) if spec.seeds.report is not None else []
    except SeedError as exc:
        raise ConfigError([doc.problem(("seeds",), str(exc))]) from None
    overlap = sorted(set(tuning) & set(report))
    if overlap:
        raise ConfigError([doc.problem(("seeds",), f"tuning and report seeds overlap "
                                       f"({describe_seeds(overlap)}): report figures must "
                                       "come from seeds no setting was chosen on")])
    pipes = [_entry(p, base) for p in spec.pipelines]
    for i, p in enumerate(pipes):
        if not Path(p.path).is_file():
            raise ConfigError([doc.problem(("pipelines", i), f"pipeline {p.path} not found")])
    baseline = _entry(spec.baseline, base) if spec.baseline is not None else None
    if baseline is not None and not Path(baseline.path).is_file():
        raise ConfigError([doc.problem(("baseline",), f"pipeline {baseline.path} not found")])
    goal = spec.objective.goal or ("max" if spec.objective.metric in MAXIMISE else "min")
    settings = settings_of(spec)
    keys = list(spec.random.params) if spec.random is not None else list(spec.grid)
    return Sweep(file=path, name=spec.name or path.stem, spec=spec, pipelines=pipes,
                 baseline=baseline, settings=settings, tuning_seeds=tuning,
                 report_seeds=report, goal=goal, param_keys=keys)


def _located(doc: LocatedDocument, err: dict):
    loc = tuple(p for p in err["loc"] if not (isinstance(p, str) and p in (
        "PipelineEntry", "str", "function-after[_one(), Distribution]")))
    return doc.problem(loc, pydantic_message(err))


# -- the runs ----------------------------------------------------------------------

@dataclass(frozen=True)
class Cell:
    """One run of the sweep and where it belongs in the table.

    ``key`` is its identity for resuming: a hash of the run's inputs and of the
    pipeline file's content, so editing the pipeline or a value runs the cell again.
    """

    phase: str              # "tuning", "report" or "baseline"
    pipeline: str           # label
    setting: Setting
    scenario: str | None
    run: RunSpec
    key: str

    @property
    def label(self) -> str:
        return (f"{self.phase} {self.pipeline} {self.setting.id} "
                f"{self.scenario or ''} seed {self.run.seed}").replace("  ", " ")


def sweep_run(run: RunSpec) -> list[dict[str, Any]]:
    """One run's figures as table rows: agent ``all`` (pooled) first, then each agent."""
    ev = run_one(run)
    rows = [{"agent": "all", **ev.figures.as_dict()}]
    rows += [{"agent": a, **m.as_dict()} for a, m in sorted(ev.metrics.items())]
    for r in rows:
        r["wall_s"] = round(ev.wall_s, 3)
    return rows


def plan_cells(sweep: Sweep, phase: str, entries: list[tuple[PipelineEntry, Setting]],
               seeds: list[int]) -> list[Cell]:
    """Cells of ``entries`` x scenarios x ``seeds``; each combination validated up front.

    The sweep's fixed ``set`` applies to its pipelines, not to the baseline, which has
    only its own ``set`` (it may be another pipeline without those keys).
    """
    cells = []
    s = sweep.spec
    fixed = [] if phase == "baseline" else s.set
    for entry, setting in entries:
        for scenario in s.scenarios or [None]:
            try:
                plan = plan_evaluation(entry.path, scenario=scenario, seeds=seeds,
                                       stream=entry.stream,
                                       overrides=fixed + entry.set + setting.overrides(),
                                       truth_mode=s.truth, align=s.align,
                                       bound_m=s.converge_bound_m)
            except EvaluationError as exc:
                raise EvaluationError(f"{sweep.file}: {entry.label} {setting.id}: {exc}") from None
            digest = hashlib.sha256(Path(entry.path).read_bytes()).hexdigest()
            cells += [Cell(phase, entry.label, setting, scenario, r, _cell_key(phase, r, digest))
                      for r in plan.runs]
    return cells


def _cell_key(phase: str, r: RunSpec, pipeline_digest: str) -> str:
    ident = json.dumps([r.pipeline, pipeline_digest, list(r.overrides), r.stream, r.truth_mode,
                        r.align, r.bound_m])
    return f"{phase}-{hashlib.sha256(ident.encode()).hexdigest()[:16]}"


def _record(cell: Cell, outcome) -> dict[str, Any]:
    return {"key": cell.key, "ok": outcome.ok, "phase": cell.phase, "pipeline": cell.pipeline,
            "setting": cell.setting.id, "params": dict(cell.setting.params),
            "scenario": cell.scenario, "seed": cell.run.seed, "attempts": outcome.attempts,
            "error": outcome.error, "rows": outcome.value if outcome.ok else []}


def run_cells(cells: list[Cell], journal: Journal, executor: Executor,
              progress: Progress, what: str) -> None:
    """Run the cells the journal does not have yet, appending each result as it comes."""
    done = journal.done()
    todo = [c for c in cells if c.key not in done]
    by_key = {c.key: c for c in todo}
    tasks = [Task(c.key, c.label, sweep_run, (c.run,)) for c in todo]
    if progress is not None and len(todo) < len(cells):
        progress.note(f"{what}: {len(cells) - len(todo)} of {len(cells)} runs already in "
                      f"{journal.path.name}, {len(todo)} to run")
    progress.start(len(tasks), what)
    try:
        for outcome in executor.run(tasks, progress):
            journal.append(_record(by_key[outcome.task.key], outcome))
    finally:
        progress.close()


@dataclass
class SweepResult:
    """What a sweep wrote and how it went."""

    out_dir: Path
    ranked: list[Ranked]
    best: list[Ranked]
    table: list[Path]
    report: Path
    runs: int
    failed: int


def run_sweep(sweep: Sweep, out_dir: str | Path, *, executor: Executor | None = None,
              progress: Progress | None = None) -> SweepResult:
    """Both phases (see the module docstring); resumes from ``out_dir/results.jsonl``."""
    executor = executor or SerialExecutor()
    progress = progress or Progress()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    journal = Journal(out / "results.jsonl")
    tuning = plan_cells(sweep, "tuning", [(p, st) for p in sweep.pipelines
                                          for st in sweep.settings], sweep.tuning_seeds)
    run_cells(tuning, journal, executor, progress, "tuning")
    ranked = rank(sweep, tuning, journal)
    best = [r for r in ranked if r.eligible][:sweep.spec.best]
    report_cells: dict[str, list[Cell]] = {}
    baseline_cells: list[Cell] = []
    if sweep.report_seeds:
        for r in best:
            report_cells[f"{r.pipeline.label} {r.setting.id}"] = plan_cells(
                sweep, "report", [(r.pipeline, r.setting)], sweep.report_seeds)
        if sweep.baseline is not None:
            baseline_cells = plan_cells(sweep, "baseline",
                                        [(sweep.baseline, Setting("baseline", ()))],
                                        sweep.report_seeds)
        run_cells([c for cs in report_cells.values() for c in cs] + baseline_cells, journal,
                  executor, progress, "report")
    cells = tuning + [c for cs in report_cells.values() for c in cs] + baseline_cells
    table = write_table(table_rows(sweep, cells, journal), out)
    report = write_report(sweep, ranked, report_cells, baseline_cells, cells, journal, out)
    failed = sum(1 for c in cells if not journal.records.get(c.key, {}).get("ok"))
    return SweepResult(out, ranked, best, table, report, len(cells), failed)


