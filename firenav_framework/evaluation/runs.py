"""Running a pipeline against ground truth over several seeds (and a baseline alike).

:func:`plan_evaluation` turns a pipeline, scenario, seeds and ``--set`` overrides into
one :class:`RunSpec` per seed: the pipeline with overrides of its ``simulator`` source
(``seed``, and ``scenario`` when one is given). :func:`run_one` runs one of them and
measures every agent's track on the evaluated pose stream (by default the ``pose``
output of the last estimator) against the truth the run carried; it is a pure
function of its RunSpec, so it can run on any worker (:mod:`firenav_framework.
scaleout`). :func:`run_plans` runs several plans (a pipeline and its baseline) on one
executor and assembles an :class:`Evaluation` per plan, with the spread of every
figure over runs (:mod:`.spread`). A pipeline without a simulator (a recording with
surveyed checkpoints) is run once.

Truth modes: ``dense`` (truth interpolated to the estimate times), ``sparse`` (the
truth stream is checkpoints: the estimate is interpolated to them, see
:mod:`.checkpoints`), ``checkpoints`` (the scenario's marked stops, like the ORCA
paper's check points), ``auto`` (sparse when the truth is, else dense).
"""
from __future__ import annotations

import json
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..pipeline import PipelineSpec, load_pipeline
from ..scaleout import Executor, LineProgress, Progress, SerialExecutor, Task
from ..scaleout.executor import executor_from_environment
from ..scaleout.journal import json_default
from ..tracks import Track
from .checkpoints import Checkpoints, checkpoint_errors, is_sparse, parse_align
from .metrics import (CONVERGE_BOUND_M, KEYS, TrackErrors, TrackMetrics, metrics_of,
                      pooled_metrics, track_errors)
from .seeds import seed_set_name
from .spread import Spread, run_figures, spreads

TRUTH_MODES = ("auto", "dense", "sparse", "checkpoints")


class EvaluationError(ValueError):
    """The evaluation cannot be done as asked (no stream, no truth, no simulator...)."""


@dataclass(frozen=True)
class RunSpec:
    """One run of an evaluation: all a worker needs, small and picklable.

    ``pipeline`` is an absolute path and ``overrides`` include the seed and scenario,
    so the run is the same wherever it is done (docs/scale-out.md: what workers read).
    """

    pipeline: str
    overrides: tuple[str, ...]
    seed: int | None
    stream: str
    truth_mode: str
    align: str
    bound_m: float
    sim_id: str | None
    output_dir: str | None = None
    truth_file: str | None = None   # truth read from this recording instead of the run's


@dataclass
class RunEvaluation:
    """One run (one seed) of one pipeline, measured."""

    seed: int | None
    stream: str
    metrics: dict[str, TrackMetrics]
    errors: dict[str, TrackErrors]
    tracks: dict[str, Track]
    truth: dict[str, Track]
    truth_mode: str
    outside_checkpoints: int = 0
    building: Any = None
    wall_s: float = 0.0
    missing_truth: list[str] = field(default_factory=list)
    figures: TrackMetrics | None = None     # this run's agents pooled (see .spread)
    cpu_s: float = 0.0                      # CPU time of the process during the run


@dataclass(frozen=True)
class FailedRun:
    """A run that failed twice (first attempt and its retry): its seed and last error."""

    seed: int | None
    error: str
    attempts: int
    detail: str = ""


@dataclass
class Evaluation:
    """A pipeline over all seeds: per-run figures, pooled per agent and overall."""

    pipeline: str
    scenario: str | None
    seeds: list[int | None]
    stream: str
    truth_mode: str
    align: str
    bound_m: float
    runs: list[RunEvaluation]
    overall: TrackMetrics
    per_agent: dict[str, TrackMetrics]
    baseline: "Evaluation | None" = None
    failed: list[FailedRun] = field(default_factory=list)

    def spread(self) -> dict[str, Spread]:
        """Every figure's spread over the runs (each run's agents pooled)."""
        return spreads([r.figures for r in self.runs])

    def summary(self) -> dict:
        """The JSON object of ``firenav evaluate --json`` (see docs/scenarios.md)."""
        out: dict[str, Any] = {k: getattr(self.overall, k) for k in KEYS}
        out.update({
            "runs": len(self.runs), "pipeline": self.pipeline, "scenario": self.scenario,
            "seeds": self.seeds, "seed_set": seed_set_name(self.seeds),
            "stream": self.stream, "truth_mode": self.truth_mode,
            "align": self.align, "converge_bound_m": self.bound_m, "samples": self.overall.n,
            "spread": {k: s.as_dict() for k, s in self.spread().items()},
            "per_agent": {a: m.as_dict() for a, m in self.per_agent.items()},
            "per_run": [{"seed": r.seed, "wall_s": round(r.wall_s, 3),
                         "cpu_s": round(r.cpu_s, 3),
                         "outside_checkpoints": r.outside_checkpoints,
                         "missing_truth": r.missing_truth,
                         "figures": r.figures.as_dict() if r.figures else None,
                         "agents": {a: m.as_dict() for a, m in r.metrics.items()}}
                        for r in self.runs],
            "failed": [{"seed": f.seed, "error": f.error, "attempts": f.attempts}
                       for f in self.failed],
        })
        if self.baseline is not None:
            base = self.baseline.summary()
            base.pop("baseline", None)
            out["baseline"] = base
        else:
            out["baseline"] = None
        return out


def write_json(evaluation: Evaluation, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(evaluation.summary(), indent=1, default=json_default) + "\n",
                    encoding="utf-8")
    return path


def simulator_source(spec: PipelineSpec) -> str | None:
    """Id of the pipeline's first ``simulator`` source, if any."""
    for c in spec.components:
        if c.kind == "source" and c.plugin.name == "simulator":
            return c.id
    return None


def default_stream(spec: PipelineSpec) -> str:
    """The ``pose`` stream of the last estimator in the pipeline."""
    poses = [f"{c.id}.pose" for c in spec.components
             if c.kind == "estimator" and "pose" in c.outputs]
    if not poses:
        raise EvaluationError(f"{spec.file}: no estimator with a 'pose' output; name the "
                              "evaluated stream with --stream")
    return poses[-1]


def _scenario_value(scenario: str) -> str:
    """A scenario given on the command line, made independent of the pipeline's folder."""
    p = Path(scenario).expanduser()
    return str(p.resolve()) if p.is_file() else scenario


@dataclass
class EvaluationPlan:
    """The runs of one pipeline over its seeds, validated before any of them starts."""

    pipeline: str
    name: str
    scenario: str | None
    seeds: list[int | None]
    runs: list[RunSpec]        # one per seed; stream, truth mode, alignment alike in all


def plan_evaluation(pipeline: str | Path, *, scenario: str | None = None,
                    seeds: int | list[int] = 1, stream: str | None = None,
                    overrides: list[str] = (), truth_mode: str = "auto", align: str = "none",
                    bound_m: float = CONVERGE_BOUND_M, output_dir: Path | None = None,
                    truth_file: str | Path | None = None) -> EvaluationPlan:
    """One :class:`RunSpec` per seed; the first is validated here (a bad scenario, stream
    or override fails before anything runs). ``truth_file``: a recording whose ``truth``
    port replaces the run's truth."""
    if truth_mode not in TRUTH_MODES:
        raise EvaluationError(f"truth mode '{truth_mode}' must be one of {', '.join(TRUTH_MODES)}")
    parse_align(align)
    path = str(Path(pipeline).expanduser().resolve())
    base_spec = load_pipeline(path, list(overrides))
    sim_id = simulator_source(base_spec)
    seed_list: list[int | None] = list(range(seeds)) if isinstance(seeds, int) else list(seeds)
    if sim_id is None:
        if scenario is not None:
            raise EvaluationError(f"{pipeline}: --scenario needs a pipeline with a "
                                  "'simulator' source")
        if len(seed_list) > 1:
            raise EvaluationError(f"{pipeline}: several seeds need a 'simulator' source; "
                                  "a recorded run is evaluated once")
        seed_list = [None]
    if not seed_list:
        raise EvaluationError("no seeds to run")
    truth = None
    if truth_file is not None:
        truth = str(Path(truth_file).expanduser().resolve())
        if not load_truth_file(truth):
            raise EvaluationError(f"truth file {truth_file}: it has no ground truth "
                                  "(the recording readers give it no 'truth' messages)")
    stream = stream or default_stream(base_spec)
    if stream not in base_spec.streams():
        raise EvaluationError(f"stream '{stream}' is produced by nobody in {pipeline}; "
                              f"pose streams: {', '.join(_pose_streams(base_spec)) or 'none'}")
    runs = []
    for seed in seed_list:
        over = list(overrides)
        if sim_id is not None:
            over.append(f"sources.{sim_id}.seed={seed}")
            if scenario is not None:
                over.append(f"sources.{sim_id}.scenario={json.dumps(_scenario_value(scenario))}")
        out = None
        if output_dir is not None:
            out = str((Path(output_dir) / f"{base_spec.name}-seed{seed}").resolve())
        runs.append(RunSpec(path, tuple(over), seed, stream, truth_mode, align, bound_m,
                            sim_id, out, truth))
    load_pipeline(path, list(runs[0].overrides))   # the scenario exists, the seed is valid
    scen = scenario
    if scen is None and sim_id is not None:
        scen = str(base_spec.by_id(sim_id).params.scenario)
    return EvaluationPlan(pipeline=str(pipeline), name=base_spec.name, scenario=scen,
                          seeds=seed_list, runs=runs)


def run_one(run: RunSpec) -> RunEvaluation:
    """Run and measure one seed: a pure function of ``run`` (safe on any worker)."""
    from ..runner import run_pipeline
    spec = load_pipeline(run.pipeline, list(run.overrides))
    t0, c0 = time.monotonic(), time.process_time()
    with tempfile.TemporaryDirectory(prefix="firenav-eval-") as tmp:
        out = Path(run.output_dir) if run.output_dir else Path(tmp)
        out.mkdir(parents=True, exist_ok=True)
        result = run_pipeline(spec, output_dir=out)
    if run.truth_file is not None:
        result.truth = load_truth_file(run.truth_file)
    measured = _measure(result, run.seed, run.stream, run.truth_mode, run.align, run.bound_m,
                        run.sim_id, time.monotonic() - t0)
    measured.cpu_s = time.process_time() - c0
    return measured


def load_truth_file(path: str | Path) -> dict[str, Track]:
    """The ground truth of a recording, per agent: its reader's ``truth`` messages (the
    dataset files, Constrained-ZUPT-FGO's measData, a simulator recording ...)."""
    from ..formats.base import ReadOptions
    from ..sources.readers import ReaderError, find_reader
    from ..tracks import TrackStore
    store = TrackStore()
    try:
        for port, msg in find_reader(path)(Path(path), ReadOptions()):
            if port == "truth":
                store("truth", msg)
    except (ReaderError, OSError) as exc:
        raise EvaluationError(f"truth file {path}: {exc}") from None
    return store.truth()


def assemble(plan: EvaluationPlan, runs: list[RunEvaluation],
             failed: list[FailedRun] = ()) -> Evaluation:
    """The :class:`Evaluation` of a plan from its measured runs (in seed order)."""
    if not runs:
        first = failed[0] if failed else None
        raise EvaluationError(f"{plan.name}: every run failed" + (
            f"; seed {first.seed}: {first.error}" if first else ""))
    how = plan.runs[0]
    errs = [e for r in runs for e in r.errors.values()]
    agents = sorted({a for r in runs for a in r.errors})
    per_agent = {a: pooled_metrics([r.errors[a] for r in runs if a in r.errors], how.bound_m)
                 for a in agents}
    return Evaluation(pipeline=plan.pipeline, scenario=plan.scenario, seeds=plan.seeds,
                      stream=how.stream, truth_mode=runs[0].truth_mode, align=how.align,
                      bound_m=how.bound_m, runs=runs,
                      overall=pooled_metrics(errs, how.bound_m), per_agent=per_agent,
                      failed=list(failed))


def run_plans(plans: list[EvaluationPlan], *, executor: Executor | None = None,
              progress: Progress | Callable[[str], None] | None = None) -> list[Evaluation]:
    """Run every plan's runs on one executor (all submitted at once) and assemble them.

    Without an executor: the one ``FIRENAV_WORKERS``/``FIRENAV_SCHEDULER`` ask for, else
    serial in this process. A run that fails twice is listed in ``Evaluation.failed``
    with its seed and error; the others are kept.
    """
    executor = executor or executor_from_environment() or SerialExecutor()
    if progress is None:
        progress = Progress()
    elif not isinstance(progress, Progress):
        progress = LineProgress(progress)
    tasks = [Task(key=f"{i}/{j}", label=f"{plan.name} seed {r.seed}" if r.seed is not None
                  else plan.name, fn=run_one, args=(r,))
             for i, plan in enumerate(plans) for j, r in enumerate(plan.runs)]
    outcomes = {}
    progress.start(len(tasks), "evaluate")
    try:
        for outcome in executor.run(tasks, progress):
            outcomes[outcome.task.key] = outcome
    finally:
        progress.close()
    evaluations = []
    for i, plan in enumerate(plans):
        got = [outcomes[f"{i}/{j}"] for j in range(len(plan.runs))]
        evaluations.append(assemble(
            plan, [o.value for o in got if o.ok],
            [FailedRun(r.seed, o.error, o.attempts, o.detail)
             for r, o in zip(plan.runs, got) if not o.ok]))
    return evaluations


def evaluate(pipeline: str | Path, *, scenario: str | None = None,
             seeds: int | list[int] = 1, stream: str | None = None,
             overrides: list[str] = (), truth_mode: str = "auto", align: str = "none",
             bound_m: float = CONVERGE_BOUND_M, output_dir: Path | None = None,
             executor: Executor | None = None,
             progress: Progress | Callable[[str], None] | None = None) -> Evaluation:
    """Run ``pipeline`` for each seed and measure it (see the module docstring)."""
    plan = plan_evaluation(pipeline, scenario=scenario, seeds=seeds, stream=stream,
                           overrides=overrides, truth_mode=truth_mode, align=align,
                           bound_m=bound_m, output_dir=output_dir)
    return run_plans([plan], executor=executor, progress=progress)[0]


def _pose_streams(spec: PipelineSpec) -> list[str]:
    from ..messages import PoseEstimate
    return sorted(s for s, t in spec.streams().items() if issubclass(t, PoseEstimate))


def _measure(result, seed, stream: str, truth_mode: str, align: str, bound_m: float,
             sim_id: str | None, wall_s: float) -> RunEvaluation:
    tracks = result.tracks.get(stream, {})
    truth = result.truth
    sim = result.components.get(sim_id) if sim_id else None
    errors: dict[str, TrackErrors] = {}
    missing: list[str] = []
    outside = 0
    mode_used = truth_mode
    levels = (np.array([f.z for f in result.building.floors])
              if result.building is not None else None)
    for agent, tr in tracks.items():
        tt = truth.get(agent)
        if tt is None or len(tt) == 0:
            missing.append(agent)
            continue
        mode = truth_mode
        if mode == "auto":
            mode = "sparse" if is_sparse(tt) else "dense"
        mode_used = mode
        if mode == "dense" and align != "none":
            mode = mode_used = "sparse"     # an aligned dense truth: its samples as checkpoints
        if mode == "dense":
            errors[agent] = track_errors(tr, tt, levels)
        elif mode == "sparse":
            errors[agent], n_out = checkpoint_errors(tr, Checkpoints.from_track(tt), align=align)
            outside += n_out
        else:
            sim_result = getattr(sim, "result", None)
            if sim_result is None or agent not in sim_result.truth:
                raise EvaluationError("truth mode 'checkpoints' needs a simulator source "
                                      "whose scenario marks checkpoints")
            marks = sim_result.truth[agent].checkpoints
            if not marks:
                missing.append(agent)
                continue
            cps = Checkpoints(agent, np.array([c.t for c in marks]),
                              np.array([c.position for c in marks]),
                              np.asarray(sim_result.building.floor_of_z(
                                  np.array([c.position[2] for c in marks]))),
                              [c.name for c in marks])
            dense = sim_result.truth[agent]
            errors[agent], n_out = checkpoint_errors(tr, cps, align=align,
                                                     distance_m=dense.distance_m)
            outside += n_out
    if not tracks:
        raise EvaluationError(f"the run produced no poses on '{stream}'")
    metrics = {a: metrics_of(e, bound_m) for a, e in errors.items()}
    return RunEvaluation(seed=seed, stream=stream, metrics=metrics, errors=errors,
                         tracks=dict(tracks), truth=dict(truth), truth_mode=mode_used,
                         outside_checkpoints=outside, building=result.building,
                         wall_s=wall_s, missing_truth=missing,
                         figures=run_figures(errors.values(), bound_m))
