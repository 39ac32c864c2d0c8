"""The benchmark: runner (resumable JSON lines), limits (LB, best-known), statistics and the
markdown report. See `lamde-mission bench` and `lamde-mission report`. Jobs run through
`planner_core.execution` (re-exported here for existing callers)."""

from planner_core.bench.runner import BenchError, BenchSummary, Job, execute, plan_jobs, run_bench
from planner_core.execution import Executor, ProcessExecutor, SerialExecutor, make_executor

__all__ = [
    "BenchError",
    "BenchSummary",
    "Executor",
    "Job",
    "ProcessExecutor",
    "SerialExecutor",
    "execute",
    "make_executor",
    "plan_jobs",
    "run_bench",
]
