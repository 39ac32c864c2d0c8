"""Where batch work runs: one executor interface (`base.Executor`) and local implementations
(`SerialExecutor` in this process, `ProcessExecutor` over worker processes). The benchmark runs
its jobs through it; a distributed backend (Ray, Dask, ...) plugs in by implementing the same
two methods, since every job carries its data (a map's JSON content), not a local path.
"""

from planner_core.execution.base import SINGLE_THREAD_ENV, Executor
from planner_core.execution.local import ProcessExecutor, SerialExecutor, make_executor

__all__ = ["Executor", "ProcessExecutor", "SINGLE_THREAD_ENV", "SerialExecutor", "make_executor"]
