"""Classical Exploratory Landscape Analysis (ELA): a documented subset in numpy / scipy.

Input: unit-box samples ``U`` (n, d) and values ``y`` (n,). ``y`` is min-max scaled to [0, 1]
first (a constant y becomes all zeros), so every feature is invariant to ``y -> a y + b`` with
``a > 0``. Output: :data:`ELA_NAMES` (17 values, float64); an undefined value (e.g. the
nearest-better features when y is constant) is 0.

=========================  ==================================================================
feature                    definition (after y scaling)
=========================  ==================================================================
ydist.skewness             sample skewness of y (Mersmann et al. 2011, "y-Distribution")
ydist.kurtosis             excess kurtosis of y
ydist.peaks                local maxima of a Gaussian KDE of y on 256 grid points in [0, 1]
                           that reach 5 % of the density's maximum (flacco: number_of_peaks)
meta.lin_r2                leave-one-out R^2 of ridge y ~ 1 + x (closed form, below)
meta.quad_r2               leave-one-out R^2 of ridge y ~ 1 + x + x^2 (no interactions)
meta.lin_coef_ratio        log10(max |c| / min |c|) of the linear model's slopes
meta.quad_coef_ratio       log10(max |q| / min |q|) of the quadratic terms (flacco: quad cond)
disp.ratio_mean_10         mean pairwise distance of the best 10 % / of all (Lunacek &
disp.ratio_mean_25         Whitley 2006, "dispersion"); same for the best 25 %
ic.h_max                   max over eps of the entropy H(eps) (Munoz et al. 2015, information
ic.eps_s                   content); log10 of the smallest eps with H(eps) < 0.05 (settling)
ic.m0                      partial information M(0)
ic.eps_ratio               log10 of the smallest eps with M(eps) < 0.5 M(0)
nbc.nn_nb_sd_ratio         sd(nearest-neighbour distance) / sd(nearest-better distance)
nbc.nn_nb_mean_ratio       mean(nn) / mean(nb)  (Kerschke et al. 2015, nearest-better
nbc.nb_fitness_cor         corr(in-degree in the nearest-better graph, y)  clustering)
=========================  ==================================================================

Departures from flacco, each for a stated reason:

- Meta-models: the paper's probe has N = 100 points in d = 20..200 dimensions, so the ordinary
  least-squares fit of flacco (adjusted R^2) is undefined once d + 1 > N. We fit ridge models
  (penalty lambda = 1e-3 * mean diagonal of the Gram matrix) and report the closed-form
  leave-one-out R^2, ``1 - sum((e_i / (1 - H_ii))^2) / sum((y - mean y)^2)`` with
  ``H = K (K + lambda I)^-1``, ``K`` the Gram matrix of the centred design (clipped to [-1, 1]).
- Information content: the random walk is a nearest-neighbour tour starting at the first sample
  (flacco: "nn" sorting from a random start), eps on 0 and 10^[-5, 5] in 201 log-steps; slopes are
  ``dy / ||dx||`` in the unit box.

No published reference values for these exact settings (N = 100, unit box, scaled y) exist, so
the tests check properties with known answers instead: a linear function has meta.lin_r2 ~ 1,
a separable quadratic (BBOB f1) has meta.quad_r2 ~ 1 and a smaller dispersion than a
multimodal function, and so on (``tests/test_lam_features.py``).
"""

from __future__ import annotations

import numpy as np
from scipy import stats
from scipy.spatial.distance import cdist, pdist

__all__ = ["ELA_NAMES", "ELAExtractor", "ela_features", "scale_y"]

ELA_NAMES = (
    "ydist.skewness", "ydist.kurtosis", "ydist.peaks",
    "meta.lin_r2", "meta.quad_r2", "meta.lin_coef_ratio", "meta.quad_coef_ratio",
    "disp.ratio_mean_10", "disp.ratio_mean_25",
    "ic.h_max", "ic.eps_s", "ic.m0", "ic.eps_ratio",
    "nbc.nn_nb_sd_ratio", "nbc.nn_nb_mean_ratio", "nbc.nb_fitness_cor",
)  # fmt: skip

_EPS_GRID = np.concatenate([[0.0], 10.0 ** np.linspace(-5.0, 5.0, 201)])


def scale_y(y: np.ndarray) -> np.ndarray:
    """Min-max scale to [0, 1]; a constant (or empty-range) y becomes zeros.

    Args:
        y: values, any shape (not empty).

    Returns:
        y's shape, in [0, 1].
    """
    y = np.asarray(y, dtype=float)
    lo, hi = float(np.min(y)), float(np.max(y))
    if not hi > lo:
        return np.zeros_like(y)
    return (y - lo) / (hi - lo)


# ---------------------------------------------------------------- y-distribution
def _ydist(y: np.ndarray) -> list[float]:
    if np.ptp(y) == 0.0:
        return [0.0, 0.0, 1.0]
    skew = float(stats.skew(y))
    kurt = float(stats.kurtosis(y))
    try:
        dens = stats.gaussian_kde(y)(np.linspace(0.0, 1.0, 256))
    except (np.linalg.LinAlgError, ValueError):  # all mass on a few values
        return [skew, kurt, 1.0]
    inner = (dens[1:-1] > dens[:-2]) & (dens[1:-1] >= dens[2:])
    peaks = int(np.sum(inner & (dens[1:-1] >= 0.05 * dens.max())))
    peaks += int(dens[0] > dens[1]) + int(dens[-1] > dens[-2])
    return [skew, kurt, float(max(peaks, 1))]


# ---------------------------------------------------------------- meta-models
def _ridge_loo(Phi: np.ndarray, y: np.ndarray) -> tuple[float, np.ndarray]:
    """(leave-one-out R^2, coefficients) of ridge y ~ 1 + Phi (module doc)."""
    yc = y - y.mean()
    sst = float(yc @ yc)
    A = Phi - Phi.mean(axis=0)
    K = A @ A.T
    lam = 1e-3 * max(float(np.trace(K)) / len(y), 1e-12)
    n = len(y)
    Kinv = np.linalg.solve(K + lam * np.eye(n), np.eye(n))
    H = K @ Kinv
    alpha = Kinv @ yc
    coef = A.T @ alpha
    if sst == 0.0:
        return 0.0, coef
    e = yc - H @ yc
    loo = e / np.maximum(1.0 - np.diag(H), 1e-12)
    r2 = 1.0 - float(loo @ loo) / sst
    return float(np.clip(r2, -1.0, 1.0)), coef


def _log_ratio(c: np.ndarray) -> float:
    a = np.abs(c)
    if a.max() == 0.0:
        return 0.0
    return float(np.log10(a.max() / max(a.min(), 1e-12 * a.max())))


def _meta(U: np.ndarray, y: np.ndarray) -> list[float]:
    lin_r2, lin_c = _ridge_loo(U, y)
    d = U.shape[1]
    quad_r2, quad_c = _ridge_loo(np.hstack([U, U * U]), y)
    return [lin_r2, quad_r2, _log_ratio(lin_c), _log_ratio(quad_c[d:])]


# ---------------------------------------------------------------- dispersion
def _dispersion(U: np.ndarray, y: np.ndarray) -> list[float]:
    full = float(np.mean(pdist(U)))
    out = []
    order = np.argsort(y, kind="stable")
    for q in (0.10, 0.25):
        m = max(2, int(round(q * len(y))))
        out.append(float(np.mean(pdist(U[order[:m]]))) / full if full > 0 else 0.0)
    return out


# ---------------------------------------------------------------- information content
def _nn_tour(D: np.ndarray) -> np.ndarray:
    n = len(D)
    seen = np.zeros(n, dtype=bool)
    tour = np.empty(n, dtype=np.int64)
    cur = 0
    for k in range(n):
        tour[k] = cur
        seen[cur] = True
        if k + 1 < n:
            row = np.where(seen, np.inf, D[cur])
            cur = int(np.argmin(row))
    return tour


def _entropy_and_partial(slopes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """H(eps), M(eps) over the eps grid for a sequence of slopes (Munoz et al. 2015)."""
    E = _EPS_GRID[:, None]
    sym = np.where(slopes[None, :] > E, 1, np.where(slopes[None, :] < -E, -1, 0))  # (g, m)
    a, b = sym[:, :-1], sym[:, 1:]
    code = (a + 1) * 3 + (b + 1)  # 0..8
    npairs = code.shape[1]
    H = np.zeros(len(_EPS_GRID))
    for c in range(9):
        if c in (0, 4, 8):  # pairs of equal symbols do not count (p != q)
            continue
        p = np.sum(code == c, axis=1) / npairs
        with np.errstate(divide="ignore", invalid="ignore"):
            H -= np.where(p > 0, p * np.log(p) / np.log(6.0), 0.0)
    M = np.zeros(len(_EPS_GRID))
    n = sym.shape[1]
    for g in range(len(_EPS_GRID)):
        s = sym[g][sym[g] != 0]
        if s.size == 0:
            continue
        # the longest alternating subsequence of a sign sequence: 1 + number of sign changes
        M[g] = (1 + int(np.sum(s[1:] != s[:-1]))) / n if s.size else 0.0
        if s.size == 1:
            M[g] = 1.0 / n
    return H, M


def _information_content(U: np.ndarray, y: np.ndarray) -> list[float]:
    D = cdist(U, U)
    tour = _nn_tour(D)
    dx = D[tour[:-1], tour[1:]]
    dy = np.diff(y[tour])
    slopes = np.where(dx > 0, dy / np.where(dx > 0, dx, 1.0), 0.0)
    H, M = _entropy_and_partial(slopes)
    h_max = float(H.max())
    log_eps = np.log10(np.where(_EPS_GRID > 0, _EPS_GRID, 10.0**-5.5))
    below = np.flatnonzero(H < 0.05)
    eps_s = float(log_eps[below[0]]) if below.size else 5.0
    m0 = float(M[0])
    half = np.flatnonzero(M < 0.5 * m0) if m0 > 0 else np.array([0])
    eps_ratio = float(log_eps[half[0]]) if half.size else 5.0
    return [h_max, eps_s, m0, eps_ratio]


# ---------------------------------------------------------------- nearest-better clustering
def _nbc(U: np.ndarray, y: np.ndarray) -> list[float]:
    D = cdist(U, U)
    np.fill_diagonal(D, np.inf)
    nn = D.min(axis=1)
    better = y[None, :] < y[:, None]  # better[i, j]: j strictly better than i
    Db = np.where(better, D, np.inf)
    nb_idx = np.argmin(Db, axis=1)
    nb = Db[np.arange(len(y)), nb_idx]
    has = np.isfinite(nb)
    if has.sum() < 3:
        return [0.0, 0.0, 0.0]
    sd_nb = float(np.std(nb[has], ddof=1))
    sd_ratio = float(np.std(nn[has], ddof=1)) / sd_nb if sd_nb > 0 else 0.0
    mean_ratio = float(np.mean(nn[has]) / np.mean(nb[has]))
    indeg = np.bincount(nb_idx[has], minlength=len(y)).astype(float)
    flat = np.ptp(indeg) == 0.0 or np.ptp(y) == 0.0
    cor = 0.0 if flat else float(np.corrcoef(indeg, y)[0, 1])
    return [sd_ratio, mean_ratio, cor]


def ela_features(U: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The ELA subset of the module doc for one probe (`ELA_NAMES`, in that order); non-finite
    features are set to 0.

    Args:
        U: (n, d) unit-box probe points.
        y: (n,) values there (min-max scaled first, so the features are invariant to
            y -> a y + b, a > 0).

    Returns:
        (16,) float64.

    Raises:
        ValueError: the shapes disagree or n < 4.
    """
    U = np.asarray(U, dtype=float)
    y = np.asarray(y, dtype=float).reshape(-1)
    if U.ndim != 2 or U.shape[0] != y.size:
        raise ValueError(f"U {U.shape} and y {y.shape} disagree")
    if y.size < 4:
        raise ValueError(f"n_probe: {y.size} < 4")
    ys = scale_y(y)
    z = _ydist(ys) + _meta(U, ys) + _dispersion(U, ys) + _information_content(U, ys) + _nbc(U, ys)
    out = np.asarray(z, dtype=float)
    return np.where(np.isfinite(out), out, 0.0)


class ELAExtractor:
    """Classical ELA behind the extractor interface (``name``, ``dim``, ``identity``, call)."""

    name = "ela"
    dim = len(ELA_NAMES)
    #: bump when a definition changes: it is part of the database cache hash
    identity = "ela-subset-v1"
    #: standardise across the database before distances (features have unlike scales)
    standardise = True

    def __call__(self, U: np.ndarray, y: np.ndarray) -> np.ndarray:
        return ela_features(U, y)
