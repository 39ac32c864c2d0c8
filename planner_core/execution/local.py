"""Local executors: in this process (`SerialExecutor`) or over a pool of worker processes
(`ProcessExecutor`, `concurrent.futures` with spawned, single-threaded workers).
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import Any, TypeVar

from planner_core.execution.base import SINGLE_THREAD_ENV

__all__ = ["SerialExecutor", "ProcessExecutor", "make_executor"]

T = TypeVar("T")
R = TypeVar("R")


class SerialExecutor:
    """Runs every item in this process, in order."""

    def map_unordered(self, fn: Callable[[T], R], items: Iterable[T]) -> Iterator[R]:
        for item in items:
            yield fn(item)

    def close(self) -> None:
        return None

    def __enter__(self) -> SerialExecutor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class ProcessExecutor:
    """A `ProcessPoolExecutor` (spawned workers with single-threaded numerics), at most
    2 * jobs items in flight so a long item list is never submitted all at once."""

    def __init__(self, jobs: int):
        if jobs < 1:
            raise ValueError(f"jobs must be >= 1, got {jobs}")
        self.jobs = int(jobs)
        self._pool: ProcessPoolExecutor | None = None

    def _ensure_pool(self) -> ProcessPoolExecutor:
        if self._pool is None:
            # spawned children inherit os.environ at start: set the thread limits only around it
            saved = {k: os.environ.get(k) for k in SINGLE_THREAD_ENV}
            os.environ.update(SINGLE_THREAD_ENV)
            try:
                ctx = multiprocessing.get_context("spawn")
                self._pool = ProcessPoolExecutor(max_workers=self.jobs, mp_context=ctx)
                # spawn every worker now, while the environment holds the limits
                for f in [self._pool.submit(os.getpid) for _ in range(self.jobs)]:
                    f.result()
            finally:
                for k, v in saved.items():
                    if v is None:
                        os.environ.pop(k, None)
                    else:
                        os.environ[k] = v
        return self._pool

    def map_unordered(self, fn: Callable[[T], R], items: Iterable[T]) -> Iterator[R]:
        pool = self._ensure_pool()
        it = iter(items)
        pending: set[Future[Any]] = set()
        try:
            while True:
                while len(pending) < 2 * self.jobs:
                    try:
                        item = next(it)
                    except StopIteration:
                        break
                    pending.add(pool.submit(fn, item))
                if not pending:
                    return
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    yield fut.result()
        finally:
            for fut in pending:
                fut.cancel()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def __enter__(self) -> ProcessExecutor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def make_executor(jobs: int) -> SerialExecutor | ProcessExecutor:
    """jobs == 0: in this process; jobs >= 1: that many worker processes."""
    return SerialExecutor() if jobs == 0 else ProcessExecutor(jobs)
