"""Landscape probes (paper Sec. 4.3): Latin Hypercube samples of a problem's unit box.

A probe of a box problem (``lower``, ``upper``, ``evaluate(X) -> (f, phi)``) is N_probe points
``U`` in the unit box (LHS, ``scipy.stats.qmc.LatinHypercube``), mapped to the problem's box,
evaluated once: ``z_f = Psi(U, f(U))`` and ``z_phi = Psi(U, phi(U))`` (paper notation) are then
computed from it by a feature extractor. Probes live in the unit box so that a UAV task (box in
metres and seconds) and a BBOB instance (box [-5, 5]) are described on the same scale.
"""

from __future__ import annotations

from contextlib import AbstractContextManager
from typing import Any, NamedTuple

import numpy as np
from scipy.stats import qmc

__all__ = ["MAX_N_PROBE", "N_PROBE", "Probe", "blas_single_thread", "finite_values", "lhs", "probe"]

#: the paper's probe size
N_PROBE = 100
#: the largest probe size `lam build` / `lam select` take: the learned encoder's attention
#: across samples holds d x N x N numbers, so memory grows with N squared (measured, d = 200:
#: peak RSS ~0.2 GB at N = 100, ~0.46 GB at N = 300, ~1 GB at N = 500)
MAX_N_PROBE = 300


class Probe(NamedTuple):
    """Unit-box samples U (n, d) and the problem's f (n,) and phi (n,) there."""

    U: np.ndarray
    f: np.ndarray
    phi: np.ndarray

    @property
    def feasible_fraction(self) -> float:
        """Share of probe points with phi <= 0.

        Returns:
            The share, in [0, 1].
        """
        return float(np.mean(self.phi <= 0.0))


def blas_single_thread() -> AbstractContextManager[Any]:
    """Limit BLAS/LAPACK to one thread inside the block (``threadpoolctl``).

    Features work on 100 x 100 matrices: measured here, a multi-threaded LAPACK solve of that
    size takes ~0.13 s on a busy 2-core machine (threads spin against each other) and ~1 ms on
    one thread. Batch work runs one probe per core instead.

    Returns:
        The context manager (``threadpool_limits(limits=1)``).
    """
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1)


def lhs(n: int, d: int, seed: int | np.random.SeedSequence | np.random.Generator) -> np.ndarray:
    """n Latin Hypercube points in [0, 1)^d (``scipy.stats.qmc.LatinHypercube``); same seed ->
    same points.

    Args:
        n: points, >= 2.
        d: dimension, >= 1.
        seed: a seed, SeedSequence or Generator (used as it is).

    Returns:
        (n, d) points.

    Raises:
        ValueError: n < 2 or d < 1.
    """
    if n < 2:
        raise ValueError(f"n_probe: {n} < 2")
    if d < 1:
        raise ValueError(f"dimension: {d} < 1")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    try:
        sampler = qmc.LatinHypercube(d=d, rng=rng)
    except TypeError:  # scipy < 1.15 names the generator `seed`
        sampler = qmc.LatinHypercube(d=d, seed=rng)
    return sampler.random(n)


def finite_values(y: np.ndarray) -> np.ndarray:
    """Replace NaN / +-inf by the largest / smallest finite value (0 if none is finite).

    UAV evaluations can return +inf for undecodable solutions; features need finite numbers.

    Args:
        y: values, any shape.

    Returns:
        A finite float copy of y (NaN and +inf -> the largest finite value, -inf -> the
        smallest; all zeros when none is finite).
    """
    y = np.asarray(y, dtype=float).copy()
    ok = np.isfinite(y)
    if ok.all():
        return y
    if not ok.any():
        return np.zeros_like(y)
    hi, lo = y[ok].max(), y[ok].min()
    y[np.isnan(y) | (y == np.inf)] = hi
    y[y == -np.inf] = lo
    return y


def probe(problem: Any, n: int = N_PROBE, seed: Any = 0) -> Probe:
    """LHS-probe a box problem: U (n, d) in the unit box, evaluated at lower + U (upper - lower).

    Args:
        problem: a box problem (``lower``, ``upper`` (d,), ``evaluate(X) -> (f, phi)``).
        n: probe points, >= 2.
        seed: anything ``numpy.random.default_rng`` accepts.

    Returns:
        The `Probe`; non-finite f / phi are replaced by :func:`finite_values`.

    Raises:
        ValueError: n < 2 or a zero-dimensional box.
    """
    lower = np.asarray(problem.lower, dtype=float)
    upper = np.asarray(problem.upper, dtype=float)
    U = lhs(n, lower.size, seed)
    f, phi = problem.evaluate(lower + U * (upper - lower))
    return Probe(U, finite_values(f), finite_values(phi))
