"""The benchmark: runner (resumable JSON lines), executor interface, limits (LB, best-known),
statistics and the markdown report. See `lamde-mission bench` and `lamde-mission report`."""

from planner_core.bench.executor import Executor, ProcessExecutor, SerialExecutor, make_executor
from planner_core.bench.runner import BenchError, BenchSummary, Job, execute, plan_jobs, run_bench

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
