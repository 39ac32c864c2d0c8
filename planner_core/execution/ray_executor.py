"""The Ray backend of the executor interface (`base.Executor`): batch work on a Ray cluster, or
on a Ray instance started on this machine.

Ray is an optional dependency (the ``ray`` extra: ``pip install -e '.[ray]'``) and is imported
only when a `RayExecutor` first runs something, never when the planner is imported.

- ``address=None``: connect to the cluster named by ``RAY_ADDRESS`` if set, else start a local
  Ray instance with ``num_cpus`` CPUs (all of this machine's if None).
- ``address="auto"``: the cluster already started on this machine (``ray start --head``).
- ``address="ray://HOST:PORT"``: a remote cluster through the Ray Client.

If Ray is already initialised in this process (a test, a notebook), the executor uses that
instance and leaves it running on `close`; otherwise it initialises Ray itself and shuts it down
on `close`.

Every task runs in a worker whose environment holds `SINGLE_THREAD_ENV` (BLAS, OpenMP, MKL and
numba thread limits), set through Ray's runtime environment (``runtime_env={"env_vars": ...}``),
so a node runs one single-threaded job per CPU. Jobs are pickled with their data (a map's JSON
content, seeds, policy weights as numpy arrays): nothing refers to a file on this machine. The
cluster's nodes must have this package installed at the same version (``pip install
'lamde-mission[ray]'``), since a job's function is shipped by reference (module and name).

Source: Ray Core API (``ray.init``, ``ray.remote``, ``ray.wait``, runtime environments), Ray 2.x.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Iterator
from typing import Any, TypeVar

from planner_core.execution.base import SINGLE_THREAD_ENV

__all__ = ["RayExecutor", "RayUnavailable", "import_ray", "ray_missing"]

T = TypeVar("T")
R = TypeVar("R")

#: what to install when Ray is missing (named in the error)
INSTALL_HINT = "pip install 'lamde-mission[ray]' (or pip install -e '.[ray]' in a checkout)"


class RayUnavailable(RuntimeError):
    """The Ray backend was asked for but Ray is not installed (message says how to install)."""


def ray_missing() -> str | None:
    """Why the Ray backend cannot run here, found without importing Ray
    (`importlib.util.find_spec`): "Ray is not installed; pip install ...", or None.

    Returns:
        The line, or None where Ray is installed.
    """
    import importlib.util

    if importlib.util.find_spec("ray") is None:
        return f"Ray is not installed; {INSTALL_HINT}"
    return None


def import_ray() -> Any:
    """Import and return the `ray` module.

    Returns:
        The `ray` module.

    Raises:
        RayUnavailable: Ray is not installed (the message says how to install it).
    """
    try:
        import ray
    except ImportError as exc:
        raise RayUnavailable(f"the ray backend needs Ray, which is not installed ({exc}); "
                             f"{INSTALL_HINT}") from None
    return ray


def _runtime_env() -> dict[str, Any]:
    return {"env_vars": dict(SINGLE_THREAD_ENV)}


class RayExecutor:
    """Runs ``fn(item)`` as Ray tasks (one CPU each) and yields results as they finish.

    ``address``: None, "auto" or "ray://HOST:PORT" (see the module docstring).
    ``num_cpus``: CPUs of a Ray instance this executor starts locally (None = all); ignored
    when connecting to a cluster.
    ``max_in_flight``: tasks submitted but not yet returned (default 2 x the cluster's CPUs),
    so a long item list is never submitted all at once.
    Raises `RayUnavailable` (on first use) if Ray is not installed; ``ValueError`` for a bad
    ``num_cpus`` or ``max_in_flight``.
    """

    def __init__(self, address: str | None = None, *, num_cpus: int | None = None,
                 max_in_flight: int | None = None):
        if num_cpus is not None and num_cpus < 1:
            raise ValueError(f"num_cpus must be >= 1, got {num_cpus}")
        if max_in_flight is not None and max_in_flight < 1:
            raise ValueError(f"max_in_flight must be >= 1, got {max_in_flight}")
        self.address = address
        self.num_cpus = num_cpus
        self.max_in_flight = max_in_flight
        self._ray: Any = None
        self._owns_runtime = False

    def _init_kwargs(self) -> dict[str, Any]:
        """Arguments of ``ray.init``: the thread limits as the job's runtime environment; the
        CPU count and no dashboard only for an instance started here (a cluster, reached by
        ``address`` or ``RAY_ADDRESS``, takes neither; the Ray Client forwards every
        non-default argument to the cluster's own ``ray.init``)."""
        kwargs: dict[str, Any] = {"runtime_env": _runtime_env()}
        if self.address is not None:
            kwargs["address"] = self.address
        elif not os.environ.get("RAY_ADDRESS"):
            kwargs["include_dashboard"] = False
            if self.num_cpus is not None:
                kwargs["num_cpus"] = self.num_cpus
        return kwargs

    def _ensure_ray(self) -> Any:
        if self._ray is None:
            ray = import_ray()
            if not ray.is_initialized():
                ray.init(**self._init_kwargs())
                self._owns_runtime = True
            self._ray = ray
        return self._ray

    def cluster_cpus(self) -> int:
        """CPUs the connected Ray cluster offers (starts or connects to Ray if needed).

        Returns:
            The cluster's "CPU" resource, at least 1 (1 when it reports none).

        Raises:
            RayUnavailable: Ray is not installed.
        """
        ray = self._ensure_ray()
        return max(1, int(ray.cluster_resources().get("CPU", 1)))

    def map_unordered(self, fn: Callable[[T], R], items: Iterable[T]) -> Iterator[R]:
        """Run `fn(item)` as Ray tasks (one CPU each, no retries, `SINGLE_THREAD_ENV` in their
        runtime environment); tasks still pending when the generator is closed are cancelled.

        Args:
            fn: a top-level (importable) function of one item, shipped to the workers.
            items: picklable, self-contained items, consumed lazily; at most ``max_in_flight``
                (default 2 x `cluster_cpus`) submitted and not yet returned.

        Yields:
            fn's results, as they finish (any order).

        Raises:
            RayUnavailable: Ray is not installed.
            Exception: whatever fn raised in its task, as `ray.get` re-raises it.
        """
        ray = self._ensure_ray()
        # the thread limits are set per task too, so they hold on a runtime someone else started
        task = ray.remote(fn).options(num_cpus=1, runtime_env=_runtime_env(), max_retries=0)
        limit = self.max_in_flight or 2 * self.cluster_cpus()
        it = iter(items)
        pending: list[Any] = []
        try:
            while True:
                while len(pending) < limit:
                    try:
                        item = next(it)
                    except StopIteration:
                        break
                    pending.append(task.remote(item))
                if not pending:
                    return
                done, pending = ray.wait(pending, num_returns=1)
                for ref in done:
                    yield ray.get(ref)
        finally:
            for ref in pending:
                ray.cancel(ref)

    def close(self) -> None:
        if self._ray is not None and self._owns_runtime:
            self._ray.shutdown()
        self._ray = None
        self._owns_runtime = False

    def __enter__(self) -> RayExecutor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
