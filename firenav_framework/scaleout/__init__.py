"""Running many independent runs on one executor: serial, a local Dask cluster, a cluster.

* :mod:`.executor`: :class:`Task` -> :class:`Outcome` on a :class:`SerialExecutor` or a
  :class:`DaskExecutor` (``--workers N`` / ``--scheduler ADDRESS``), each failed task
  retried once, results in completion order;
* :mod:`.progress`: the done / running / failed display with an ETA;
* :mod:`.journal`: results appended as they arrive, so an interrupted job resumes.

`firenav evaluate`, `firenav sweep` and `firenav replay` use these; docs/scale-out.md
says how to run them on a laptop, a workstation or a cluster.
"""
from .executor import (DaskExecutor, Executor, ExecutorError, Outcome, SerialExecutor, Task,
                       TaskError, make_executor)
from .journal import Journal
from .progress import LineProgress, Progress

__all__ = ["Task", "Outcome", "Executor", "SerialExecutor", "DaskExecutor", "make_executor",
           "ExecutorError", "TaskError", "Journal", "Progress", "LineProgress"]
