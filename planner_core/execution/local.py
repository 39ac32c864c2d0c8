"""Local executors: in this process (`SerialExecutor`) or over a pool of worker processes
(`ProcessExecutor`, `concurrent.futures` with spawned, single-threaded workers), and
`make_executor`, which picks a backend by name (``local`` here, ``ray`` in `ray_executor`).
"""

from __future__ import annotations

import multiprocessing
import numbers
import os
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import Any, TypeVar

from planner_core.defaults import MAX_JOBS
from planner_core.execution.base import SINGLE_THREAD_ENV
from planner_core.execution.ray_executor import ray_missing

__all__ = ["BACKENDS", "SerialExecutor", "ProcessExecutor", "executor_problem", "make_executor"]

#: executor backends by name (`make_executor`, the CLI's --backend)
BACKENDS = ("local", "ray")

T = TypeVar("T")
R = TypeVar("R")


class SerialExecutor:
    """Runs every item in this process, in order."""

    def map_unordered(self, fn: Callable[[T], R], items: Iterable[T]) -> Iterator[R]:
        """Run `fn(item)` for every item here, in order.

        Args:
            fn: a function of one item.
            items: the items, consumed lazily.

        Yields:
            fn's results, in the items' order.

        Raises:
            Exception: whatever fn raises, at once (the items after it are not run).
        """
        for item in items:
            yield fn(item)

    def close(self) -> None:
        """Nothing to release.

        Returns:
            None.
        """
        return None

    def __enter__(self) -> SerialExecutor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


#: seconds between a worker's checks that the process that started it is alive
PARENT_POLL_S = 1.0


def _exit_with_parent(parent: int, poll: float = PARENT_POLL_S) -> None:
    """Watch, from a daemon thread, that the worker's parent is still `parent`, and end the
    worker (`os._exit`) once it is not: a parent killed outright (SIGKILL, an OOM kill, a
    closed terminal) cannot shut its pool down, and its workers would run on as orphans
    until their current item ends, or forever if they wait on it. POSIX re-parents an
    orphan, so `os.getppid()` changes; on Windows the pool's own broken-pipe handling stays."""
    import threading
    import time

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(poll)
        os._exit(1)

    if os.name == "posix":
        threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


def _quit_quietly(signum: int, frame: object) -> None:
    """A pool worker's SIGINT handler: end at once and say nothing. A Ctrl-C at the terminal
    reaches every process of the group; the process that started the pool says it was
    interrupted, once (`lamde-mission: interrupted` was printed by each worker too, through
    the console script's start-up handler its spawned main module installs). Ending, not
    ignoring it: the pool's shutdown waits for the items still running, so a worker that
    ignored the Ctrl-C would hold its parent until its item (a whole benchmark run) ends.

    Args:
        signum: the signal (SIGINT).
        frame: the interrupted frame (unused).
    """
    os._exit(128 + signum)


def _init_worker(env: dict[str, str], parent: int | None = None) -> None:
    """Pool initializer: the thread limits in the worker's environment (for anything loaded or
    started from now on), numba's thread count capped if numba is already loaded, the worker
    set to end with its parent (`_exit_with_parent`), and to end quietly on a Ctrl-C
    (`_quit_quietly`; a SIGINT its parent ignored, as a background job's, stays ignored)."""
    import signal
    import sys

    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        signal.signal(signal.SIGINT, _quit_quietly)
    os.environ.update(env)
    numba = sys.modules.get("numba")
    if numba is not None and "NUMBA_NUM_THREADS" in env:
        numba.set_num_threads(min(int(env["NUMBA_NUM_THREADS"]), numba.config.NUMBA_NUM_THREADS))
    if parent is not None:
        _exit_with_parent(parent)


class ProcessExecutor:
    """A `ProcessPoolExecutor` (spawned workers with single-threaded numerics), at most
    2 * jobs items in flight so a long item list is never submitted all at once. Its workers
    end within `PARENT_POLL_S` of their parent's death, however it died."""

    def __init__(self, jobs: int):
        if jobs < 1:
            raise ValueError(f"jobs must be >= 1, got {jobs}")
        self.jobs = int(jobs)
        self._pool: ProcessPoolExecutor | None = None

    def _ensure_pool(self) -> ProcessPoolExecutor:
        if self._pool is None:
            # the limits must be in the environment when a child starts, not only in the
            # initializer: a spawned child re-imports the parent's main module (which may load
            # numpy and its BLAS, which read their limits once) before the initializer runs.
            # So: set them around the spawn, and again in the initializer.
            saved = {k: os.environ.get(k) for k in SINGLE_THREAD_ENV}
            os.environ.update(SINGLE_THREAD_ENV)
            try:
                ctx = multiprocessing.get_context("spawn")
                self._pool = ProcessPoolExecutor(max_workers=self.jobs, mp_context=ctx,
                                                 initializer=_init_worker,
                                                 initargs=(dict(SINGLE_THREAD_ENV),
                                                           os.getpid()))
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
        """Run `fn(item)` for every item on the worker pool (started on first use), at most 2 * jobs
        items in flight; items still pending when the generator is closed are cancelled.

        Args:
            fn: a top-level (importable, picklable) function of one item.
            items: picklable items, consumed lazily.

        Yields:
            fn's results, as they finish (any order).

        Raises:
            Exception: whatever fn raised in a worker (re-raised here by `Future.result`).
        """
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


def executor_problem(jobs: int, backend: str = "local", address: str | None = None) -> str | None:
    """What `make_executor` refuses in these arguments, checked without building anything (a
    caller refuses them before it writes a file).

    Args:
        jobs: as `make_executor`'s.
        backend: as `make_executor`'s.
        address: as `make_executor`'s.

    Returns:
        The first problem as one line naming the argument ("backend must be one of local,
        ray, got 'dask'"; "backend ray: Ray is not installed; pip install ..." where Ray
        cannot be found, looked up without importing it), or None.
    """
    if backend not in BACKENDS:
        return f"backend must be one of {', '.join(BACKENDS)}, got {backend!r}"
    if isinstance(jobs, bool) or not isinstance(jobs, numbers.Integral) or jobs < 0:
        return f"jobs must be >= 0 (an integer), got {jobs!r}"
    if jobs > MAX_JOBS:
        return f"jobs must be at most {MAX_JOBS} (worker processes), got {jobs!r}"
    if backend == "local" and address is not None:
        return "an address is only for the ray backend"
    if backend == "ray":
        missing = ray_missing()
        if missing is not None:
            return f"backend ray: {missing}"
    return None


def make_executor(jobs: int, backend: str = "local", address: str | None = None) -> Any:
    """An executor by backend name.

    ``local``: jobs == 0 runs in this process, jobs >= 1 on that many worker processes;
    ``address`` must be None. ``ray``: a `ray_executor.RayExecutor` connected to ``address``
    (None / "auto" / "ray://HOST:PORT"); without an address it starts a local Ray instance with
    ``jobs`` CPUs (all of them if jobs == 0). Ray is imported only when the executor first runs.

    Args:
        jobs: worker processes (local; 0 = this process) or CPUs of a local Ray instance
            (0 = all); 0 to `planner_core.defaults.MAX_JOBS`.
        backend: one of `BACKENDS`, "local" or "ray".
        address: the Ray cluster's address (None / "auto" / "ray://HOST:PORT"); None for local.

    Returns:
        A `SerialExecutor`, `ProcessExecutor` or `ray_executor.RayExecutor`.

    Raises:
        ValueError: an unknown backend, ``jobs`` negative or above ``MAX_JOBS``, an address
            with ``local`` or the ray backend without Ray installed (`executor_problem`'s
            line).
    """
    problem = executor_problem(jobs, backend, address)
    if problem is not None:
        raise ValueError(problem)
    if backend == "ray":
        from planner_core.execution.ray_executor import RayExecutor

        return RayExecutor(address, num_cpus=jobs or None)
    return SerialExecutor() if jobs == 0 else ProcessExecutor(jobs)
