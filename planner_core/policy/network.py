"""The meta-level policy network in numpy (inference only; no torch on the planning path).

Architecture (paper Sec. 4.2; the shape follows RLDE-AFL's attention-based feature extractor,
written from its description, not its code). For one problem with population N and dimension d:

1. Tokens, shape (N, d, 5): for individual i and dimension j the features
   ``[x_ij, omega_f_i, eps_f_i, omega_phi_i, eps_phi_i]`` (normalised coordinate and the
   individual's mantissa-exponent pairs of f and phi, :func:`planner_core.env.mantissa_exponent`),
   embedded linearly to E.
2. Population attention: within each dimension j, multi-head self-attention across the N
   individuals (post-norm transformer block: attention + residual + LayerNorm, feed-forward
   + residual + LayerNorm).
3. Dimension attention: within each individual i, the same kind of block across its d dimensions
   (padded dimensions are masked out as keys when problems of several sizes share a batch).
4. Mean over dimensions -> (N, E); concatenated with the progress g/G and passed through one
   hidden layer (ReLU) -> h, one vector of size H per individual.
5. Actor heads on h: mutation logits (7, the paper's operators), crossover logits (2), and
   ``(alpha, beta) = 1 + softplus(.)`` of a Beta distribution for F and for Cr (both > 1, so the
   Beta is unimodal with mode ``(alpha - 1) / (alpha + beta - 2)`` and its log-probability is
   exact on (0, 1); no clamping of a Normal).
6. Critic: mean of h over the population -> ReLU layer -> scalar value.

Nothing depends on N or d: the same weights serve 40-, 80- and 400-dimensional maps and any
population. The parameter names and shapes are listed by :func:`param_shapes`; the torch twin
in :mod:`planner_core.policy.ppo` uses the same names, so a checkpoint is a flat name -> array
mapping (see :mod:`planner_core.policy.checkpoint`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, NamedTuple

import numpy as np

from planner_core.de.operators import N_CROSSOVERS, N_MUTATIONS

#: per-token input features: x, omega_f, eps_f, omega_phi, eps_phi
N_FEATURES = 5
_LN_EPS = 1e-5


@dataclass(frozen=True)
class NetConfig:
    """Sizes of the policy network (stored with every checkpoint as JSON)."""

    embed: int = 16
    """E: token embedding width (RLDE-AFL uses 64; 16 keeps inference cheap on 2 cores)."""
    heads: int = 1
    """attention heads per block (E must be divisible by it)."""
    ff: int = 32
    """hidden width of each block's feed-forward layer."""
    hidden: int = 32
    """H: width of the per-individual vector after the progress is joined."""

    def __post_init__(self) -> None:
        for name in ("embed", "heads", "ff", "hidden"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name}: must be a positive integer")
        if self.embed % self.heads:
            raise ValueError(f"embed ({self.embed}) must be divisible by heads ({self.heads})")

    def to_dict(self) -> dict[str, int]:
        return asdict(self)


def _block_shapes(prefix: str, E: int, ff: int) -> dict[str, tuple[int, ...]]:
    return {
        f"{prefix}.qkv.weight": (E, 3 * E),
        f"{prefix}.qkv.bias": (3 * E,),
        f"{prefix}.out.weight": (E, E),
        f"{prefix}.out.bias": (E,),
        f"{prefix}.ln1.weight": (E,),
        f"{prefix}.ln1.bias": (E,),
        f"{prefix}.ff1.weight": (E, ff),
        f"{prefix}.ff1.bias": (ff,),
        f"{prefix}.ff2.weight": (ff, E),
        f"{prefix}.ff2.bias": (E,),
        f"{prefix}.ln2.weight": (E,),
        f"{prefix}.ln2.bias": (E,),
    }


def param_shapes(cfg: NetConfig) -> dict[str, tuple[int, ...]]:
    """Every parameter's name and shape (weights are stored (in, out): ``y = x @ W + b``)."""
    E, H = cfg.embed, cfg.hidden
    shapes: dict[str, tuple[int, ...]] = {
        "embed.weight": (N_FEATURES, E),
        "embed.bias": (E,),
    }
    shapes.update(_block_shapes("pop", E, cfg.ff))
    shapes.update(_block_shapes("dim", E, cfg.ff))
    shapes.update({
        "join.weight": (E + 1, H),
        "join.bias": (H,),
        "mutation.weight": (H, N_MUTATIONS),
        "mutation.bias": (N_MUTATIONS,),
        "crossover.weight": (H, N_CROSSOVERS),
        "crossover.bias": (N_CROSSOVERS,),
        "F.weight": (H, 2),
        "F.bias": (2,),
        "Cr.weight": (H, 2),
        "Cr.bias": (2,),
        "critic1.weight": (H, H),
        "critic1.bias": (H,),
        "critic2.weight": (H, 1),
        "critic2.bias": (1,),
    })
    return shapes


def param_count(cfg: NetConfig) -> int:
    """Number of scalar parameters."""
    return int(sum(np.prod(s) for s in param_shapes(cfg).values()))


def init_params(cfg: NetConfig, seed: int = 0) -> dict[str, np.ndarray]:
    """Fresh weights (float32): uniform +-1/sqrt(fan_in) like torch.nn.Linear, LayerNorm 1/0.

    The mutation and crossover heads start at zero weight (uniform operator choice) and the
    Beta heads at zero (alpha = beta = 1 + softplus(0) ~ 1.69: broad, centred on 0.5).
    """
    rng = np.random.default_rng(seed)
    out: dict[str, np.ndarray] = {}
    for name, shape in param_shapes(cfg).items():
        if name.split(".")[-2].startswith("ln"):
            val = np.ones(shape) if name.endswith("weight") else np.zeros(shape)
        elif name.split(".")[0] in ("mutation", "crossover", "F", "Cr"):
            val = np.zeros(shape)
        else:
            fan_in = shape[0] if name.endswith("weight") else param_shapes(cfg)[
                name.replace("bias", "weight")][0]
            bound = 1.0 / np.sqrt(fan_in)
            val = rng.uniform(-bound, bound, size=shape)
        out[name] = val.astype(np.float32)
    return out


class PolicyOutput(NamedTuple):
    """Distribution parameters per individual (N = population)."""

    mutation_logits: np.ndarray  # (N, 7)
    crossover_logits: np.ndarray  # (N, 2)
    F_ab: np.ndarray  # (N, 2) Beta (alpha, beta) of F, both > 1
    Cr_ab: np.ndarray  # (N, 2) Beta (alpha, beta) of Cr, both > 1
    value: float  # critic's estimate of the return from this state


def tokens(X: np.ndarray, f_enc: np.ndarray, phi_enc: np.ndarray) -> np.ndarray:
    """Token features (N, d, 5) from the env's observation parts X (N, d), f (N, 2), phi (N, 2)."""
    n, d = X.shape
    out = np.empty((n, d, N_FEATURES), dtype=np.float64)
    out[:, :, 0] = X
    out[:, :, 1:3] = f_enc[:, None, :]
    out[:, :, 3:5] = phi_enc[:, None, :]
    return out


def _layer_norm(x: np.ndarray, g: np.ndarray, b: np.ndarray) -> np.ndarray:
    mu = x.mean(axis=-1, keepdims=True)
    var = ((x - mu) ** 2).mean(axis=-1, keepdims=True)
    return (x - mu) / np.sqrt(var + _LN_EPS) * g + b


def _softmax(z: np.ndarray) -> np.ndarray:
    """Softmax over the last axis, in place on ``z`` (a temporary of the caller)."""
    z -= z.max(axis=-1, keepdims=True)
    np.exp(z, out=z)
    z /= z.sum(axis=-1, keepdims=True)
    return z


def _softplus(z: np.ndarray) -> np.ndarray:
    return np.logaddexp(0.0, z)


def _block(x: np.ndarray, p: dict[str, np.ndarray], prefix: str, heads: int) -> np.ndarray:
    """Post-norm transformer block over the second-last axis of x (..., L, E)."""
    *lead, L, E = x.shape
    dh = E // heads
    qkv = x @ p[f"{prefix}.qkv.weight"] + p[f"{prefix}.qkv.bias"]
    qkv = qkv.reshape(*lead, L, 3, heads, dh)
    # (..., heads, L, dh), contiguous so that the batched matmuls run on BLAS-friendly blocks
    q = np.ascontiguousarray(np.moveaxis(qkv[..., 0, :, :], -2, -3))
    q *= 1.0 / np.sqrt(dh)
    k = np.ascontiguousarray(np.moveaxis(qkv[..., 1, :, :], -3, -1))  # (..., heads, dh, L)
    v = np.ascontiguousarray(np.moveaxis(qkv[..., 2, :, :], -2, -3))
    att = _softmax(q @ k)
    y = np.moveaxis(att @ v, -3, -2).reshape(*lead, L, E)
    y = y @ p[f"{prefix}.out.weight"] + p[f"{prefix}.out.bias"]
    x = _layer_norm(x + y, p[f"{prefix}.ln1.weight"], p[f"{prefix}.ln1.bias"])
    h = np.maximum(x @ p[f"{prefix}.ff1.weight"] + p[f"{prefix}.ff1.bias"], 0.0)
    y = h @ p[f"{prefix}.ff2.weight"] + p[f"{prefix}.ff2.bias"]
    return _layer_norm(x + y, p[f"{prefix}.ln2.weight"], p[f"{prefix}.ln2.bias"])


def forward(
    params: dict[str, np.ndarray],
    cfg: NetConfig,
    obs: dict[str, np.ndarray],
    dtype: Any = np.float32,
) -> PolicyOutput:
    """The policy on one observation (:func:`planner_core.env.observe`): X (N, d), f (N, 2),
    phi (N, 2), progress (1,). ``dtype``: the arithmetic precision (float32 by default, as
    the weights and the torch twin; the outputs are returned as float64).

    Raises ValueError when the observation's shapes disagree.
    """
    X = np.asarray(obs["X"])
    if X.ndim != 2 or obs["f"].shape != (X.shape[0], 2) or obs["phi"].shape != (X.shape[0], 2):
        raise ValueError("observation: X must be (N, d) and f, phi (N, 2)")
    p = {k: np.asarray(v, dtype=dtype) for k, v in params.items()}
    t = tokens(X, np.asarray(obs["f"]), np.asarray(obs["phi"])).astype(dtype)
    x = t @ p["embed.weight"] + p["embed.bias"]  # (N, d, E)
    x = np.swapaxes(x, 0, 1)  # (d, N, E): attention across the population within a dimension
    x = _block(x, p, "pop", cfg.heads)
    x = np.swapaxes(x, 0, 1)  # (N, d, E): attention across dimensions within an individual
    x = _block(x, p, "dim", cfg.heads)
    pooled = x.mean(axis=1)  # (N, E)
    g = np.full((pooled.shape[0], 1), float(np.asarray(obs["progress"]).reshape(-1)[0]), dtype)
    h = np.maximum(np.concatenate([pooled, g], axis=1) @ p["join.weight"] + p["join.bias"], 0.0)
    mut = h @ p["mutation.weight"] + p["mutation.bias"]
    cx = h @ p["crossover.weight"] + p["crossover.bias"]
    F_ab = 1.0 + _softplus(h @ p["F.weight"] + p["F.bias"])
    Cr_ab = 1.0 + _softplus(h @ p["Cr.weight"] + p["Cr.bias"])
    c = np.maximum(h.mean(axis=0) @ p["critic1.weight"] + p["critic1.bias"], 0.0)
    value = float((c @ p["critic2.weight"] + p["critic2.bias"])[0])
    f64 = np.float64
    return PolicyOutput(mut.astype(f64), cx.astype(f64), F_ab.astype(f64), Cr_ab.astype(f64),
                        value)


#: F and Cr actions are kept in [RATE_EPS, 1 - RATE_EPS] so that their float32 log-probability
#: under the Beta is finite; the value kept is the value the DE uses
RATE_EPS = 1e-6


def _categorical(logits: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Inverse-CDF draw per row from softmax(logits) with uniforms u (N,)."""
    cdf = np.cumsum(_softmax(np.array(logits, dtype=float)), axis=1)
    idx = (u[:, None] * cdf[:, -1:] >= cdf).sum(axis=1)
    return np.minimum(idx, logits.shape[1] - 1).astype(np.intp)


def sample_actions(
    out: PolicyOutput, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One draw per individual: (mutation (N,), crossover (N,), F (N,), Cr (N,)).

    Draw order from ``rng`` (fixed, so a seeded generator gives the same actions): N uniforms
    for the mutation, N for the crossover, then ``rng.beta`` for F (N) and Cr (N). Rates are
    kept in [RATE_EPS, 1 - RATE_EPS].
    """
    n = out.mutation_logits.shape[0]
    mut = _categorical(out.mutation_logits, rng.random(n))
    cx = _categorical(out.crossover_logits, rng.random(n))
    F = rng.beta(out.F_ab[:, 0], out.F_ab[:, 1])
    Cr = rng.beta(out.Cr_ab[:, 0], out.Cr_ab[:, 1])
    return mut, cx, np.clip(F, RATE_EPS, 1 - RATE_EPS), np.clip(Cr, RATE_EPS, 1 - RATE_EPS)


def mode_actions(out: PolicyOutput) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The most likely action per individual: argmax operators, Beta modes for F and Cr."""
    def beta_mode(ab: np.ndarray) -> np.ndarray:
        return (ab[:, 0] - 1.0) / (ab[:, 0] + ab[:, 1] - 2.0)

    return (
        np.argmax(out.mutation_logits, axis=1).astype(np.intp),
        np.argmax(out.crossover_logits, axis=1).astype(np.intp),
        np.clip(beta_mode(out.F_ab), RATE_EPS, 1 - RATE_EPS),
        np.clip(beta_mode(out.Cr_ab), RATE_EPS, 1 - RATE_EPS),
    )


def log_prob(
    out: PolicyOutput, mutation: np.ndarray, crossover: np.ndarray, F: np.ndarray, Cr: np.ndarray
) -> np.ndarray:
    """Exact log-probability (N,) of each individual's action (sum of its four parts)."""
    from scipy.stats import beta as beta_dist

    def log_softmax(z: np.ndarray) -> np.ndarray:
        z = z - z.max(axis=1, keepdims=True)
        return z - np.log(np.exp(z).sum(axis=1, keepdims=True))

    n = len(mutation)
    lp = log_softmax(out.mutation_logits)[np.arange(n), mutation]
    lp = lp + log_softmax(out.crossover_logits)[np.arange(n), crossover]
    lp = lp + beta_dist.logpdf(F, out.F_ab[:, 0], out.F_ab[:, 1])
    return lp + beta_dist.logpdf(Cr, out.Cr_ab[:, 0], out.Cr_ab[:, 1])
