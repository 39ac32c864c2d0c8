"""Where batch work runs: one executor interface (`base.Executor`), local implementations
(`SerialExecutor` in this process, `ProcessExecutor` over worker processes) and a Ray backend
(`ray_executor.RayExecutor`, a cluster or a local Ray instance; Ray is imported only when it is
used). `make_executor(jobs, backend, address)` picks one by name (the CLI's ``--backend``).
Every job carries its data (a map's JSON content, seeds, weights), never a local path, so any
backend can run it anywhere.
"""

from planner_core.execution.base import SINGLE_THREAD_ENV, Executor
from planner_core.execution.local import (
    BACKENDS,
    ProcessExecutor,
    SerialExecutor,
    executor_problem,
    make_executor,
)

__all__ = ["BACKENDS", "Executor", "ProcessExecutor", "SINGLE_THREAD_ENV", "SerialExecutor",
           "executor_problem", "make_executor"]
