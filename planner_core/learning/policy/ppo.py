"""Meta-training of the policy with PPO and n-step updates (paper Algorithm 1). Torch lives here.

One readable loop (:func:`train`), in the spirit of CleanRL's ``ppo.py``, split into actors and
a learner: the rollouts run behind an executor (:mod:`planner_core.learning.policy.rollout`, numpy
only:
this process, a local process pool or Ray), the PPO update here; before it, a warm start:

    behaviour cloning of a hand-made configurator       # PPOConfig.imitate ("adaptive"), see
      (actor by maximum likelihood, critic on the       #   planner_core.learning.policy.imitation;
      returns-to-go of its episodes)                    #   written as the epoch-0 checkpoint
    for epoch in 1..E:                                  # Algorithm 1, line 2
        for each chunk of `envs` training problems:     # line 3, several rolled out together
            one job per problem (start mode per env)    # lines 4-5 (reset in the worker)
            until the episodes end:                     # line 6
                workers run up to n generations per     # lines 7-11 (numpy forward pass,
                  episode with the weights sent along,  #   sampled actions, DE step,
                  storing (s, a, log pi(a|s), V(s), r)  #   reward)
                kappa epochs of PPO on the segments     # lines 12-14, the learner, on
                  of all the chunk's episodes           #   every episode's segment at once
                new weights out with the next jobs      # line 15 (the buffer is new)
        write the checkpoint, the CSV row, TensorBoard scalars

Objective (Schulman et al. 2017, as CleanRL): the policy is factorised over individuals, so the
probability ratio is taken per individual, ``r_i = pi(a_i|s) / pi_old(a_i|s)`` with
``log pi(a_i|s)`` the exact sum of the mutation and crossover categorical and the F and Cr Beta
log-densities. Each individual i has its own advantage ``A_i`` (``credit="individual"``, the
default since issue 34) or shares its generation's (``credit="shared"``, the paper's and
``lamde-v2``'s):

    L_clip = mean over (generation, problem, individual) of max(-A_i r_i, -A_i clip(r_i, 1-e, 1+e))
    L_V    = 0.5 mean (V(s) - R)^2                  (critic on the pooled population)
    L_BC   = mean over (generation, problem, individual) of KL(pi_ref(.|s) || pi(.|s))
    L      = L_clip - c_ent * entropy + c_V * L_V + c_BC(e) * L_BC
                                                    (gradient norm clipped to max_grad_norm)

``L_BC`` is the behaviour-cloning anchor (``bc_coef``, 0 by default): ``pi_ref`` is the frozen
warm-start policy and ``c_BC(e) = bc_coef * bc_decay**e`` in epoch e, so PPO starts close to
the warm start and is let go as it learns; every KL is closed form (categoricals and Betas).

``log pi_old`` and the values V(s) are the actors' (the numpy forward pass at the weights the
segment ran with; the torch twin agrees to about 1e-5, tests/test_policy.py).

Per-individual credit (:func:`planner_core.learning.policy.credit.individual_advantages`):
individual i's trial outcome against its parent (:func:`planner_core.learning.env.
trial_credit`: scale-free, a feasibility gain ranked above any objective gain), centred and
scaled within its generation and parent class (feasible or infeasible parent), so that the
advantage is what this individual's action did against what the others' did from a like
start; plus ``pop_weight`` times the normalised GAE advantage of the population credit (the
same credit of the generation's Deb-best change, scale-free, which the critic learns to
predict). Shared mode: every individual gets the generation's GAE advantage of the env's
reward (below).

Advantage estimation (shared mode, and the population term): GAE(gamma, lambda) over the
n-step segment, bootstrapped with V of the state after the segment unless the episode ended
there (the budget's end is a true terminal state, see planner_core.learning.env); returns
R = A + V; advantages normalised over the batch.

Reward scaling (``reward_scale``, on by default): before GAE every reward is divided by the
running std of its problem's and start mode's discounted return (CleanRL's reward
normalisation, kept per problem: :class:`planner_core.learning.policy.imitation.RewardScaler`; the
warm start's demonstration episodes seed the statistics), so that large and small maps, seeded
and uniform starts weigh alike in an update. The curve's ``return`` stays the raw env return.

Determinism: episode j of epoch e draws its DE seed and all its actions from its own
generator (``SeedSequence(seed, spawn_key=(e, j))``, see
:mod:`planner_core.learning.policy.rollout`),
the chunks' order from ``numpy.random.default_rng([seed, epoch])``, and the torch generator is
reseeded per epoch; a segment's result depends only on its job. So the same seed gives the same
checkpoint on the same machine whatever the executor and its number of workers, and ``resume``
continues exactly where an interrupted run would have been.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn
from torch.distributions import Beta, Categorical, kl_divergence

from planner_core.atomic import write_bytes_atomic
from planner_core.defaults import TRAIN_DEFAULTS
from planner_core.execution import Executor, SerialExecutor
from planner_core.learning.env import DEFAULT_DELTA, DEFAULT_ETA, N_CONTEXT, initial_features
from planner_core.learning.policy import checkpoint as ckpt
from planner_core.learning.policy import rollout
from planner_core.learning.policy.credit import individual_advantages
from planner_core.learning.policy.imitation import DEMO_KEY, Demos, RewardScaler, collect_demos
from planner_core.learning.policy.network import N_FEATURES, NetConfig, init_params, param_shapes
from planner_core.learning.policy.problems import spec_name
from planner_core.model.problem import penalised_score


@dataclass
class PPOConfig:
    """Every hyper-parameter of meta-training (defaults: the paper / RLDE-AFL where they give
    one, sized down where this 2-core machine needs it)."""

    seed: int = TRAIN_DEFAULTS["seed"]
    """Seed of the weights' initialisation, the rollouts' DE seeds and action draws."""
    epochs: int = TRAIN_DEFAULTS["epochs"]
    """E: passes over the training problems (Algorithm 1, line 2); 0 = the warm start alone."""
    envs: int = TRAIN_DEFAULTS["envs"]
    """Problems rolled out together, batched in one forward pass per generation."""
    population: int = TRAIN_DEFAULTS["population"]
    """N of the DE during training (the policy is population-agnostic; planning uses 100)."""
    budget: int = TRAIN_DEFAULTS["budget"]
    """Evaluations per training episode (G = budget / N - 1 generations; progress g/G spans
    [0, 1] whatever the budget)."""
    n_steps: int = 10
    """n: generations between PPO updates (Algorithm 1's n-step update; RLDE-AFL: 10)."""
    update_epochs: int = 3
    """kappa: PPO epochs over each n-step buffer (RLDE-AFL: 3)."""
    gamma: float = 0.99
    """Discount factor (RLDE-AFL: 0.99)."""
    gae_lambda: float = 0.95
    """GAE lambda for the advantage estimate (1.0 = n-step returns)."""
    clip: float = 0.2
    """PPO ratio clip epsilon (RLDE-AFL: 0.2)."""
    lr: float = 3e-4
    """Adam learning rate of PPO (small: PPO refines the warm start; CleanRL uses 2.5e-4)."""
    vf_coef: float = 0.5
    """Weight of the value loss."""
    ent_coef: float = 0.001
    """Weight of the entropy bonus."""
    max_grad_norm: float = 0.5
    """Gradient-norm clip."""
    norm_adv: bool = True
    """Normalise advantages over each update's batch."""
    init_modes: tuple[str, ...] = ("uniform", "seeded")
    """Start modes the episodes cycle through (env k of chunk c in epoch e uses
    init_modes[(e + c + k) % len])."""
    eta: float = DEFAULT_ETA
    """Exponent scale of the mantissa-exponent observation (planner_core.learning.env)."""
    delta: float = DEFAULT_DELTA
    """Feasibility tolerance of the reward (planner_core.learning.env)."""
    threads: int = 1
    """torch intra-op threads (1 keeps runs reproducible and leaves a core to the DE)."""
    imitate: str = TRAIN_DEFAULTS["imitate"]
    """Behaviour-cloning warm start (:mod:`planner_core.learning.policy.imitation`): the hand-made
    configurator whose choices the actor is fitted to by maximum likelihood (and the critic to
    its returns) before PPO, on every training problem in every start mode; "none" skips it."""
    imitate_epochs: int = TRAIN_DEFAULTS["imitate_epochs"]
    """Passes over the demonstrations (0 = no warm start)."""
    imitate_lr: float = 1e-3
    """Adam learning rate of the warm start."""
    imitate_batch: int = 8
    """Observations per warm-start mini-batch."""
    imitate_stride: int = 3
    """Keep every k-th generation of the demonstrations (consecutive ones are near copies)."""
    bc_coef: float = 0.0
    """Weight of the behaviour-cloning anchor in PPO's loss: ``bc_coef * KL(pi_ref || pi)``,
    per individual, with ``pi_ref`` the frozen warm-start policy (after the imitation fit, or
    ``init_checkpoint``). The KL from the reference is the expected cross-entropy of the warm
    start's own actions, so it keeps PPO near what behaviour cloning learned (0 = plain PPO)."""
    bc_decay: float = 1.0
    """Per-epoch factor of ``bc_coef``: epoch e (0-based) uses ``bc_coef * bc_decay**e``, so
    PPO is held close to the warm start first and let go as it learns (1 = constant)."""
    init_checkpoint: str = ""
    """Start PPO from this checkpoint's weights (a shipped name such as ``lamde-v1`` or a
    folder) instead of fitting the warm start here; its network sizes must equal ``net``. The
    demonstrations of ``imitate`` are still collected (not fitted) to seed the reward scaler.
    Empty = no such start."""
    credit: str = "individual"
    """``"individual"``: each individual's advantage from its own trial outcome plus
    ``pop_weight`` times the population term (:func:`individual_advantages`; the default for
    new trainings); ``"shared"``: every individual shares its generation's advantage of the
    env's reward (the paper's PPO, how ``lamde-v1``/``lamde-v2`` were trained)."""
    pop_weight: float = 0.1
    """Weight of the population term (the normalised GAE advantage of the Deb-best's credit)
    in per-individual credit."""
    reward_scale: bool = True
    """Divide each reward by the running std of its problem's (and start mode's) discounted
    return, CleanRL's reward normalisation
    (:class:`planner_core.learning.policy.imitation.RewardScaler`),
    so that big and small maps, seeded and uniform starts weigh alike in an update."""
    net: NetConfig = field(default_factory=lambda: NetConfig(context=N_CONTEXT))
    """Network sizes (new trainings read the observation's context; a stored config without
    ``context`` reads as 0, the network of ``lamde-v1``/``lamde-v2``)."""

    def to_dict(self) -> dict[str, Any]:
        """The settings as JSON-able values (stored in the checkpoint and the training state).

        Returns:
            ``dataclasses.asdict`` of the config, ``init_modes`` as a list, ``net`` as a dict.
        """
        d = dataclasses.asdict(self)
        d["init_modes"] = list(self.init_modes)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PPOConfig:
        """The config of :meth:`to_dict`; a stored config from before issue 34 (no ``credit``)
        reads as the shared credit it was trained with.

        Args:
            d: a :meth:`to_dict` object (not modified).

        Returns:
            The `PPOConfig`.

        Raises:
            TypeError: an unknown field.
            ValueError: network sizes `NetConfig` refuses.
        """
        d = dict(d)
        d.setdefault("credit", "shared")
        net = NetConfig(**d.pop("net", {}))
        if "init_modes" in d:
            d["init_modes"] = tuple(d["init_modes"])
        return cls(net=net, **d)


# ---------------------------------------------------------------------------------- network


class TorchPolicy(nn.Module):
    """The torch twin of :func:`planner_core.learning.policy.network.forward`, batched over
    problems.

    Parameters are stored under the numpy names (``.`` replaced by ``__``).
    """

    def __init__(self, cfg: NetConfig) -> None:
        super().__init__()
        self.cfg = cfg
        self.p = nn.ParameterDict({
            k.replace(".", "__"): nn.Parameter(torch.zeros(s))
            for k, s in param_shapes(cfg).items()
        })

    def load_numpy(self, params: dict[str, np.ndarray]) -> None:
        """Copy numpy weights into the module's parameters (no gradient).

        Args:
            params: {numpy name: array}, each of its parameter's shape (a subset may be given).
        """
        with torch.no_grad():
            for k, v in params.items():
                self.p[k.replace(".", "__")].copy_(torch.as_tensor(np.asarray(v)))

    def numpy_params(self) -> dict[str, np.ndarray]:
        """The weights under their numpy names.

        Returns:
            {name: float32 array} (copies).
        """
        return {k.replace("__", "."): v.detach().cpu().numpy().astype(np.float32).copy()
                for k, v in self.p.items()}

    def _w(self, name: str) -> torch.Tensor:
        return self.p[name.replace(".", "__")]

    def _lin(self, x: torch.Tensor, prefix: str) -> torch.Tensor:
        """``x @ W + b`` with the bias fused into the matmul (weights are stored (in, out))."""
        return nn.functional.linear(x, self._w(f"{prefix}.weight").t(), self._w(f"{prefix}.bias"))

    def _mab(self, a: torch.Tensor, b: torch.Tensor, prefix: str,
             key_mask: torch.Tensor | None) -> torch.Tensor:
        """MAB(A, B) as written in the Set Transformer paper: a (..., La, E) attends to
        b (..., Lb, E); post-norm."""
        *lead, La, E = a.shape
        Lb = b.shape[-2]
        h = self.cfg.heads
        dh = E // h
        q = self._lin(a, f"{prefix}.q")
        kv = self._lin(b, f"{prefix}.kv")
        q = q.reshape(*lead, La, h, dh).movedim(-2, -3)
        k = kv[..., :E].reshape(*lead, Lb, h, dh).movedim(-2, -3)
        v = kv[..., E:].reshape(*lead, Lb, h, dh).movedim(-2, -3)
        s = (q @ k.transpose(-1, -2)) / math.sqrt(dh)
        if key_mask is not None:  # (..., Lb) additive: 0 for a real key, -inf for padding
            s = s + key_mask[..., None, None, :]
        y = (torch.softmax(s, dim=-1) @ v).movedim(-3, -2).reshape(*lead, La, E)
        y = self._lin(y, f"{prefix}.out")
        x = nn.functional.layer_norm(a + y, (E,), self._w(f"{prefix}.ln1.weight"),
                                     self._w(f"{prefix}.ln1.bias"), eps=1e-5)
        y = torch.relu(self._lin(x, f"{prefix}.ff1"))
        y = self._lin(y, f"{prefix}.ff2")
        return nn.functional.layer_norm(x + y, (E,), self._w(f"{prefix}.ln2.weight"),
                                        self._w(f"{prefix}.ln2.bias"), eps=1e-5)

    def _isab(self, x: torch.Tensor, prefix: str, key_mask: torch.Tensor | None) -> torch.Tensor:
        """ISAB(X) = MAB(X, MAB(I, X)) over the second-last axis of x (..., L, E)."""
        ind = self._w(f"{prefix}.inducing")
        ind = ind.expand(*x.shape[:-2], *ind.shape)
        h = self._mab(ind, x, f"{prefix}.ind", key_mask)
        return self._mab(x, h, f"{prefix}.set", None)

    def forward(
        self,
        X: torch.Tensor,
        f: torch.Tensor,
        phi: torch.Tensor,
        progress: torch.Tensor,
        mask: torch.Tensor,
        context: torch.Tensor | None = None,
    ) -> tuple[torch.Tensor, ...]:
        """The policy on a batch of observations (:func:`batch_obs`).

        Args:
            X: (B, N, D) populations, dimensions padded.
            f: (B, N, 2) mantissa-exponent pairs of f.
            phi: (B, N, 2) mantissa-exponent pairs of phi.
            progress: (B,) g / G.
            mask: (B, D) True = real dimension.
            context: (B, K) context vectors, used when ``cfg.context`` is K > 0.

        Returns:
            (mutation logits (B, N, 7), crossover logits (B, N, 2), F and Cr Beta parameters
            (B, N, 2) each, value (B,)).
        """
        B, N, D = X.shape
        t = torch.cat([X[..., None], f[:, :, None, :].expand(B, N, D, 2),
                       phi[:, :, None, :].expand(B, N, D, 2)], dim=-1)
        assert t.shape[-1] == N_FEATURES
        x = self._lin(t, "embed")  # (B, N, D, E)
        x = self._isab(x.transpose(1, 2), "pop", None).transpose(1, 2)
        km = None
        if not bool(mask.all()):
            km = torch.zeros(mask.shape, dtype=x.dtype).masked_fill(~mask, float("-inf"))
            km = km[:, None, :].expand(B, N, D)
        x = self._isab(x, "dim", km)
        m = mask[:, None, :, None].to(x.dtype)
        pooled = (x * m).sum(dim=2) / m.sum(dim=2)  # (B, N, E)
        g = progress[:, None, None].expand(B, N, 1).to(x.dtype)
        parts = [pooled, g]
        if self.cfg.context:
            parts.append(context[:, None, :].expand(B, N, self.cfg.context).to(x.dtype))
        h = torch.relu(torch.cat(parts, dim=-1) @ self._w("join.weight")
                       + self._w("join.bias"))
        mut = self._lin(h, "mutation")
        cx = self._lin(h, "crossover")
        F_ab = 1.0 + nn.functional.softplus(self._lin(h, "F"))
        Cr_ab = 1.0 + nn.functional.softplus(self._lin(h, "Cr"))
        c = torch.relu(h.mean(dim=1) @ self._w("critic1.weight") + self._w("critic1.bias"))
        value = self._lin(c, "critic2")[:, 0]
        return mut, cx, F_ab, Cr_ab, value


def log_prob_entropy(
    out: tuple[torch.Tensor, ...], actions: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """Exact per-individual log-probability and entropy of ``actions``.

    Args:
        out: :meth:`TorchPolicy.forward`'s output (its first four entries are read).
        actions: (B, N, 4): columns mutation id, crossover id, F, Cr.

    Returns:
        (log-probability (B, N), entropy (B, N)).
    """
    mut, cx, F_ab, Cr_ab = out[:4]
    dm, dc = Categorical(logits=mut), Categorical(logits=cx)
    dF, dCr = Beta(F_ab[..., 0], F_ab[..., 1]), Beta(Cr_ab[..., 0], Cr_ab[..., 1])
    lp = (dm.log_prob(actions[..., 0].long()) + dc.log_prob(actions[..., 1].long())
          + dF.log_prob(actions[..., 2]) + dCr.log_prob(actions[..., 3]))
    ent = dm.entropy() + dc.entropy() + dF.entropy() + dCr.entropy()
    return lp, ent


def kl_from_reference(
    ref: tuple[torch.Tensor, ...], out: tuple[torch.Tensor, ...]
) -> torch.Tensor:
    """Exact per-individual KL(pi_ref || pi) between two policy outputs (the factorised
    distribution: the mutation and crossover categoricals and the F and Cr Betas, closed form
    for each; the KL of a product is the sum of the KLs).

    Args:
        ref: the reference policy's output, held fixed (no gradient).
        out: the trained policy's output on the same batch.

    Returns:
        (B, N) KL divergences.
    """
    def dists(o: tuple[torch.Tensor, ...]) -> tuple[Any, ...]:
        return (Categorical(logits=o[0]), Categorical(logits=o[1]),
                Beta(o[2][..., 0], o[2][..., 1]), Beta(o[3][..., 0], o[3][..., 1]))

    return sum(kl_divergence(p, q) for p, q in zip(dists(ref), dists(out), strict=True))


def batch_obs(obs: list[dict[str, np.ndarray]]) -> dict[str, torch.Tensor]:
    """Stack env observations of problems with the same N (dimensions padded, masked). An
    observation without a context (written by hand, or before issue 34) reads as a run's
    first one.

    Args:
        obs: env observations (:func:`planner_core.learning.env.observe`), same N each.

    Returns:
        Tensors: "X" (B, N, D) float32, "f", "phi" (B, N, 2), "progress" (B,), "mask" (B, D)
        bool, "context" (B, K).

    Raises:
        ValueError: observations of different N.
    """
    B = len(obs)
    N = obs[0]["X"].shape[0]
    D = max(o["X"].shape[1] for o in obs)
    X = np.zeros((B, N, D), dtype=np.float32)
    mask = np.zeros((B, D), dtype=bool)
    for b, o in enumerate(obs):
        d = o["X"].shape[1]
        X[b, :, :d] = o["X"]
        mask[b, :d] = True
    return {
        "X": torch.from_numpy(X),
        "f": torch.from_numpy(np.stack([o["f"] for o in obs]).astype(np.float32)),
        "phi": torch.from_numpy(np.stack([o["phi"] for o in obs]).astype(np.float32)),
        "progress": torch.from_numpy(
            np.array([o["progress"][0] for o in obs], dtype=np.float32)),
        "mask": torch.from_numpy(mask),
        # an observation without a context (written by hand, or before issue 34) reads as a
        # run's first one; a network without context ignores it
        "context": torch.from_numpy(np.stack([
            np.asarray(o["context"]) if "context" in o else _FIRST_CONTEXT
            for o in obs]).astype(np.float32)),
    }


#: the context of a run before its first generation (all arms at the prior, no stall, none
#: feasible)
_FIRST_CONTEXT = np.concatenate([initial_features().arm_success, [0.0, 0.0]])


def _cat_obs(batches: list[dict[str, torch.Tensor]]) -> dict[str, torch.Tensor]:
    """Concatenate batched observations along B, padding D to the largest."""
    D = max(b["X"].shape[2] for b in batches)
    out: dict[str, list[torch.Tensor]] = {k: [] for k in batches[0]}
    for b in batches:
        pad = D - b["X"].shape[2]
        out["X"].append(nn.functional.pad(b["X"], (0, pad)))
        out["mask"].append(nn.functional.pad(b["mask"], (0, pad), value=False))
        for k in ("f", "phi", "progress", "context"):
            out[k].append(b[k])
    return {k: torch.cat(v) for k, v in out.items()}


def _forward(model: TorchPolicy, o: dict[str, torch.Tensor]) -> tuple[torch.Tensor, ...]:
    return model(o["X"], o["f"], o["phi"], o["progress"], o["mask"], o.get("context"))


def with_context(params: dict[str, np.ndarray], net: NetConfig, wider: NetConfig
                 ) -> dict[str, np.ndarray]:
    """Weights of a network without context (``net.context == 0``) as weights of ``wider``
    (the same sizes with ``context`` K): zero rows for the context in ``join.weight``, so the
    wider network computes exactly what the given one does until training moves them (how a
    new training starts from ``lamde-v2``).

    Args:
        params: the narrow network's weights (not modified).
        net: its sizes.
        wider: the sizes with a context.

    Returns:
        A new dict: ``params`` with a widened float32 ``join.weight``.

    Raises:
        ValueError: ``net`` has a context or differs from ``wider`` in another size.
    """
    if net.context or dataclasses.replace(net, context=wider.context) != wider:
        raise ValueError(f"init_checkpoint: network {net} cannot be widened to {wider}")
    out = dict(params)
    w = np.asarray(params["join.weight"], dtype=np.float32)
    out["join.weight"] = np.concatenate([w, np.zeros((wider.context, w.shape[1]), np.float32)])
    return out


def _normalised(a: np.ndarray) -> np.ndarray:
    """(a - mean) / std over all entries (a copy; 0 when a has no spread)."""
    sd = float(a.std())
    return (a - a.mean()) / sd if sd > 1e-12 else np.zeros_like(a)


# ---------------------------------------------------------------------------------- PPO update


def ppo_update(
    model: TorchPolicy,
    optimizer: torch.optim.Optimizer,
    cfg: PPOConfig,
    obs: dict[str, torch.Tensor],
    actions: torch.Tensor,
    old_logp: torch.Tensor,
    advantages: torch.Tensor,
    returns: torch.Tensor,
    reference: TorchPolicy | None = None,
    bc_coef: float = 0.0,
) -> dict[str, float]:
    """``cfg.update_epochs`` full-batch PPO steps on one buffer (B samples of N individuals).

    Args:
        model: the policy trained.
        optimizer: its optimiser.
        cfg: the settings (clip, coefficients, norm_adv, update_epochs, max_grad_norm).
        obs: the batched observations (:func:`batch_obs`), B samples.
        actions: (B, N, 4) the actions taken.
        old_logp: (B, N) their log-probabilities when taken.
        advantages: (B,) one per sample (shared credit; normalised here when ``norm_adv``) or
            (B, N) one per individual (per-individual credit, already scale-free).
        returns: (B,) targets of the critic.
        reference: the frozen warm-start policy of the behaviour-cloning anchor, or None.
        bc_coef: the anchor's weight (this epoch's :attr:`PPOConfig.bc_coef`); 0 (or
            ``reference`` None): no anchor.

    Returns:
        The last epoch's "policy_loss", "value_loss", "entropy", "approx_kl" ((r-1) - log r,
        as CleanRL), "clipfrac" and "bc_kl" (the anchor's KL(pi_ref || pi), mean per
        individual).
    """
    adv = advantages
    if cfg.norm_adv and adv.numel() > 1 and adv.dim() == 1:
        adv = (adv - adv.mean()) / (adv.std() + 1e-8)
    a = adv[:, None] if adv.dim() == 1 else adv
    ref_out = None
    if reference is not None and bc_coef > 0:
        with torch.no_grad():
            ref_out = _forward(reference, obs)
    stats: dict[str, float] = {}
    for _ in range(cfg.update_epochs):
        out = _forward(model, obs)
        logp, ent = log_prob_entropy(out, actions)
        log_ratio = logp - old_logp
        ratio = log_ratio.exp()
        pg_loss = torch.max(-a * ratio, -a * ratio.clamp(1 - cfg.clip, 1 + cfg.clip)).mean()
        v_loss = 0.5 * ((out[4] - returns) ** 2).mean()
        entropy = ent.mean()
        bc_kl = (kl_from_reference(ref_out, out).mean() if ref_out is not None
                 else torch.zeros(()))
        loss = pg_loss - cfg.ent_coef * entropy + cfg.vf_coef * v_loss + bc_coef * bc_kl
        optimizer.zero_grad()
        loss.backward()
        nn.utils.clip_grad_norm_(model.parameters(), cfg.max_grad_norm)
        optimizer.step()
        with torch.no_grad():
            stats = {
                "policy_loss": float(pg_loss),
                "value_loss": float(v_loss),
                "entropy": float(entropy),
                "approx_kl": float(((ratio - 1) - log_ratio).mean()),
                "clipfrac": float(((ratio - 1).abs() > cfg.clip).float().mean()),
                "bc_kl": float(bc_kl),
            }
    return stats


def clipped_objective(
    model: TorchPolicy, cfg: PPOConfig, obs: dict[str, torch.Tensor], actions: torch.Tensor,
    old_logp: torch.Tensor, advantages: torch.Tensor,
) -> float:
    """The clipped surrogate loss L_clip of the current weights on a fixed batch (for tests).

    Args:
        model: the policy.
        cfg: the settings (its ``clip``).
        obs: the batched observations.
        actions: (B, N, 4) actions.
        old_logp: (B, N) their old log-probabilities.
        advantages: (B,) one per sample (not normalised here).

    Returns:
        L_clip (mean over samples and individuals).
    """
    with torch.no_grad():
        logp, _ = log_prob_entropy(_forward(model, obs), actions)
        ratio = (logp - old_logp).exp()
        a = advantages[:, None]
        return float(torch.max(-a * ratio, -a * ratio.clamp(1 - cfg.clip, 1 + cfg.clip)).mean())


def gae(
    rewards: np.ndarray, values: np.ndarray, dones: np.ndarray, next_value: np.ndarray,
    gamma: float, lam: float,
) -> np.ndarray:
    """GAE advantages of one n-step segment (Schulman et al. 2016).

    ``delta_t = r_t + gamma V_{t+1} (1 - done_t) - V_t``, ``A_t = delta_t + gamma lam
    (1 - done_t) A_{t+1}``.

    Args:
        rewards: (T, B) rewards.
        values: (T, B) V of each step's state.
        dones: (T, B), ``dones[t] = 1`` when the episode ended with step t (then nothing is
            bootstrapped past it).
        next_value: (B,) V of the state after the segment.
        gamma: discount.
        lam: GAE lambda.

    Returns:
        (T, B) advantages.
    """
    T = rewards.shape[0]
    adv = np.zeros_like(rewards)
    last = np.zeros(rewards.shape[1])
    for t in reversed(range(T)):
        nv = next_value if t == T - 1 else values[t + 1]
        nonterminal = 1.0 - dones[t]
        delta = rewards[t] + gamma * nv * nonterminal - values[t]
        last = delta + gamma * lam * nonterminal * last
        adv[t] = last
    return adv


# ---------------------------------------------------------------------------------- warm start


def imitation_loss(
    model: TorchPolicy, obs: dict[str, torch.Tensor], actions: torch.Tensor, returns: torch.Tensor,
    vf_coef: float,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Behaviour-cloning loss on one batch.

    Args:
        model: the policy.
        obs: batched observations (:func:`planner_core.learning.policy.ppo.batch_obs`).
        actions: (B, N, 4) demonstrated actions.
        returns: (B,) returns-to-go.
        vf_coef: weight of the value loss.

    Returns:
        (total, negative log-likelihood per individual, value loss), scalar tensors.
    """
    out = _forward(model, obs)
    logp, _ = log_prob_entropy(out, actions)
    nll = -logp.mean()
    v_loss = 0.5 * ((out[4] - returns) ** 2).mean()
    return nll + vf_coef * v_loss, nll, v_loss


def pretrain(
    model: TorchPolicy,
    demos: Demos,
    *,
    epochs: int,
    batch: int,
    lr: float,
    vf_coef: float,
    max_grad_norm: float,
    seed: int,
    log: Callable[[str], None] | None = None,
) -> list[dict[str, float]]:
    """Behaviour cloning (:mod:`planner_core.learning.policy.imitation`): maximum-likelihood fit
    of the actor (and least squares of the critic, weight ``vf_coef``) to ``demos`` with Adam
    over shuffled mini-batches (order from ``default_rng([seed, DEMO_KEY, epoch])``), gradient
    norm clipped.

    Args:
        model: the policy fitted (in place).
        demos: the demonstrations.
        epochs: passes over the demonstrations.
        batch: observations per mini-batch.
        lr: Adam's learning rate.
        vf_coef: weight of the value loss.
        max_grad_norm: gradient-norm clip.
        seed: seed of the mini-batch order.
        log: gets one line per pass.

    Returns:
        One row per pass: "epoch", mean imitation "nll", "value_loss", "seconds".
    """
    optimizer = torch.optim.Adam(model.parameters(), lr=lr, eps=1e-5)
    S = len(demos.obs)
    rows = []
    for epoch in range(epochs):
        t0 = time.perf_counter()
        order = np.random.default_rng([seed, DEMO_KEY, epoch]).permutation(S)
        nlls, vls = [], []
        for s in range(0, S, batch):
            idx = order[s:s + batch]
            o = batch_obs([demos.obs[i] for i in idx])
            loss, nll, vl = imitation_loss(
                model, o, torch.from_numpy(demos.actions[idx]),
                torch.from_numpy(demos.returns[idx]), vf_coef)
            optimizer.zero_grad()
            loss.backward()
            nn.utils.clip_grad_norm_(model.parameters(), max_grad_norm)
            optimizer.step()
            nlls.append(float(nll.detach()) * len(idx))
            vls.append(float(vl.detach()) * len(idx))
        row = {"epoch": epoch + 1, "nll": sum(nlls) / S, "value_loss": sum(vls) / S,
               "seconds": time.perf_counter() - t0}
        rows.append(row)
        if log is not None:
            log(f"imitation epoch {epoch + 1}/{epochs}: NLL {row['nll']:.4f}, value loss "
                f"{row['value_loss']:.4f}, {row['seconds']:.0f} s")
    return rows


# ---------------------------------------------------------------------------------- training


CURVE_FIELDS = ("epoch", "episodes", "return", "feasible_rate", "best_score", "policy_loss",
                "value_loss", "entropy", "approx_kl", "clipfrac", "bc_kl", "seconds")


def _scalar_writer(folder: Path) -> Any:
    """A TensorBoard SummaryWriter when tensorboard (or tensorboardX) is installed, else None.
    Only an ImportError means "not installed": any other error of an installed but broken one
    propagates."""
    try:
        from torch.utils.tensorboard import SummaryWriter
    except ImportError:  # tensorboard is optional
        try:
            from tensorboardX import SummaryWriter  # type: ignore[no-redef]
        except ImportError:
            return None
    return SummaryWriter(str(folder / "tb"))


def train(
    cfg: PPOConfig,
    specs: list[dict[str, Any]],
    out: str | Path,
    *,
    resume: bool = False,
    log: Callable[[str], None] | None = None,
    progress: Callable[[int, int, str], None] | None = None,
    executor: Executor | None = None,
) -> Path:
    """Meta-train a policy on the problems ``specs`` (see planner_core.learning.policy.problems)
    and write a checkpoint folder ``out`` every epoch (weights.npz, config.json, manifest.json,
    curve.csv, imitation.csv, and state.pt for ``resume``). The checkpoint does not depend on
    the executor.

    Args:
        cfg: the training settings.
        specs: the problem specs.
        out: the checkpoint folder.
        resume: continue the training saved in ``out`` (state.pt; only ``cfg.epochs`` may
            differ); without state.pt a new one starts (and ``log`` says so).
        log: ``log(line)`` gets one line per epoch (and the warm start's).
        progress: ``progress(done, total, text)`` is called after each n-step segment of each
            chunk.
        executor: runs the rollout segments (:mod:`planner_core.learning.policy.rollout`;
            :func:`planner_core.execution.make_executor`: a local process pool or Ray); None
            runs them in this process. The caller closes the executor.

    Returns:
        ``out``.

    Raises:
        ValueError: bad settings or problem specs, a resumed folder trained with other
            settings or problems or whose state.pt cannot be read (CheckpointError), or an
            ``init_checkpoint`` whose network does not fit (CheckpointError, a ValueError, for
            an unreadable one).
        RuntimeError: the episodes of one chunk ran out of step.
    """
    out = Path(out)
    if cfg.credit not in ("individual", "shared"):
        raise ValueError(f"credit: must be 'individual' or 'shared', got {cfg.credit!r}")
    if cfg.envs < 1 or cfg.n_steps < 1 or cfg.update_epochs < 1 or cfg.epochs < 0:
        raise ValueError("envs, n_steps and update_epochs must be >= 1, epochs >= 0")
    if cfg.epochs == 0 and (cfg.imitate == "none" or cfg.imitate_epochs < 1):
        raise ValueError("epochs: 0 PPO epochs needs the imitation warm start (imitate, "
                         "imitate_epochs >= 1)")
    for mode in cfg.init_modes:
        if mode not in ("seeded", "uniform"):
            raise ValueError(f"init_modes: unknown start mode {mode!r}")
    torch.set_num_threads(cfg.threads)
    # jobs carry map content, never a path; the driver builds each problem once too (its
    # dimension orders the chunks), through the same per-process cache as the workers
    portable = [rollout.portable_spec(s) for s in specs]
    problems = [rollout.problem_of(s) for s in portable]
    names = [spec_name(s) for s in specs]
    executor = SerialExecutor() if executor is None else executor
    model = TorchPolicy(cfg.net)
    model.load_numpy(init_params(cfg.net, cfg.seed))
    optimizer = torch.optim.Adam(model.parameters(), lr=cfg.lr, eps=1e-5)
    scaler = RewardScaler(cfg.gamma)
    curve: list[dict[str, Any]] = []
    imitation_rows: list[dict[str, float]] = []
    start_epoch = 0
    state_path = out / "state.pt"
    resumed = resume and state_path.exists()
    if resume and not resumed and log is not None:  # a mistyped folder shows here
        log(f"--resume: {out} holds no training to continue (no state.pt): starting one")
    if resumed:
        state = _load_state(state_path)
        same = {k: v for k, v in state["config"].items() if k != "epochs"} == {
            k: v for k, v in cfg.to_dict().items() if k != "epochs"}
        if not same or state["specs"] != specs:
            raise ValueError(f"--resume: {out} was trained with other settings or problems "
                             "(only --epochs may change)")
        model.load_state_dict(state["model"])
        optimizer.load_state_dict(state["optimizer"])
        start_epoch = int(state["epoch"])
        curve = list(state["curve"])
        scaler.load_state_dict(state.get("scaler", {}))
        imitation_rows = list(state.get("imitation", []))
    writer = _scalar_writer(out) if start_epoch < cfg.epochs else None
    if not resumed and cfg.init_checkpoint:
        # ---- PPO from a given checkpoint's weights (e.g. the shipped warm start)
        params, net, _ = ckpt.load(cfg.init_checkpoint)
        if net != cfg.net and dataclasses.replace(net, context=cfg.net.context) == cfg.net \
                and net.context == 0:
            params = with_context(params, net, cfg.net)
        elif net != cfg.net:
            raise ValueError(f"init_checkpoint: {cfg.init_checkpoint} has network {net}, "
                             f"not {cfg.net}")
        model.load_numpy(params)
    fit_bc = not cfg.init_checkpoint and cfg.imitate_epochs > 0
    if not resumed and cfg.imitate != "none" and (fit_bc or cfg.reward_scale):
        # ---- behaviour-cloning warm start (planner_core.learning.policy.imitation); its episodes
        # also
        # seed the reward scaler's statistics of every problem and start mode
        t_bc = time.perf_counter()
        demos = collect_demos(
            problems, names, configurator=cfg.imitate, init_modes=cfg.init_modes,
            seed=cfg.seed, population=cfg.population, budget=cfg.budget, gamma=cfg.gamma,
            eta=cfg.eta, delta=cfg.delta, stride=cfg.imitate_stride,
            scaler=scaler if cfg.reward_scale else None)
        if log is not None:
            log(f"imitation: {len(demos.obs)} generations of {cfg.imitate} on "
                f"{len(problems)} problems x {len(cfg.init_modes)} start modes, "
                f"{time.perf_counter() - t_bc:.0f} s")
        if fit_bc:
            torch.manual_seed(cfg.seed * 100_003 - 1)
            imitation_rows = pretrain(
                model, demos, epochs=cfg.imitate_epochs, batch=cfg.imitate_batch,
                lr=cfg.imitate_lr, vf_coef=cfg.vf_coef, max_grad_norm=cfg.max_grad_norm,
                seed=cfg.seed, log=log)
        del demos
    if not resumed and (cfg.init_checkpoint or imitation_rows):
        # the warm-started policy is a checkpoint of its own (0 PPO epochs), and resumable
        _save(out, model, optimizer, cfg, specs, curve, 0, scaler, imitation_rows)
    # the behaviour-cloning anchor's reference: the warm start, frozen (epoch 0's weights)
    reference = None
    if cfg.bc_coef > 0:
        reference = TorchPolicy(cfg.net)
        if resumed:
            reference.load_state_dict(state["reference"])
        else:
            reference.load_state_dict(model.state_dict())
        reference.requires_grad_(False)
    G = max(1, math.ceil((cfg.budget - cfg.population) / cfg.population))
    chunks = [list(range(i, min(i + cfg.envs, len(problems))))
              for i in range(0, len(problems), cfg.envs)]
    total = len(chunks) * G * cfg.epochs

    for epoch in range(start_epoch, cfg.epochs):
        t0 = time.perf_counter()
        order_rng = np.random.default_rng([cfg.seed, epoch])
        torch.manual_seed(cfg.seed * 100_003 + epoch)
        # a random order, then grouped by dimension (stable), so that a chunk mixes sizes only
        # where the counts force it and little is padded
        order = sorted(order_rng.permutation(len(problems)).tolist(),
                       key=lambda i: len(problems[i].lower))
        returns_ep, feasible_ep, score_ep, stats_ep = [], [], [], []
        for c, chunk in enumerate(chunks):
            idx = [int(order[i]) for i in chunk]
            # one job per episode of the chunk; the rollouts run behind the executor
            jobs = [rollout.SegmentJob(
                key=rollout.EpisodeKey(cfg.seed, epoch, c * cfg.envs + k),
                spec=portable[i], init=cfg.init_modes[(epoch + c + k) % len(cfg.init_modes)],
                population=cfg.population, budget=cfg.budget, eta=cfg.eta, delta=cfg.delta,
                n_steps=cfg.n_steps, net=cfg.net.to_dict(), weights={})
                for k, i in enumerate(idx)]
            # reward-scaling keys: problem and start mode; a new episode restarts its return
            keys = [f"{names[i]}/{job.init}" for i, job in zip(idx, jobs, strict=True)]
            for key in keys:
                scaler.reset(key)
            ep_return = np.zeros(len(jobs))
            g = 0
            while True:
                # ---- rollout: up to n generations per episode (Algorithm 1, lines 6-11)
                weights = model.numpy_params()
                for job in jobs:
                    job.weights = weights
                segs = rollout.collect(executor, jobs)
                T = segs[0].steps
                if any(s.steps != T for s in segs) or len({s.done for s in segs}) > 1:
                    raise RuntimeError("episodes of one chunk ran out of step (same budget and "
                                       "population should give the same generations)")
                buf_obs = [batch_obs([s.obs(t) for s in segs]) for t in range(T)]
                rew = np.stack([s.rewards for s in segs], axis=1)  # (T, B)
                ep_return += rew.sum(axis=0)
                g += T
                if progress is not None:
                    progress(epoch * len(chunks) * G + c * G + min(g, G), total,
                             f"epoch {epoch + 1}/{cfg.epochs} chunk {c + 1}/{len(chunks)}")
                # ---- n-step PPO update (Algorithm 1, lines 12-15)
                values = np.stack([s.values for s in segs], axis=1)
                dones = np.stack([s.dones for s in segs], axis=1)
                next_values = np.array([s.next_value for s in segs])
                if cfg.credit == "individual":
                    # the critic learns the population credit's return; each individual's
                    # advantage is its own trial's credit plus a small population term
                    pop = np.stack([s.population_credit for s in segs], axis=1)  # (T, B)
                    adv_pop = gae(pop, values, dones, next_values, cfg.gamma, cfg.gae_lambda)
                    ret = adv_pop + values
                    ind = individual_advantages(
                        np.stack([s.credits for s in segs], axis=1),
                        np.stack([s.parent_feasible for s in segs], axis=1))  # (T, B, N)
                    adv = ind + cfg.pop_weight * _normalised(adv_pop)[:, :, None]
                else:
                    rewards = rew
                    if cfg.reward_scale:
                        rewards = np.stack([scaler.scale(key, rew[:, b])
                                            for b, key in enumerate(keys)], axis=1)
                    adv = gae(rewards, values, dones, next_values, cfg.gamma, cfg.gae_lambda)
                    ret = adv + values
                acts = np.stack([s.actions for s in segs], axis=1)  # (T, B, N, 4)
                logp = np.stack([s.logp for s in segs], axis=1)  # (T, B, N)
                stats_ep.append(ppo_update(
                    model, optimizer, cfg, _cat_obs(buf_obs),
                    torch.from_numpy(acts.reshape(-1, *acts.shape[2:])),
                    torch.from_numpy(logp.reshape(-1, logp.shape[2])),
                    torch.from_numpy(adv.reshape(-1, *adv.shape[2:]).astype(np.float32)),
                    torch.from_numpy(ret.reshape(-1).astype(np.float32)),
                    reference, cfg.bc_coef * cfg.bc_decay ** epoch,
                ))
                if segs[0].done:
                    break
                for job, s in zip(jobs, segs, strict=True):
                    job.carry = s.carry
            for s, ret_b in zip(segs, ep_return, strict=True):
                returns_ep.append(float(ret_b))
                feasible_ep.append(s.best_phi == 0.0)
                score_ep.append(float(penalised_score(s.best_f, s.best_phi)))
        row = {
            "epoch": epoch + 1,
            "episodes": len(returns_ep),
            "return": float(np.mean(returns_ep)),
            "feasible_rate": float(np.mean(feasible_ep)),
            "best_score": float(np.mean(score_ep)),
            **{k: float(np.mean([s[k] for s in stats_ep])) for k in stats_ep[0]},
            "seconds": time.perf_counter() - t0,
        }
        curve.append(row)
        _save(out, model, optimizer, cfg, specs, curve, epoch + 1, scaler, imitation_rows,
              reference)
        if writer is not None:
            for k, v in row.items():
                if k not in ("epoch", "episodes"):
                    writer.add_scalar(f"train/{k}", v, epoch + 1)
            writer.flush()
        if log is not None:
            log(f"epoch {epoch + 1}/{cfg.epochs}: return {row['return']:.3f}, feasible "
                f"{row['feasible_rate']:.2f}, score {row['best_score']:.1f}, "
                f"policy loss {row['policy_loss']:.4f}, value loss {row['value_loss']:.4f}, "
                f"entropy {row['entropy']:.3f}, KL {row['approx_kl']:.4f}, "
                f"{row['seconds']:.0f} s")
    if writer is not None:
        writer.close()
    return out


def curve_csv(curve: list[dict[str, Any]]) -> str:
    """The training curve as CSV text (one row per epoch, columns CURVE_FIELDS).

    Args:
        curve: the epochs' rows (each holding every field of CURVE_FIELDS).

    Returns:
        The CSV text with a header; floats written with 6 significant digits.
    """
    return _rows_csv(curve, CURVE_FIELDS)


#: columns of imitation.csv, the warm start's curve (one row per pass over the demonstrations)
IMITATION_FIELDS = ("epoch", "nll", "value_loss", "seconds")


def _rows_csv(rows: list[dict[str, Any]], fields: tuple[str, ...]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(fields), lineterminator="\n")
    w.writeheader()
    for row in rows:
        w.writerow({k: (f"{row[k]:.6g}" if isinstance(row[k], float) else row[k])
                    for k in fields})
    return buf.getvalue()


#: the entries of a training state (state.pt, written by `_save`) that `train` reads back
STATE_KEYS = ("model", "optimizer", "epoch", "curve", "config", "specs")


#: the only pickled globals a training state may name beyond weights_only's own (numpy
#: scalars and their dtypes)
_STATE_GLOBALS = [(np._core if hasattr(np, "_core") else np.core).multiarray.scalar, np.dtype,
                  *(type(np.dtype(c)) for c in "?bBhHiIlLqQefdg")]


def _load_state(path: Path) -> dict[str, Any]:
    """The training state `_save` wrote to `path` (state.pt), for ``resume``; one that torch
    cannot read (cut short, damaged) or that lacks an entry of `STATE_KEYS` is a CheckpointError
    naming the file (nothing is written before it is read). Read with ``weights_only=True``:
    tensors, containers, numbers and strings, all a training state holds, and no pickled
    object that would run code (a state.pt from elsewhere)."""
    from planner_core.textio import printable

    try:
        # numpy scalars (the curve's figures) are rebuilt from their dtype and bytes, nothing
        # more; every other global stays refused
        with torch.serialization.safe_globals(_STATE_GLOBALS):
            state = torch.load(path, weights_only=True)
    except Exception as exc:  # torch's zip reader, pickle, EOF: each its own exception
        why = printable(str(exc).split("\n")[0].split(". ")[0])[:200] or type(exc).__name__
        raise ckpt.CheckpointError(f"--resume: {path}: not a readable training state ({why}); "
                                   "it was cut short, damaged, or holds objects other than "
                                   "tensors, numbers and strings") from None
    missing = [k for k in STATE_KEYS if not isinstance(state, dict) or k not in state]
    if missing:
        raise ckpt.CheckpointError(f"--resume: {path}: not a training state (no "
                                   f"{', '.join(missing)})")
    return state


def _save(out: Path, model: TorchPolicy, optimizer: torch.optim.Optimizer, cfg: PPOConfig,
          specs: list[dict[str, Any]], curve: list[dict[str, Any]], epoch: int,
          scaler: RewardScaler, imitation_rows: list[dict[str, float]],
          reference: TorchPolicy | None = None) -> None:
    manifest = {"problems": specs, "names": [spec_name(s) for s in specs]}
    meta = {"ppo": cfg.to_dict(), "epochs_done": epoch, "eta": cfg.eta,
            "seconds": float(sum(r["seconds"] for r in curve)
                             + sum(r["seconds"] for r in imitation_rows)),
            "imitation": imitation_rows}
    ckpt.save(out, model.numpy_params(), cfg.net, meta, {
        "manifest.json": json.dumps(manifest, indent=2) + "\n",
        "curve.csv": curve_csv(curve),
        "imitation.csv": _rows_csv(imitation_rows, IMITATION_FIELDS),
    })
    buf = io.BytesIO()
    torch.save({"model": model.state_dict(), "optimizer": optimizer.state_dict(),
                "epoch": epoch, "curve": curve, "config": cfg.to_dict(), "specs": specs,
                "scaler": scaler.state_dict(), "imitation": imitation_rows,
                "reference": None if reference is None else reference.state_dict()}, buf)
    write_bytes_atomic(out / "state.pt", buf.getvalue())


def text_progress(stream: Any = None, width: int = 24) -> Callable[[int, int, str], None]:
    """A progress bar on one updating line (TTY, at most every 0.2 s) or a line per 5 %
    otherwise, with elapsed and estimated remaining seconds.

    Args:
        stream: the text stream (None: the sys.stderr of the call, not of the import).
        width: the bar's width in characters.

    Returns:
        ``show(done, total, text)``, the callback `train` takes as ``progress``.
    """
    stream = sys.stderr if stream is None else stream
    tty = bool(getattr(stream, "isatty", lambda: False)())
    state = {"last": -1.0, "t0": time.monotonic()}

    def show(done: int, total: int, text: str) -> None:
        frac = done / max(total, 1)
        if not tty and frac - state["last"] < 0.05 and done < total:
            return
        if tty and time.monotonic() - state.get("shown", 0.0) < 0.2 and done < total:
            return
        state["last"], state["shown"] = frac, time.monotonic()
        fill = int(round(frac * width))
        el = time.monotonic() - state["t0"]
        eta = el / frac - el if frac > 0 else float("nan")
        line = f"[{'#' * fill}{'.' * (width - fill)}] {100 * frac:5.1f}% {text}  " \
               f"{el:6.0f} s elapsed, ~{eta:5.0f} s left"
        stream.write(("\r" + line + ("\n" if done >= total else "")) if tty else line + "\n")
        stream.flush()

    return show


__all__ = [
    "CURVE_FIELDS",
    "PPOConfig",
    "TorchPolicy",
    "batch_obs",
    "clipped_objective",
    "curve_csv",
    "gae",
    "imitation_loss",
    "kl_from_reference",
    "log_prob_entropy",
    "ppo_update",
    "pretrain",
    "text_progress",
    "train",
    "with_context",
]
