"""Ground truth and metrics: one module used by tests, benchmarks and the CLI alike.

* :mod:`.metrics`: error series and the reported figures (RMSE ... convergence time);
* :mod:`.checkpoints`: sparse truth (surveyed checkpoints) with stated alignment;
* :mod:`.runs`: a pipeline over several seeds, and a baseline on the same seeds, on any
  executor (serial, local Dask workers, a cluster: :mod:`firenav_framework.scaleout`);
* :mod:`.seeds`: the held-out protocol's named seed sets (tuning, report, fresh-report);
* :mod:`.spread`: min / median / max and the 95 % interval of a figure over runs;
* :mod:`.report`: the Markdown page with plots;
* :mod:`.sweep`: a parameter grid or random search, chosen on tuning seeds and checked
  on report seeds.
"""
from .checkpoints import Checkpoints, checkpoint_errors, fit_rigid_2d
from .metrics import (CONVERGE_BOUND_M, KEYS, ErrorStats, TrackErrors, TrackMetrics,
                      error_stats, horizontal_errors, metrics_of, pooled_metrics, track_errors)
from .runs import (Evaluation, EvaluationError, EvaluationPlan, FailedRun, RunEvaluation,
                   RunSpec, evaluate, plan_evaluation, run_one, run_plans, write_json)
from .seeds import SEED_SETS, SeedError, parse_seeds
from .spread import Spread, spread, spreads

__all__ = ["ErrorStats", "horizontal_errors", "error_stats", "TrackErrors", "TrackMetrics",
           "track_errors", "metrics_of", "pooled_metrics", "KEYS", "CONVERGE_BOUND_M",
           "Checkpoints", "checkpoint_errors", "fit_rigid_2d", "Evaluation", "RunEvaluation",
           "EvaluationError", "EvaluationPlan", "FailedRun", "RunSpec", "evaluate",
           "plan_evaluation", "run_one", "run_plans", "write_json", "SEED_SETS", "SeedError",
           "parse_seeds", "Spread", "spread", "spreads"]
