"""A learned landscape encoder in NeurELA's shape, inference in numpy (no torch here).

NeurELA (Ma et al., "Neural Exploratory Landscape Analysis", 2024) has no public weights; its
shape is public and is what this module implements, with weights trained here
(:mod:`planner_core.learning.lam.train_encoder`, objective documented there) and shipped as package
data
(``planner_core/learning/lam/data/encoder.npz``, about 13 kB).

Forward pass for one probe, U (n, d) in the unit box and y (n,):

1. y is min-max scaled to [0, 1] (so the feature is invariant to ``y -> a y + b``, ``a > 0``);
   token (i, j) = (U[i, j], y_s[i]): shape (n, d, 2).
2. Embedding: linear 2 -> 16.
3. Block "across samples": for each dimension j, single-head self-attention over the n tokens
   (pre-LayerNorm, residual), then a residual feed-forward 16 -> 16 (ReLU) on LayerNorm.
4. Block "across dimensions": the same with attention over the d tokens of each sample i.
5. Mean-pool over samples and dimensions, linear 16 -> 16, then L2-normalise: the 16-d
   feature z (unit norm; the contrastive objective trains cosine similarity, so Euclidean
   distances between z are chord distances on the sphere).

Parameters: 3,168 (embedding 48, each block 1,424, head 272).
"""

from __future__ import annotations

import hashlib
from importlib import resources
from pathlib import Path

import numpy as np

from planner_core.learning.lam.ela import scale_y

__all__ = [
    "EMBED",
    "PARAM_SHAPES",
    "LearnedExtractor",
    "encode",
    "init_params",
    "load_params",
    "n_params",
    "params_digest",
]

EMBED = 16
_LN_EPS = 1e-5

#: every parameter's name and shape (the .npz holds exactly these)
PARAM_SHAPES: dict[str, tuple[int, ...]] = {"embed.w": (2, EMBED), "embed.b": (EMBED,)}
for _blk in ("s", "d"):
    PARAM_SHAPES.update({
        f"{_blk}.ln1.g": (EMBED,), f"{_blk}.ln1.b": (EMBED,),
        f"{_blk}.qkv.w": (EMBED, 3 * EMBED), f"{_blk}.qkv.b": (3 * EMBED,),
        f"{_blk}.out.w": (EMBED, EMBED), f"{_blk}.out.b": (EMBED,),
        f"{_blk}.ln2.g": (EMBED,), f"{_blk}.ln2.b": (EMBED,),
        f"{_blk}.ff.w": (EMBED, EMBED), f"{_blk}.ff.b": (EMBED,),
    })  # fmt: skip
PARAM_SHAPES.update({"head.w": (EMBED, EMBED), "head.b": (EMBED,)})


def n_params() -> int:
    """Number of scalar parameters (3,168).

    Returns:
        The sum of the sizes of `PARAM_SHAPES`.
    """
    return int(sum(np.prod(s) for s in PARAM_SHAPES.values()))


def init_params(seed: int = 0) -> dict[str, np.ndarray]:
    """Random parameters (Glorot-uniform weights, zero biases, unit LayerNorm gains).

    Args:
        seed: seed of ``numpy.random.default_rng``.

    Returns:
        {name: array of its `PARAM_SHAPES` shape}.
    """
    rng = np.random.default_rng(seed)
    out: dict[str, np.ndarray] = {}
    for name, shape in PARAM_SHAPES.items():
        if name.endswith(".g"):
            out[name] = np.ones(shape)
        elif len(shape) == 1:
            out[name] = np.zeros(shape)
        else:
            lim = np.sqrt(6.0 / (shape[0] + shape[1]))
            out[name] = rng.uniform(-lim, lim, size=shape)
    return out


def _layer_norm(x: np.ndarray, g: np.ndarray, b: np.ndarray) -> np.ndarray:
    mu = x.mean(axis=-1, keepdims=True)
    var = x.var(axis=-1, keepdims=True)
    return (x - mu) / np.sqrt(var + _LN_EPS) * g + b


def _block(h: np.ndarray, P: dict[str, np.ndarray], blk: str) -> np.ndarray:
    """Attention over axis -2 of h (..., t, 16), then feed-forward; both residual."""
    x = _layer_norm(h, P[f"{blk}.ln1.g"], P[f"{blk}.ln1.b"])
    qkv = x @ P[f"{blk}.qkv.w"] + P[f"{blk}.qkv.b"]
    q, k, v = qkv[..., :EMBED], qkv[..., EMBED : 2 * EMBED], qkv[..., 2 * EMBED :]
    s = (q @ np.swapaxes(k, -1, -2)) / np.sqrt(EMBED)
    s = s - s.max(axis=-1, keepdims=True)
    a = np.exp(s)
    a /= a.sum(axis=-1, keepdims=True)
    h = h + (a @ v) @ P[f"{blk}.out.w"] + P[f"{blk}.out.b"]
    x = _layer_norm(h, P[f"{blk}.ln2.g"], P[f"{blk}.ln2.b"])
    return h + np.maximum(x @ P[f"{blk}.ff.w"] + P[f"{blk}.ff.b"], 0.0)


def encode(U: np.ndarray, y: np.ndarray, params: dict[str, np.ndarray]) -> np.ndarray:
    """The 16-d unit-norm feature of one probe (module doc's forward pass).

    Args:
        U: (n, d) unit-box probe points.
        y: (n,) values there.
        params: the encoder's parameters (`PARAM_SHAPES`).

    Returns:
        (16,) feature of unit L2 norm.

    Raises:
        ValueError: U is not 2-d or its rows do not match y's length.
    """
    U = np.asarray(U, dtype=float)
    y = np.asarray(y, dtype=float).reshape(-1)
    if U.ndim != 2 or U.shape[0] != y.size:
        raise ValueError(f"U {U.shape} and y {y.shape} disagree")
    ys = scale_y(y)
    n, d = U.shape
    tok = np.stack([U, np.broadcast_to(ys[:, None], (n, d))], axis=-1)  # (n, d, 2)
    h = tok @ params["embed.w"] + params["embed.b"]  # (n, d, E)
    h = _block(np.swapaxes(h, 0, 1), params, "s")  # (d, n, E): attention across samples
    h = _block(np.swapaxes(h, 0, 1), params, "d")  # (n, d, E): attention across dimensions
    z = h.mean(axis=(0, 1)) @ params["head.w"] + params["head.b"]
    return z / max(float(np.linalg.norm(z)), 1e-12)


def load_params(path: str | Path | None = None) -> dict[str, np.ndarray]:
    """Load weights from an .npz (default: the shipped ``data/encoder.npz``).

    Args:
        path: the .npz file, or None for the shipped weights.

    Returns:
        {name: float array} for exactly the names of `PARAM_SHAPES` (other arrays dropped).

    Raises:
        ValueError: naming the first missing or mis-shaped parameter.
        OSError: the file cannot be read.
    """
    if path is None:
        ref = resources.files("planner_core.learning.lam") / "data" / "encoder.npz"
        with resources.as_file(ref) as p, np.load(p) as z:
            raw = {k: np.array(z[k], dtype=float) for k in z.files}
    else:
        with np.load(path) as z:
            raw = {k: np.array(z[k], dtype=float) for k in z.files}
    for name, shape in PARAM_SHAPES.items():
        if name not in raw:
            raise ValueError(f"encoder weights: {name} missing")
        if raw[name].shape != shape:
            raise ValueError(f"encoder weights: {name} has shape {raw[name].shape}, not {shape}")
    return {k: raw[k] for k in PARAM_SHAPES}


def params_digest(params: dict[str, np.ndarray]) -> str:
    """sha256 (first 16 hex) of the parameters, in PARAM_SHAPES order (each name, then its values
    as little-endian f8).

    Args:
        params: the encoder's parameters (every name of `PARAM_SHAPES`).

    Returns:
        16 hex digits.
    """
    h = hashlib.sha256()
    for name in PARAM_SHAPES:
        h.update(name.encode())
        h.update(np.ascontiguousarray(params[name], dtype="<f8").tobytes())
    return h.hexdigest()[:16]


class LearnedExtractor:
    """The NeurELA-shaped encoder behind the extractor interface.

    ``params`` None -> the shipped weights; ``identity`` includes the weights' digest, so a
    database built with other weights is cached apart.
    """

    name = "learned"
    dim = EMBED
    standardise = False

    def __init__(self, params: dict[str, np.ndarray] | None = None):
        self.params = load_params() if params is None else params
        self.identity = f"neurela-shape-v1-{params_digest(self.params)}"

    def __call__(self, U: np.ndarray, y: np.ndarray) -> np.ndarray:
        return encode(U, y, self.params)
