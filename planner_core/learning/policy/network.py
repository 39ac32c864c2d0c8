"""The meta-level policy network in numpy (inference only; no torch on the planning path).

Architecture (paper Sec. 4.2; the shape follows RLDE-AFL's attention-based feature extractor,
written from its description, not its code; the attention blocks are the Set Transformer's
induced set attention, Lee et al. 2019, so the cost grows linearly in N and d). For one problem
with population N and dimension d:

1. Tokens, shape (N, d, 5): for individual i and dimension j the features
   ``[x_ij, omega_f_i, eps_f_i, omega_phi_i, eps_phi_i]`` (normalised coordinate and the
   individual's mantissa-exponent pairs of f and phi,
   :func:`planner_core.learning.env.mantissa_exponent`),
   embedded linearly to E.
2. Population attention: within each dimension j, an induced set attention block (ISAB) across
   the N individuals: ``m`` learned inducing points attend to the N tokens (``H = MAB(I, X)``),
   then every token attends to those m summaries (``MAB(X, H)``). MAB(A, B) is a post-norm
   transformer block: ``A' = LN(A + MultiHead(A, B, B))``, ``LN(A' + FF(A'))``. Attention
   entries: d * 2 m N instead of d N^2.
3. Dimension attention: within each individual i, the same kind of block across its d dimensions
   (padded dimensions are masked out as keys when problems of several sizes share a batch).
4. Mean over dimensions -> (N, E); concatenated with the progress g/G (and, when
   ``NetConfig.context`` is set, the run's context vector of
   :func:`planner_core.learning.env.context`, the same for every individual) and passed
   through one hidden layer (ReLU) -> h, one vector of size H per individual.
5. Actor heads on h: mutation logits (7, the paper's operators), crossover logits (2), and
   ``(alpha, beta) = 1 + softplus(.)`` of a Beta distribution for F and for Cr (both > 1, so the
   Beta is unimodal with mode ``(alpha - 1) / (alpha + beta - 2)`` and its log-probability is
   exact on (0, 1); no clamping of a Normal).
6. Critic: mean of h over the population -> ReLU layer -> scalar value.

Nothing depends on N or d: the same weights serve 40-, 80- and 400-dimensional maps and any
population. The parameter names and shapes are listed by :func:`param_shapes`; the torch twin
in :mod:`planner_core.learning.policy.ppo` uses the same names, so a checkpoint is a flat name ->
array
mapping (see :mod:`planner_core.learning.policy.checkpoint`).

Cost: float32 throughout, every linear map one BLAS matmul over all N * d tokens (the query,
key and value projections fused), no Python loop over individuals or dimensions; at N 100 x d 80
a forward pass needs about 0.3 M attention entries (full attention would need 1.4 M).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, NamedTuple

import numpy as np

from planner_core.learning.env import N_CONTEXT
from planner_core.search.de.operators import N_CROSSOVERS, N_MUTATIONS

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
    inducing: int = 8
    """m: inducing points of each induced set attention block (population and dimensions)."""
    context: int = 0
    """Context features joined with the progress: 0 (none; every checkpoint before issue 34,
    e.g. ``lamde-v1``/``lamde-v2``, whose config.json has no such field) or
    :data:`planner_core.learning.env.N_CONTEXT` (the observation's ``"context"``)."""

    def __post_init__(self) -> None:
        for name in ("embed", "heads", "ff", "hidden", "inducing"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name}: must be a positive integer")
        if self.context not in (0, N_CONTEXT):
            raise ValueError(f"context: must be 0 or {N_CONTEXT} (the env's context length), "
                             f"got {self.context}")
        if self.embed % self.heads:
            raise ValueError(f"embed ({self.embed}) must be divisible by heads ({self.heads})")

    def to_dict(self) -> dict[str, int]:
        """The sizes as stored in a checkpoint's config.json.

        Returns:
            {"embed", "heads", "ff", "hidden", "inducing", "context"}: ints.
        """
        return asdict(self)


def _mab_shapes(prefix: str, E: int, ff: int) -> dict[str, tuple[int, ...]]:
    """Parameters of one MAB(A, B): query from A, fused key-value from B, output, two LayerNorms
    and the feed-forward layer."""
    return {
        f"{prefix}.q.weight": (E, E),
        f"{prefix}.q.bias": (E,),
        f"{prefix}.kv.weight": (E, 2 * E),
        f"{prefix}.kv.bias": (2 * E,),
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


def _isab_shapes(prefix: str, cfg: NetConfig) -> dict[str, tuple[int, ...]]:
    """ISAB ``prefix``: inducing points, MAB(I, X) under ``prefix.ind``, MAB(X, H) under
    ``prefix.out``."""
    shapes: dict[str, tuple[int, ...]] = {f"{prefix}.inducing": (cfg.inducing, cfg.embed)}
    shapes.update(_mab_shapes(f"{prefix}.ind", cfg.embed, cfg.ff))
    shapes.update(_mab_shapes(f"{prefix}.set", cfg.embed, cfg.ff))
    return shapes


def param_shapes(cfg: NetConfig) -> dict[str, tuple[int, ...]]:
    """Every parameter's name and shape (weights are stored (in, out): ``y = x @ W + b``).

    Args:
        cfg: the network's sizes.

    Returns:
        {name: shape}, in a fixed order.
    """
    E, H = cfg.embed, cfg.hidden
    shapes: dict[str, tuple[int, ...]] = {
        "embed.weight": (N_FEATURES, E),
        "embed.bias": (E,),
    }
    shapes.update(_isab_shapes("pop", cfg))
    shapes.update(_isab_shapes("dim", cfg))
    shapes.update({
        "join.weight": (E + 1 + cfg.context, H),
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
    """Number of scalar parameters.

    Args:
        cfg: the network's sizes.

    Returns:
        The sum of the sizes of :func:`param_shapes`.
    """
    return int(sum(np.prod(s) for s in param_shapes(cfg).values()))


def init_params(cfg: NetConfig, seed: int = 0) -> dict[str, np.ndarray]:
    """Fresh weights (float32): uniform +-1/sqrt(fan_in) like torch.nn.Linear (the inducing
    points +-1/sqrt(E)), LayerNorm 1/0.

    The mutation and crossover heads start at zero weight (uniform operator choice) and the
    Beta heads at zero (alpha = beta = 1 + softplus(0) ~ 1.69: broad, centred on 0.5).

    Args:
        cfg: the network's sizes.
        seed: seed of ``numpy.random.default_rng``.

    Returns:
        {name: float32 array} of :func:`param_shapes`.
    """
    rng = np.random.default_rng(seed)
    shapes = param_shapes(cfg)
    out: dict[str, np.ndarray] = {}
    for name, shape in shapes.items():
        parts = name.split(".")
        if parts[-2].startswith("ln"):
            val = np.ones(shape) if parts[-1] == "weight" else np.zeros(shape)
        elif parts[0] in ("mutation", "crossover", "F", "Cr"):
            val = np.zeros(shape)
        else:
            if parts[-1] == "inducing":
                fan_in = shape[1]
            else:
                fan_in = shapes[".".join(parts[:-1] + ["weight"])][0]
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
    """Token features from the env's observation parts (the readable statement; :func:`forward`
    embeds them without building this array).

    Args:
        X: (N, d) population in the unit box.
        f_enc: (N, 2) mantissa-exponent pairs of f.
        phi_enc: (N, 2) mantissa-exponent pairs of phi.

    Returns:
        (N, d, 5) float64: ``[x_ij, omega_f_i, eps_f_i, omega_phi_i, eps_phi_i]``.
    """
    n, d = X.shape
    out = np.empty((n, d, N_FEATURES), dtype=np.float64)
    out[:, :, 0] = X
    out[:, :, 1:3] = f_enc[:, None, :]
    out[:, :, 3:5] = phi_enc[:, None, :]
    return out


def _layer_norm(x: np.ndarray, g: np.ndarray, b: np.ndarray) -> np.ndarray:
    """LayerNorm over the features of a feature-major array x (E, ...) (each column one
    token); ``x`` is a temporary of the caller and is overwritten.

    Feature-major because numpy's reductions and broadcasts along a short last axis (E = 16)
    cost ten times more than along a long one; the means are BLAS matrix-vector products.
    """
    E = x.shape[0]
    x2 = x.reshape(E, -1)
    avg = np.full((1, E), 1.0 / E, dtype=x.dtype)
    x2 -= avg @ x2
    var = avg @ np.square(x2)
    var += _LN_EPS
    x2 /= np.sqrt(var, out=var)
    x2 *= g[:, None]
    x2 += b[:, None]
    return x


def _softmax(z: np.ndarray, axis: int = -1) -> np.ndarray:
    """Softmax along ``axis``, in place on ``z`` (a temporary of the caller)."""
    z -= z.max(axis=axis, keepdims=True)
    np.exp(z, out=z)
    z /= z.sum(axis=axis, keepdims=True)
    return z


def _softplus(z: np.ndarray) -> np.ndarray:
    return np.logaddexp(0.0, z)


def _linear(x: np.ndarray, p: dict[str, np.ndarray], prefix: str) -> np.ndarray:
    """Token-major linear map: x (..., in) -> (..., out)."""
    y = x @ p[f"{prefix}.weight"]
    y += p[f"{prefix}.bias"]
    return y


def _linear_fm(x: np.ndarray, p: dict[str, np.ndarray], prefix: str) -> np.ndarray:
    """Feature-major linear map: x (in, T) -> (out, T), one BLAS matmul ``W^T x + b``."""
    y = p[f"{prefix}.weight"].T @ x
    y += p[f"{prefix}.bias"][:, None]
    return y


def _finish(y: np.ndarray, p: dict[str, np.ndarray], prefix: str) -> np.ndarray:
    """The rest of a MAB, feature-major: y (E, ...) = the residual sum ``A + attention``;
    ``x = LN(y)``, then ``LN(x + FF(x))``. ``y`` is overwritten."""
    E = y.shape[0]
    x = _layer_norm(y, p[f"{prefix}.ln1.weight"], p[f"{prefix}.ln1.bias"])
    h = _linear_fm(x.reshape(E, -1), p, f"{prefix}.ff1")
    np.maximum(h, 0.0, out=h)
    out = _linear_fm(h, p, f"{prefix}.ff2").reshape(x.shape)
    out += x
    return _layer_norm(out, p[f"{prefix}.ln2.weight"], p[f"{prefix}.ln2.bias"])


def _heads(w: np.ndarray, heads: int) -> np.ndarray:
    """Split the output columns of a weight (in, E) by head: (heads, in, dh); a bias (E,):
    (heads, dh)."""
    if w.ndim == 1:
        return w.reshape(heads, -1)
    return w.reshape(w.shape[0], heads, -1).transpose(1, 0, 2)


def _isab(x: np.ndarray, p: dict[str, np.ndarray], prefix: str, heads: int) -> np.ndarray:
    """Induced set attention block MAB(X, MAB(I, X)) over the last axis of the feature-major
    tokens x (E, B, L): B independent sets of L tokens each. Returns (E, B, L).

    Each MAB is the textbook block (scores ``(A Wq + bq)(B Wk + bk)^T / sqrt(dh)`` per head,
    output ``softmax(.) (B Wv + bv) Wo + bo``, post-norm), evaluated in an order that never
    projects the B * L tokens through a query, key or value matrix:

    * MAB(I, X), the m inducing points attending to the L tokens: scores
      ``(q_h Wk_h^T) x + q_h . bk_h``; as each softmax row sums to one, the output is
      ``(softmax(.) x) Wv_h + bv_h``.
    * MAB(X, H), the tokens attending to the m summaries H: scores ``(k_h Wq_h^T) x + k_h .
      bq_h`` (softmax over the m keys), output ``sum_h softmax(.)^T (v_h Wo_h) + bo``.
    """
    E, B, L = x.shape
    dh = E // heads
    scale = float(1.0 / np.sqrt(dh))  # a Python float keeps float32 arrays float32
    inducing = p[f"{prefix}.inducing"]  # (m, E)
    m = inducing.shape[0]
    # ---- MAB(I, X) -> H (E, B, m)
    pre = f"{prefix}.ind"
    q = (_linear(inducing, p, f"{pre}.q") * scale).reshape(m, heads, dh).transpose(1, 0, 2)
    wkv, bkv = p[f"{pre}.kv.weight"], p[f"{pre}.kv.bias"]
    qk = q @ _heads(wkv[:, :E], heads).transpose(0, 2, 1)  # (h, m, E)
    qb = np.einsum("hmd,hd->hm", q, _heads(bkv[:E], heads))
    s = (qk.reshape(heads * m, E) @ x.reshape(E, B * L)).reshape(heads, m, B, L)
    s += qb[:, :, None, None]
    att = _softmax(s, axis=-1)  # over the L tokens
    ax = att.transpose(2, 0, 1, 3) @ x.transpose(1, 2, 0)[:, None]  # (B, h, m, E)
    y = ax @ _heads(wkv[:, E:], heads)  # (B, h, m, dh)
    y += _heads(bkv[E:], heads)[:, None, :]
    y = y.transpose(0, 2, 1, 3).reshape(B * m, E) @ p[f"{pre}.out.weight"]  # (B m, E)
    y = np.ascontiguousarray(y.T).reshape(E, B, m)
    y += (inducing + p[f"{pre}.out.bias"]).T[:, None, :]
    hs = _finish(y, p, pre)  # (E, B, m)
    # ---- MAB(X, H) -> (E, B, L)
    pre = f"{prefix}.set"
    kv = hs.transpose(1, 2, 0) @ p[f"{pre}.kv.weight"]  # (B, m, 2E)
    kv += p[f"{pre}.kv.bias"]
    k = kv[..., :E].reshape(B, m, heads, dh).transpose(0, 2, 1, 3) * scale  # (B, h, m, dh)
    v = kv[..., E:].reshape(B, m, heads, dh).transpose(0, 2, 1, 3)
    wq = _heads(p[f"{pre}.q.weight"], heads)  # (h, E, dh)
    kq = k @ wq.transpose(0, 2, 1)  # (B, h, m, E)
    kb = k @ _heads(p[f"{pre}.q.bias"], heads)[:, :, None]  # (B, h, m, 1)
    s = kq @ x.transpose(1, 0, 2)[:, None]  # (B, h, m, L)
    s += kb
    att = _softmax(s, axis=-2)  # over the m summaries
    vo = v @ p[f"{pre}.out.weight"].reshape(heads, dh, E)  # (B, h, m, E)
    yt = vo.transpose(0, 1, 3, 2) @ att  # (B, h, E, L)
    yt = yt[:, 0] if heads == 1 else yt.sum(axis=1)
    y = np.ascontiguousarray(yt.transpose(1, 0, 2))  # (E, B, L)
    y += p[f"{pre}.out.bias"][:, None, None]
    y += x
    return _finish(y, p, pre)


_BLAS: list[Any] = []


def _keep_freed_memory() -> None:
    """Ask glibc's malloc to keep freed memory for reuse instead of returning it to the kernel
    (``mallopt``: trim threshold 256 MB, mmap threshold 32 MB, glibc's own upper bound for its
    dynamic threshold); a no-op where the C library has no ``mallopt``.

    Why: a forward pass makes a few dozen temporaries of 0.5-1 MB; with glibc's defaults the
    heap is trimmed after each pass, so every pass page-faults its temporaries in again, and
    measured on this (virtualised, shared) machine that doubled its cost (13 -> 5 ms at N 100 x
    d 80). The process keeps at most the 256 MB it already used.
    """
    try:
        import ctypes

        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return
    mallopt(-1, 256 << 20)  # M_TRIM_THRESHOLD
    mallopt(-3, 32 << 20)  # M_MMAP_THRESHOLD


def _one_blas_thread() -> Any:
    """A context limiting BLAS to one thread (threadpoolctl; the controller is built once, and
    then :func:`_keep_freed_memory` is applied once).

    Measured on the shared 2-core machine: the multi-threaded OpenBLAS spins its threads
    against each other on these small matrices (a forward pass at N 100 x d 80 took 60-90 ms
    with its default threads and a few ms with one).
    """
    if not _BLAS:
        from threadpoolctl import ThreadpoolController

        _keep_freed_memory()
        _BLAS.append(ThreadpoolController())
    return _BLAS[0].limit(limits=1, user_api="blas")


def _as_dtype(params: dict[str, np.ndarray], dtype: Any) -> dict[str, np.ndarray]:
    return {k: v if v.dtype == dtype else np.asarray(v, dtype=dtype) for k, v in params.items()}


def forward(
    params: dict[str, np.ndarray],
    cfg: NetConfig,
    obs: dict[str, np.ndarray],
    dtype: Any = np.float32,
) -> PolicyOutput:
    """The policy on one observation (:func:`planner_core.learning.env.observe`). BLAS runs on
    one thread inside (threadpoolctl).

    Args:
        params: the network's parameters (:func:`param_shapes`).
        cfg: the network's sizes.
        obs: X (N, d), f (N, 2), phi (N, 2), progress (1,), and context (K,) when
            ``cfg.context`` is K > 0.
        dtype: the arithmetic precision (float32 by default, as the weights and the torch
            twin).

    Returns:
        The :class:`PolicyOutput`, returned as float64: logits (N, 7) and (N, 2), Beta
        (alpha, beta) (N, 2) of F and Cr, the critic's value.

    Raises:
        ValueError: the observation's shapes disagree.
    """
    X = np.asarray(obs["X"])
    if X.ndim != 2 or obs["f"].shape != (X.shape[0], 2) or obs["phi"].shape != (X.shape[0], 2):
        raise ValueError("observation: X must be (N, d) and f, phi (N, 2)")
    if cfg.context and np.shape(obs.get("context")) != (cfg.context,):
        raise ValueError(f"observation: context must have shape ({cfg.context},), got "
                         f"{np.shape(obs.get('context'))}")
    with _one_blas_thread():
        return _forward(_as_dtype(params, np.dtype(dtype)), cfg, X, obs, dtype)


def _forward(p: dict[str, np.ndarray], cfg: NetConfig, X: np.ndarray, obs: dict[str, Any],
             dtype: Any) -> PolicyOutput:
    W = p["embed.weight"]
    # token embedding [x, f, phi] @ W + b without the (N, d, 5) array, feature-major (E, d, N)
    # so that the population attention runs within each dimension: the coordinate's part
    # varies per token, the f and phi part per individual
    fphi = np.concatenate([obs["f"], obs["phi"]], axis=1).astype(dtype)  # (N, 4)
    per_ind = W[1:].T @ fphi.T  # (E, N)
    per_ind += p["embed.bias"][:, None]
    x = W[0][:, None, None] * X.T.astype(dtype)[None]  # (E, d, N)
    x += per_ind[:, None, :]
    x = _isab(x, p, "pop", cfg.heads)  # across the population, within each dimension
    x = np.ascontiguousarray(x.transpose(0, 2, 1))  # (E, N, d)
    x = _isab(x, p, "dim", cfg.heads)  # across dimensions, within each individual
    pooled = x.mean(axis=2).T  # (N, E)
    g = np.full((pooled.shape[0], 1), float(np.asarray(obs["progress"]).reshape(-1)[0]), dtype)
    parts = [pooled, g]
    if cfg.context:
        ctx = np.asarray(obs["context"], dtype=dtype)
        parts.append(np.broadcast_to(ctx, (pooled.shape[0], cfg.context)))
    h = _linear(np.concatenate(parts, axis=1), p, "join")
    np.maximum(h, 0.0, out=h)
    mut = _linear(h, p, "mutation")
    cx = _linear(h, p, "crossover")
    F_ab = 1.0 + _softplus(_linear(h, p, "F"))
    Cr_ab = 1.0 + _softplus(_linear(h, p, "Cr"))
    c = np.maximum(_linear(h.mean(axis=0), p, "critic1"), 0.0)
    value = float(_linear(c, p, "critic2")[0])
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
    """One draw per individual.

    Draw order from ``rng`` (fixed, so a seeded generator gives the same actions): N uniforms
    for the mutation, N for the crossover, then ``rng.beta`` for F (N) and Cr (N).

    Args:
        out: the policy's distributions (:func:`forward`).
        rng: the generator.

    Returns:
        (mutation (N,), crossover (N,), F (N,), Cr (N,)): operator ids (intp) and rates kept
        in [RATE_EPS, 1 - RATE_EPS].
    """
    n = out.mutation_logits.shape[0]
    mut = _categorical(out.mutation_logits, rng.random(n))
    cx = _categorical(out.crossover_logits, rng.random(n))
    F = rng.beta(out.F_ab[:, 0], out.F_ab[:, 1])
    Cr = rng.beta(out.Cr_ab[:, 0], out.Cr_ab[:, 1])
    return mut, cx, np.clip(F, RATE_EPS, 1 - RATE_EPS), np.clip(Cr, RATE_EPS, 1 - RATE_EPS)


def mode_actions(out: PolicyOutput) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The most likely action per individual: argmax operators, Beta modes for F and Cr
    (``(alpha - 1) / (alpha + beta - 2)``). Uses no randomness.

    Args:
        out: the policy's distributions (:func:`forward`).

    Returns:
        (mutation (N,), crossover (N,), F (N,), Cr (N,)): operator ids (intp) and rates kept
        in [RATE_EPS, 1 - RATE_EPS].
    """
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
    """Exact log-probability of each individual's action (sum of its four parts: the two
    categorical operators and the Beta densities of F and Cr).

    Args:
        out: the policy's distributions (:func:`forward`).
        mutation: (N,) mutation ids.
        crossover: (N,) crossover ids.
        F: (N,) scale factors, in (0, 1).
        Cr: (N,) crossover rates, in (0, 1).

    Returns:
        (N,) log-probabilities.
    """
    from scipy.stats import beta as beta_dist

    def log_softmax(z: np.ndarray) -> np.ndarray:
        z = z - z.max(axis=1, keepdims=True)
        return z - np.log(np.exp(z).sum(axis=1, keepdims=True))

    n = len(mutation)
    lp = log_softmax(out.mutation_logits)[np.arange(n), mutation]
    lp = lp + log_softmax(out.crossover_logits)[np.arange(n), crossover]
    lp = lp + beta_dist.logpdf(F, out.F_ab[:, 0], out.F_ab[:, 1])
    return lp + beta_dist.logpdf(Cr, out.Cr_ab[:, 0], out.Cr_ab[:, 1])
