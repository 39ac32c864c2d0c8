"""Training LAMDE-S's learned policy (issue 34, part 1): behaviour cloning of the default
scheduler, then PPO over the improving stage's macro-decisions. Torch lives here; the actors
(`planner_core.learning.schedule_policy.rollout`) are numpy and run behind the executor.

One readable loop (:func:`train`), CleanRL's discrete PPO with one `Args` object:

    cases = generated maps x plan seeds                  # `Args.maps`, `Args.seeds`
    demos = the default scheduler on every case          # actors; also each case's reference
    behaviour cloning: actor by cross-entropy on the     # the warm start: the policy starts
      demos' (observation, action), label-smoothed, and  #   as the default (`bc_epochs`),
      the critic on their returns-to-go; mu / sd of the  #   `bc_smoothing` off its choice
      demos' observations
    for iteration 1..I:
        sample `episodes` cases, one episode each,       # actors, actions sampled from pi
          with the current weights
        advantages: the default's return-to-go on the    # the paired baseline
          same case up to the first departure from its   #   (`advantages`); the episode's
          actions, then GAE(gamma, lambda)               #   end is terminal
        `update_epochs` of PPO on minibatches            # clipped ratio, value loss, entropy,
                                                         #   plus `bc_coef` x the demos' CE
        log the mean return beside the default's on the same cases, and the mean f
          against the default's

Reward (the env's; `Args.reference`): by default "percent", each action's gain in f in percent
of the stage's starting f (bounded; the env's "default" unit, the share of the gap the default
closes on the case, explodes on cases where the default closes almost none). The paired
baseline is reported: each iteration's episodes against the default's f and return on the
same cases (the demonstrations).

    python -m planner_core.learning.schedule_ppo -o DIR [--maps 48 | --maps-file picks.json]
        [--seeds 2] [--iterations 20] [--episodes 32] [--jobs 1] [--seed 0] ...

(every `Args` field is an option; the shipped checkpoint's command, which differs from these
defaults, is in its manifest.json and in docs/scheduler.md)

writes DIR/weights.npz and DIR/manifest.json (`schedule_policy.save`; the arguments, the
command, the training's CPU seconds and its curve per iteration).

Cost: an episode is one improving stage and the stages after it (~0.3-0.5 s on a paper-size map
at 10,000 evaluations once the case's prefix is cached in the worker; the first visit also runs
the prefix and the default's rest, ~1 s); an update is a few thousand (F x H) products.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

try:
    import torch
    from torch import nn
except ImportError as exc:  # missing, or a broken install (a library it cannot load)
    if __name__ != "__main__":
        raise
    # the command line (`python -m ...`) without torch: one line and status 2, as
    # `lamde-mission train` says it, not the import's traceback
    _why = "" if getattr(exc, "name", None) == "torch" else f" ({exc})"
    sys.stderr.write(f"schedule_ppo: needs torch{_why}: pip install 'lamde-mission[train]'"[:300]
                     + "\n")
    raise SystemExit(2) from None

__all__ = ["Args", "train"]


@dataclass
class Args:
    """Every setting of a training run (CleanRL's one Args object)."""

    output: str = "lamde-s-ppo"
    #: generated training maps (`planner_core.suite.generated_maps`) and their first seed
    maps: int = 48
    map_seed: int = 5000
    #: a `planner_core.learning.lam.maps` choice (JSON) to train on instead (its maps)
    maps_file: str = ""
    #: plan seeds per map (0..seeds-1 offset by `plan_seed`)
    seeds: int = 2
    plan_seed: int = 100
    budget: int = 10_000
    hidden: int = 64
    #: full-batch Adam steps of behaviour cloning (at 10 x `lr`)
    bc_epochs: int = 400
    #: the least standard deviation the features are scaled by: a feature that never varies
    #: in the demonstrations (the gain of an action the default never takes) would otherwise
    #: reach the first layer at hundreds of its units once it varies (the shipped checkpoint
    #: was trained with 0.001)
    sd_floor: float = 0.1
    #: label smoothing of the cloning's cross-entropy: the warm start keeps about this much
    #: probability off the default's choice, so PPO's sampled episodes explore
    bc_smoothing: float = 0.2
    iterations: int = 20
    episodes: int = 32
    update_epochs: int = 4
    minibatch: int = 64
    lr: float = 3e-4
    clip: float = 0.2
    gamma: float = 1.0
    gae_lambda: float = 0.95
    ent_coef: float = 0.01
    vf_coef: float = 0.5
    bc_coef: float = 0.1
    max_grad_norm: float = 0.5
    #: the env's reward unit: "percent" (1 % of the stage's starting f; bounded) or
    #: "default" (the gap the default closes on the case; unbounded where it closes ~none)
    reference: str = "percent"
    #: the paired baseline (the default's return-to-go on the same case up to the first
    #: departure from its actions, `advantages`); False: the critic's GAE throughout
    paired: bool = True
    #: every this many iterations (and at the last), the greedy policy on every training case
    #: (0: never)
    eval_every: int = 10
    jobs: int = 1
    seed: int = 0


class Agent(nn.Module):
    """The torch twin of `schedule_policy.forward` (same arrays, same arithmetic)."""

    def __init__(self, params: dict[str, np.ndarray]) -> None:
        super().__init__()
        self.p = nn.ParameterDict({k: nn.Parameter(torch.tensor(v, dtype=torch.float64))
                                   for k, v in params.items() if k not in ("mu", "sd")})
        self.register_buffer("mu", torch.tensor(params["mu"], dtype=torch.float64))
        self.register_buffer("sd", torch.tensor(params["sd"], dtype=torch.float64))

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Logits and values of a batch of observations (`schedule_policy.forward`'s arithmetic).

        Args:
            x: (n, F) float64 observations.

        Returns:
            (logits (n, A), values (n,)).
        """
        p = self.p
        h = torch.tanh(((x - self.mu) / self.sd) @ p["W1"] + p["b1"])
        h = torch.tanh(h @ p["W2"] + p["b2"])
        return h @ p["Wpi"] + p["bpi"], (h @ p["Wv"] + p["bv"])[:, 0]

    def numpy_params(self) -> dict[str, np.ndarray]:
        """The weights as `schedule_policy` stores them.

        Returns:
            {"mu", "sd", "W1", "b1", "W2", "b2", "Wpi", "bpi", "Wv", "bv"}: float64 copies.
        """
        out = {k: v.detach().numpy().copy() for k, v in self.p.items()}
        out["mu"], out["sd"] = self.mu.numpy().copy(), self.sd.numpy().copy()
        return out


def gae(rewards: np.ndarray, values: np.ndarray, gamma: float, lam: float) -> np.ndarray:
    """Generalised advantage estimates of one episode that ends in a terminal state
    (`planner_core.learning.policy.ppo.gae` on a single column, done at the last step).

    Args:
        rewards: (T,) rewards.
        values: (T,) V of each step's state.
        gamma: discount.
        lam: GAE lambda.

    Returns:
        (T,) advantages.
    """
    from planner_core.learning.policy.ppo import gae as segment_gae

    r = np.asarray(rewards, dtype=float)[:, None]
    done = np.zeros_like(r)
    done[-1:] = 1.0
    return segment_gae(r, np.asarray(values, dtype=float)[:, None], done, np.zeros(1), gamma,
                       lam)[:, 0]


def advantages(episode: dict[str, Any], demo: dict[str, Any], args: Args
               ) -> tuple[np.ndarray, np.ndarray]:
    """An episode's advantages with the paired baseline, and the critic's targets.

    The env is deterministic given the actions (each action's random stream is its index in
    the stage), so up to and including the first decision where the episode leaves the
    default's actions, its state is the demonstration's state at that step, and the
    demonstration's return-to-go there is a baseline that depends on the state only
    (unbiased, and exact for the default's action): A_t = G_t - G_t(default). After the
    first departure the critic's GAE (`Args.gae_lambda`) is used. With `Args.paired` False,
    GAE throughout.

    Args:
        episode, demo: `schedule_policy.rollout` results on the same case (demo: the default
            scheduler's); args: gamma, gae_lambda, paired.

    Returns:
        (advantages (T,), returns for the critic (T,)).
    """
    r, v = episode["rewards"], episode["values"]
    g = _returns_to_go(r, args.gamma)
    adv = gae(r, v, args.gamma, args.gae_lambda)
    if args.paired:
        a, d = episode["actions"], demo["actions"]
        same = 0
        while same < min(len(a), len(d)) and a[same] == d[same]:
            same += 1
        k = min(same + 1, len(a), len(d))  # through the first departure
        adv[:k] = g[:k] - _returns_to_go(demo["rewards"], args.gamma)[:k]
    return adv, g


def _cases(args: Args) -> list[dict[str, Any]]:
    import json

    from planner_core.suite import generate_map, generated_maps

    if args.maps_file:
        try:
            picks = json.loads(Path(args.maps_file).read_text())["maps"]
        except (OSError, KeyError, TypeError, json.JSONDecodeError) as exc:
            raise ValueError(f"maps_file: cannot read {args.maps_file}: {exc}") from None
        if not isinstance(picks, list) or not picks:
            raise ValueError(f"maps_file: {args.maps_file}: 'maps' must be a non-empty list")
        maps = []
        for i, p in enumerate(picks):
            try:
                maps.append((str(p["name"]), generate_map(int(p["size"]), int(p["density"]),
                                                          int(p["seed"]))))
            except (KeyError, TypeError, ValueError) as exc:
                raise ValueError(f"maps_file: {args.maps_file}: entry {i}: {exc}") from None
    else:
        maps = generated_maps(args.maps, args.map_seed)
    return [{"map": data, "key": name, "plan_seed": args.plan_seed + s, "budget": args.budget,
             "reference": args.reference} for name, data in maps for s in range(args.seeds)]


def _run(executor: Any, jobs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    from planner_core.learning.schedule_policy import rollout

    out = list(executor.map_unordered(rollout, jobs))
    return sorted(out, key=lambda r: (r["key"], r["plan_seed"]))


def _returns_to_go(rewards: np.ndarray, gamma: float) -> np.ndarray:
    """G_t = sum_k gamma^k r_(t+k) of one episode (GAE with lambda 1 and no values)."""
    return gae(rewards, np.zeros(len(rewards)), gamma, 1.0)


#: (field, least, greatest, least included, greatest included) of the numeric settings
_RANGES = (
    ("maps", 1, None, True, True), ("seeds", 1, None, True, True),
    ("plan_seed", 0, None, True, True), ("map_seed", 0, None, True, True),
    ("budget", 1, None, True, True), ("hidden", 1, None, True, True),
    ("bc_epochs", 0, None, True, True), ("bc_smoothing", 0.0, 1.0, True, False),
    ("iterations", 0, None, True, True), ("episodes", 1, None, True, True),
    ("update_epochs", 1, None, True, True), ("minibatch", 1, None, True, True),
    ("lr", 0.0, None, False, True), ("clip", 0.0, None, False, True),
    ("gamma", 0.0, 1.0, False, True), ("gae_lambda", 0.0, 1.0, True, True),
    ("ent_coef", 0.0, None, True, True), ("vf_coef", 0.0, None, True, True),
    ("bc_coef", 0.0, None, True, True), ("max_grad_norm", 0.0, None, False, True),
    ("sd_floor", 0.0, None, False, True), ("eval_every", 0, None, True, True),
    ("jobs", 0, None, True, True), ("seed", 0, None, True, True),
)


def check(args: Args) -> None:
    """Every setting in its range, the reference known, the output writable (its folder is
    created by `save` at the end).

    Args:
        args: the training's settings.

    Raises:
        ValueError: one line naming the field ("lr: must be > 0, got -1.0"); an unwritable
            output folder as "output: ...".
    """
    import math
    import os

    from planner_core.atomic import check_writable

    for name, lo, hi, lo_in, hi_in in _RANGES:
        v = getattr(args, name)
        bad = not math.isfinite(v) or (v < lo if lo_in else v <= lo) or (
            hi is not None and (v > hi if hi_in else v >= hi))
        if bad:
            span = f"{'>=' if lo_in else '>'} {lo}" + (
                "" if hi is None else f" and {'<=' if hi_in else '<'} {hi}")
            raise ValueError(f"{name}: must be {span}, got {v}")
    if args.reference not in ("default", "percent"):
        raise ValueError(f"reference: must be 'default' or 'percent', got {args.reference!r}")
    out = Path(args.output)
    if out.is_dir():
        check_writable(out / "weights.npz", what="output")
        return
    probe = out
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir() or not os.access(probe, os.W_OK | os.X_OK):
        raise ValueError(f"output: {out}: {probe} is not a folder this process can write in")


def train(args: Args, progress: Any = None) -> dict[str, Any]:
    """Behaviour cloning then PPO (module docstring); writes the checkpoint to `args.output`.

    Args:
        args: the run's settings.
        progress: called with one line of text per phase and iteration (None: silent).

    Returns:
        The manifest written (curve, CPU seconds, command).

    Raises:
        ValueError: one line naming the setting for a bad count or rate.
    """
    from planner_core.execution.local import make_executor
    from planner_core.learning.schedule_env import FEATURES
    from planner_core.learning.schedule_policy import init_params, save
    from planner_core.pipeline.schedule import ACTIONS

    check(args)
    say = progress or (lambda line: None)
    torch.manual_seed(args.seed)
    rng = np.random.default_rng(args.seed)
    cases = _cases(args)
    t0, cpu0 = time.perf_counter(), time.process_time()
    actor_seconds = 0.0
    with make_executor(args.jobs) as ex:
        # ---- demonstrations: the default scheduler on every case
        demos = _run(ex, [dict(c, params=None, sample_seed=None) for c in cases])
        actor_seconds += sum(d["cpu"] for d in demos)
        d_obs = np.concatenate([d["obs"] for d in demos])
        d_act = np.concatenate([d["actions"] for d in demos])
        d_ret = np.concatenate([_returns_to_go(d["rewards"], args.gamma) for d in demos])
        f_default = {(d["key"], d["plan_seed"]): d["f"] for d in demos}
        d_return = {(d["key"], d["plan_seed"]): float(d["rewards"].sum()) for d in demos}
        demo_by_case = {(d["key"], d["plan_seed"]): d for d in demos}
        say(f"demos: {len(demos)} episodes, {len(d_obs)} decisions, "
            f"{time.perf_counter() - t0:.0f} s")
        params = init_params(len(FEATURES), len(ACTIONS), args.hidden, args.seed)
        params["mu"] = d_obs.mean(axis=0).astype(float)
        params["sd"] = np.maximum(d_obs.std(axis=0).astype(float), args.sd_floor)
        agent = Agent(params)
        opt = torch.optim.Adam(agent.parameters(), lr=args.lr * 10, eps=1e-5)
        Xd = torch.tensor(d_obs, dtype=torch.float64)
        Ad = torch.tensor(d_act)
        Rd = torch.tensor(d_ret)
        # ---- behaviour cloning (actor) and the critic on the demos' returns-to-go
        for _ in range(args.bc_epochs):
            logits, v = agent(Xd)
            loss = (nn.functional.cross_entropy(logits, Ad, label_smoothing=args.bc_smoothing)
                    + args.vf_coef * ((v - Rd) ** 2).mean())
            opt.zero_grad()
            loss.backward()
            opt.step()
        with torch.no_grad():
            acc = float((agent(Xd)[0].argmax(1) == Ad).double().mean())
        say(f"behaviour cloning: {acc * 100:.1f} % of the default's decisions")
        curve: list[dict[str, Any]] = [{"iteration": 0, "bc_accuracy": acc}]
        for g in opt.param_groups:
            g["lr"] = args.lr
        # ---- PPO
        for it in range(1, args.iterations + 1):
            pick = rng.choice(len(cases), size=min(args.episodes, len(cases)), replace=False)
            weights = agent.numpy_params()
            jobs = [dict(cases[i], params=weights, sample_seed=int(rng.integers(2**31 - 1)))
                    for i in pick]
            eps = [e for e in _run(ex, jobs) if len(e["actions"])]
            actor_seconds += sum(e["cpu"] for e in eps)
            adv, ret = [], []
            for e in eps:
                a, g = advantages(e, demo_by_case[e["key"], e["plan_seed"]], args)
                adv.append(a)
                ret.append(g)
            adv = np.concatenate(adv)
            X = torch.tensor(np.concatenate([e["obs"] for e in eps]), dtype=torch.float64)
            A = torch.tensor(np.concatenate([e["actions"] for e in eps]))
            LP = torch.tensor(np.concatenate([e["logp"] for e in eps]))
            R = torch.tensor(np.concatenate(ret))
            ADV = torch.tensor((adv - adv.mean()) / (adv.std() + 1e-8))
            n = len(A)
            for _ in range(args.update_epochs):
                order = torch.tensor(rng.permutation(n))
                for s in range(0, n, args.minibatch):
                    mb = order[s:s + args.minibatch]
                    logits, v = agent(X[mb])
                    logp_all = torch.log_softmax(logits, dim=1)
                    logp = logp_all.gather(1, A[mb][:, None])[:, 0]
                    ratio = torch.exp(logp - LP[mb])
                    pg = torch.max(-ADV[mb] * ratio,
                                   -ADV[mb] * torch.clamp(ratio, 1 - args.clip, 1 + args.clip))
                    ent = -(logp_all.exp() * logp_all).sum(1).mean()
                    loss = pg.mean() - args.ent_coef * ent + args.vf_coef * (
                        (v - R[mb]) ** 2).mean()
                    if args.bc_coef > 0:
                        j = torch.tensor(rng.integers(len(Ad), size=len(mb)))
                        loss = loss + args.bc_coef * nn.functional.cross_entropy(
                            agent(Xd[j])[0], Ad[j], label_smoothing=args.bc_smoothing)
                    opt.zero_grad()
                    loss.backward()
                    nn.utils.clip_grad_norm_(agent.parameters(), args.max_grad_norm)
                    opt.step()
            ret = [float(e["rewards"].sum()) for e in eps]
            rel = [(e["f"] / f_default[e["key"], e["plan_seed"]] - 1.0) * 100.0 for e in eps]
            row = {"iteration": it, "episodes": len(eps), "decisions": n,
                   "mean_return": float(np.mean(ret)),
                   "default_return": float(np.mean([d_return[e["key"], e["plan_seed"]]
                                                    for e in eps])),
                   "f_vs_default_pct": float(np.mean(rel)),
                   "better": int(sum(r < -1e-9 for r in rel)),
                   "worse": int(sum(r > 1e-9 for r in rel)),
                   "infeasible": int(sum(e["phi"] > 0 for e in eps)),
                   "seconds": round(time.perf_counter() - t0, 1)}
            curve.append(row)
            say(f"iteration {it}: return {row['mean_return']:.3f} (default "
                f"{row['default_return']:.3f}), f vs default "
                f"{row['f_vs_default_pct']:+.4f} %, better/worse {row['better']}/"
                f"{row['worse']}, {row['seconds']:.0f} s")
            if args.eval_every and (it % args.eval_every == 0 or it == args.iterations):
                # the greedy policy (what `PolicyScheduler` does) on every training case
                weights = agent.numpy_params()
                greedy = _run(ex, [dict(c, params=weights, sample_seed=None) for c in cases])
                actor_seconds += sum(e["cpu"] for e in greedy)
                rel = np.array([(e["f"] / f_default[e["key"], e["plan_seed"]] - 1.0) * 100.0
                                for e in greedy])
                row.update(greedy_f_vs_default_pct=float(rel.mean()),
                           greedy_better=int((rel < -1e-9).sum()),
                           greedy_worse=int((rel > 1e-9).sum()),
                           greedy_departures=int(sum(
                               not np.array_equal(e["actions"], demo_by_case[
                                   e["key"], e["plan_seed"]]["actions"]) for e in greedy)))
                say(f"  greedy on the {len(cases)} training cases: f vs default "
                    f"{row['greedy_f_vs_default_pct']:+.4f} %, better/worse "
                    f"{row['greedy_better']}/{row['greedy_worse']}, "
                    f"{row['greedy_departures']} leave the default's actions")
    cpu = time.process_time() - cpu0 + actor_seconds * (args.jobs > 0)
    manifest = {
        "max_points": max(int(r["imax"]) for r in demos), "time_limits": False,
        "cases": len(cases), "maps": sorted({c["key"] for c in cases}),
        "hidden": args.hidden, "actions": list(ACTIONS), "features": list(FEATURES),
        "args": dataclasses.asdict(args), "curve": curve,
        "cpu_seconds": round(cpu, 1), "wall_seconds": round(time.perf_counter() - t0, 1),
        "command": "python -m planner_core.learning.schedule_ppo " + " ".join(
            sys.argv[1:]) if sys.argv and sys.argv[0].endswith("schedule_ppo.py") else "",
    }
    save(args.output, agent.numpy_params(), manifest)
    return manifest


def _flag(text: str) -> bool:
    if text.lower() in ("1", "true", "yes", "on"):
        return True
    if text.lower() in ("0", "false", "no", "off"):
        return False
    raise argparse.ArgumentTypeError(f"must be true or false, got {text!r}")


def main(argv: list[str] | None = None) -> int:
    """The command line (module docstring): every `Args` field is an option; trains and writes
    the checkpoint.

    Args:
        argv: the arguments (None: ``sys.argv[1:]``).

    Returns:
        The exit status: 0 written, 2 bad arguments (a ValueError of `train`, e.g. a
        setting `check` refuses, or a `NoImprovingStageError`; one line on stderr). An
        argument argparse refuses exits with status 2 (SystemExit) instead.
    """
    ap = argparse.ArgumentParser(prog="python -m planner_core.learning.schedule_ppo",
                                 description="train LAMDE-S's policy: behaviour cloning of "
                                 "the default scheduler, then PPO")
    ap.add_argument("-o", "--output", required=True, help="checkpoint folder to write")
    for f in dataclasses.fields(Args):
        if f.name != "output":
            kind = _flag if isinstance(f.default, bool) else type(f.default)
            ap.add_argument("--" + f.name.replace("_", "-"), type=kind,
                            default=f.default, help=f"(default {f.default})")
    ns = ap.parse_args(argv)
    args = Args(**vars(ns))
    from planner_core.learning.schedule_env import NoImprovingStageError

    try:
        m = train(args, progress=lambda line: print(line, file=sys.stderr, flush=True))
    except (ValueError, NoImprovingStageError) as exc:
        print(f"schedule_ppo: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {args.output}: {m['cpu_seconds'] / 3600:.2f} CPU-h")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
