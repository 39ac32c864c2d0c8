"""Train the NeurELA-shaped encoder (torch; training code only, never on the planning path).

Objective: supervised contrastive loss (Khosla et al., "Supervised Contrastive Learning", 2020)
with the BBOB function id as the label. A batch holds 12 of the 24 functions (drawn per step),
two instances of each, each probed twice with independent LHS designs (N_probe = 100 points,
one dimension per batch, alternating): probes of the same function, whether of the same
instance or another, are positives; probes of other functions are negatives. Temperature 0.1,
cosine similarity on the encoder's unit-norm output, Adam with a cosine-decayed learning rate
from 3e-3. So two probes of one instance land close, different functions apart, and instance
transformations (shift, rotation) and the probe's randomness are what the feature must ignore.

Training instances use BBOB instance ids 1001.. (held out from every database, which uses ids
1..100), 8 instances x 3 probes per function, dimensions 10 and 20 by default (the cost of a
step grows with d; two shared cores set this); the features are then used at any dimension (the
encoder is dimension-agnostic).

Run: ``python -m planner_core.learning.lam.train_encoder --out
planner_core/learning/lam/data/encoder.npz``
(about 25 minutes on a busy core for the default 700 steps; same seed, same weights on one
machine). The shipped weights are this command's output at its defaults.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from planner_core.atomic import write_bytes_atomic
from planner_core.learning.lam.bbob import InstanceKey, bbob_values
from planner_core.learning.lam.ela import scale_y
from planner_core.learning.lam.encoder import EMBED, PARAM_SHAPES, init_params
from planner_core.learning.lam.probe import lhs

__all__ = ["TorchEncoder", "make_pool", "train", "main"]


def _torch():
    import torch

    return torch


def TorchEncoder(params: dict[str, np.ndarray]):  # noqa: N802 - a class factory
    """A torch module with the same forward as :func:`planner_core.learning.lam.encoder.encode`.

    Args:
        params: initial parameters, {name: array} of `PARAM_SHAPES` (copied into torch
            parameters).

    Returns:
        The module: ``forward(U (b, n, d), ys (b, n) already min-max scaled) -> (b, 16)``
        unit-norm, and ``numpy_params()`` giving the weights back as float arrays.
    """
    torch = _torch()
    nn = torch.nn

    class _Enc(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.p = nn.ParameterDict(
                {k.replace(".", "__"): nn.Parameter(torch.tensor(v)) for k, v in params.items()}
            )

        def P(self, name: str):  # noqa: N802
            return self.p[name.replace(".", "__")]

        def _block(self, h, blk: str):
            ln = torch.nn.functional.layer_norm
            x = ln(h, (EMBED,), self.P(f"{blk}.ln1.g"), self.P(f"{blk}.ln1.b"), eps=1e-5)
            qkv = x @ self.P(f"{blk}.qkv.w") + self.P(f"{blk}.qkv.b")
            q, k, v = qkv[..., :EMBED], qkv[..., EMBED : 2 * EMBED], qkv[..., 2 * EMBED :]
            a = torch.softmax((q @ k.transpose(-1, -2)) / EMBED**0.5, dim=-1)
            h = h + (a @ v) @ self.P(f"{blk}.out.w") + self.P(f"{blk}.out.b")
            x = ln(h, (EMBED,), self.P(f"{blk}.ln2.g"), self.P(f"{blk}.ln2.b"), eps=1e-5)
            return h + torch.relu(x @ self.P(f"{blk}.ff.w") + self.P(f"{blk}.ff.b"))

        def forward(self, U, ys):
            """U (b, n, d), ys (b, n) already min-max scaled -> (b, 16) unit-norm."""
            b, n, d = U.shape
            tok = torch.stack([U, ys[:, :, None].expand(b, n, d)], dim=-1)
            h = tok @ self.P("embed.w") + self.P("embed.b")  # (b, n, d, E)
            h = self._block(h.transpose(1, 2), "s")  # (b, d, n, E)
            h = self._block(h.transpose(1, 2), "d")  # (b, n, d, E)
            z = h.mean(dim=(1, 2)) @ self.P("head.w") + self.P("head.b")
            return z / z.norm(dim=-1, keepdim=True).clamp_min(1e-12)

        def numpy_params(self) -> dict[str, np.ndarray]:
            return {k: self.P(k).detach().cpu().numpy().astype(float) for k in PARAM_SHAPES}

    return _Enc()


def make_pool(
    dims: tuple[int, ...] = (10, 20),
    instances: tuple[int, ...] = tuple(range(1001, 1009)),
    probes: int = 3,
    n_probe: int = 100,
    seed: int = 0,
) -> dict[int, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """Per dimension: U (m, n, d), scaled y (m, n), function labels (m,), instance ids (m,),
    for all 24 functions x `instances` x `probes` LHS probes (seed
    ``SeedSequence([seed, f, d, i, r])``).

    Args:
        dims: dimensions.
        instances: BBOB instance ids (1001.. are held out from every database).
        probes: independent probes per instance.
        n_probe: points per probe.
        seed: the probes' base seed.

    Returns:
        {d: (U, scaled y, labels, instance ids)}, m = 24 x len(instances) x probes.
    """
    pool = {}
    for d in dims:
        Us, ys, fs, iids = [], [], [], []
        for f in range(1, 25):
            for i in instances:
                key = InstanceKey(f, d, i)
                for r in range(probes):
                    U = lhs(n_probe, d, np.random.SeedSequence([seed, f, d, i, r]))
                    Us.append(U)
                    ys.append(scale_y(bbob_values(key, U)))
                    fs.append(f)
                    iids.append(i)
        pool[d] = (np.array(Us), np.array(ys), np.array(fs), np.array(iids))
    return pool


def _supcon(z, labels, temperature: float):
    torch = _torch()
    sim = z @ z.T / temperature
    n = z.shape[0]
    eye = torch.eye(n, dtype=torch.bool)
    sim = sim.masked_fill(eye, -1e9)
    logp = sim - torch.logsumexp(sim, dim=1, keepdim=True)
    pos = (labels[:, None] == labels[None, :]) & ~eye
    return -((logp * pos).sum(1) / pos.sum(1).clamp_min(1)).mean()


def train(
    steps: int = 700,
    seed: int = 0,
    lr: float = 3e-3,
    temperature: float = 0.1,
    per_function: int = 2,
    functions_per_batch: int = 12,
    pool: dict | None = None,
    log_every: int = 25,
) -> dict[str, np.ndarray]:
    """Train from random init (seed) and return numpy parameters (module doc).

    Args:
        steps: optimiser steps (dimensions alternate per step).
        seed: seed of the init, the batches and torch.
        lr: initial Adam learning rate (cosine-decayed over `steps`).
        temperature: the contrastive loss's temperature.
        per_function: instances per function in a batch (two probes each).
        functions_per_batch: functions in a batch.
        pool: `make_pool`'s output (None: built with `seed`).
        log_every: print the loss every this many steps and at the last (0: never).

    Returns:
        {name: float array} of `PARAM_SHAPES`.
    """
    torch = _torch()
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    pool = make_pool(seed=seed) if pool is None else pool
    model = TorchEncoder(init_params(seed))
    opt = torch.optim.Adam(model.parameters(), lr=lr)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=max(steps, 1))
    dims = sorted(pool)
    t0 = time.time()
    for step in range(steps):
        U, ys, fs, iids = pool[dims[step % len(dims)]]
        pick = []
        for f in rng.choice(np.arange(1, 25), size=functions_per_batch, replace=False):
            inst = rng.choice(np.unique(iids[fs == f]), size=per_function, replace=False)
            for i in inst:
                rows = np.flatnonzero((fs == f) & (iids == i))
                pick.extend(rng.choice(rows, size=2, replace=False))
        pick = np.array(pick)
        z = model(torch.tensor(U[pick]), torch.tensor(ys[pick]))
        loss = _supcon(z, torch.tensor(fs[pick]), temperature)
        opt.zero_grad()
        loss.backward()
        opt.step()
        sched.step()
        if log_every and (step % log_every == 0 or step == steps - 1):
            print(f"step {step:4d}  loss {loss.item():.4f}  {time.time() - t0:.0f} s", flush=True)
    return model.numpy_params()


def save_params(params: dict[str, np.ndarray], path: str | Path) -> None:
    """Write weights as float32 .npz, atomically (shapes as in PARAM_SHAPES).

    Args:
        params: {name: array} holding every name of `PARAM_SHAPES`.
        path: the .npz file; a missing folder is created.
    """
    import io

    buf = io.BytesIO()
    np.savez_compressed(buf, **{k: np.asarray(params[k], dtype=np.float32) for k in PARAM_SHAPES})
    write_bytes_atomic(path, buf.getvalue())


def main(argv: list[str] | None = None) -> int:
    """The command line: train with --steps, --seed, --lr and write the weights to --out.

    Args:
        argv: the arguments (None: ``sys.argv[1:]``).

    Returns:
        0 (argparse exits with status 2 on bad arguments).
    """
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="planner_core/learning/lam/data/encoder.npz")
    ap.add_argument("--steps", type=int, default=700)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--lr", type=float, default=3e-3, help="initial Adam learning rate")
    args = ap.parse_args(argv)
    torch = _torch()
    torch.set_num_threads(1)
    save_params(train(steps=args.steps, seed=args.seed, lr=args.lr), args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
