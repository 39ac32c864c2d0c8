"""The executor interface: what batch work (benchmark runs; later training rollouts) needs from
whatever runs it, so a local pool today and a cluster later (Ray, Dask) are interchangeable.

Contract for an implementation and its callers:

- ``map_unordered(fn, items)`` runs ``fn(item)`` for every item and yields each result as soon
  as it is done, in any order (results stream back; a caller writes each one at once, which is
  what makes the benchmark's JSON lines resumable). It may keep only a bounded number of items
  in flight, so a long item list is never materialised all at once.
- ``fn`` is a top-level (importable) function and items and results are picklable values that
  are complete in themselves: a job carries the data it needs (a map's JSON content, a seed, a
  budget), never a path or handle that only this machine can open.
- ``close()`` releases the workers; executors are also context managers.
- Workers run numeric code one thread each (``SINGLE_THREAD_ENV``): one process per core.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from typing import Protocol, TypeVar

__all__ = ["Executor", "SINGLE_THREAD_ENV"]

T = TypeVar("T")
R = TypeVar("R")

#: set in worker processes: one process per core, so numeric libraries must not spawn threads
#: of their own (a 40 x 40 eigh took 30 ms instead of 0.6 ms with OpenBLAS threads on 2 busy cores)
SINGLE_THREAD_ENV = {
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "NUMBA_NUM_THREADS": "1",
}


class Executor(Protocol):
    """Runs fn over items; results come back as they finish (order not guaranteed)."""

    def map_unordered(self, fn: Callable[[T], R], items: Iterable[T]) -> Iterator[R]:
        """Run `fn(item)` for every item, yielding each result as soon as it is done.

        Args:
            fn: a top-level (importable) function of one item.
            items: picklable, self-contained job values; may be a long or lazy iterable (an
                implementation may keep only a bounded number in flight).

        Yields:
            fn's results, in any order.
        """
        ...

    def close(self) -> None: ...
