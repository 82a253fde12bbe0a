"""Ground truth and metrics: one module used by tests, benchmarks and the CLI alike.

* :mod:`.metrics`: error series and the reported figures (RMSE ... convergence time);
* :mod:`.checkpoints`: sparse truth (surveyed checkpoints) with stated alignment;
* :mod:`.runs`: a pipeline over several seeds, and a baseline on the same seeds;
* :mod:`.report`: the Markdown page with plots.
"""
from .checkpoints import Checkpoints, checkpoint_errors, fit_rigid_2d
from .metrics import (CONVERGE_BOUND_M, KEYS, ErrorStats, TrackErrors, TrackMetrics,
                      error_stats, horizontal_errors, metrics_of, pooled_metrics, track_errors)
from .runs import Evaluation, EvaluationError, RunEvaluation, evaluate, write_json

__all__ = ["ErrorStats", "horizontal_errors", "error_stats", "TrackErrors", "TrackMetrics",
           "track_errors", "metrics_of", "pooled_metrics", "KEYS", "CONVERGE_BOUND_M",
           "Checkpoints", "checkpoint_errors", "fit_rigid_2d", "Evaluation", "RunEvaluation",
           "EvaluationError", "evaluate", "write_json"]
