"""Ground truth and metrics: one module used by tests, benchmarks and the CLI alike."""
from .metrics import ErrorStats, horizontal_errors, error_stats

__all__ = ["ErrorStats", "horizontal_errors", "error_stats"]
