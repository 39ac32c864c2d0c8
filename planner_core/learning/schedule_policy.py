"""LAMDE-S's learned policy (issue 34, part 1): an MLP over the scheduling MDP's observation
(`planner_core.learning.schedule_env.FEATURES`) that names the improving stage's next
macro-action, trained by `planner_core.learning.schedule_ppo` (behaviour cloning of the default
scheduler, then PPO). Numpy only: planning with it needs no torch.

Network (actor-critic, shared trunk): x -> (x - mu) / sd -> tanh(W1 x + b1) -> tanh(W2 h +
b2) -> logits over `schedule.ACTIONS` (Wpi, bpi) and a value V(s) (Wv, bv), as CleanRL's
discrete PPO agent with a shared body. `mu` and `sd` are the feature statistics of the
behaviour-cloning data, stored with the weights.

A checkpoint is a folder: `weights.npz` (the arrays above, float64) and `manifest.json` (the
hidden width, the action and feature names it was trained with, the training command, its
CPU time and curve). `PolicyScheduler` (`--scheduler lamde-s-ppo`) acts greedily (the
most probable action) and stops after `schedule.IDLE_ROUNDS` idle actions as every scheduler.

Cost per decision: the features (`ScheduleFeatures`: one breakdown, O(I x J)) and two F x H
and H x H products (microseconds).
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["DEFAULT_CHECKPOINT", "PolicyScheduler", "forward", "init_params", "load", "save"]

#: the shipped checkpoint (`--scheduler lamde-s-ppo`)
DEFAULT_CHECKPOINT = Path(__file__).resolve().parent / "checkpoints" / "lamde-s-ppo"
_NAMES = ("mu", "sd", "W1", "b1", "W2", "b2", "Wpi", "bpi", "Wv", "bv")


def init_params(n_features: int, n_actions: int, hidden: int = 64, seed: int = 0
                ) -> dict[str, np.ndarray]:
    """Orthogonal initial weights (gain sqrt 2 for the trunk, 0.01 for the logits, 1 for the
    value; CleanRL's `layer_init`), zero biases, mu 0 and sd 1.

    Args:
        n_features: F, the observation's length; n_actions: A; hidden: H; seed: the draw's.

    Returns:
        {"mu" (F,), "sd" (F,), "W1" (F, H), "b1" (H,), "W2" (H, H), "b2" (H,), "Wpi" (H, A),
        "bpi" (A,), "Wv" (H, 1), "bv" (1,)}.
    """
    rng = np.random.default_rng(seed)

    def ortho(n_in: int, n_out: int, gain: float) -> np.ndarray:
        q, r = np.linalg.qr(rng.standard_normal((max(n_in, n_out), min(n_in, n_out))))
        q = q * np.sign(np.diag(r))
        w = q if n_in >= n_out else q.T
        return gain * w[:n_in, :n_out]

    return {"mu": np.zeros(n_features), "sd": np.ones(n_features),
            "W1": ortho(n_features, hidden, np.sqrt(2)), "b1": np.zeros(hidden),
            "W2": ortho(hidden, hidden, np.sqrt(2)), "b2": np.zeros(hidden),
            "Wpi": ortho(hidden, n_actions, 0.01), "bpi": np.zeros(n_actions),
            "Wv": ortho(hidden, 1, 1.0), "bv": np.zeros(1)}


def forward(params: dict[str, np.ndarray], x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Logits and values of observations.

    Args:
        params: the network (`init_params`'s keys); x: observations (n, F) or (F,).

    Returns:
        (logits (n, A), values (n,)); a 1-d x gives n = 1.
    """
    p = params
    z = (np.atleast_2d(np.asarray(x, dtype=float)) - p["mu"]) / p["sd"]
    h = np.tanh(z @ p["W1"] + p["b1"])
    h = np.tanh(h @ p["W2"] + p["b2"])
    return h @ p["Wpi"] + p["bpi"], (h @ p["Wv"] + p["bv"])[:, 0]


def save(folder: str | Path, params: dict[str, np.ndarray], manifest: dict[str, Any]) -> None:
    """Write `weights.npz` and `manifest.json` into `folder` (created), each through a
    temporary file and a rename; the manifest records the weights' sha256 (`load` checks it).

    Args:
        folder: the checkpoint folder.
        params: the network (`init_params`'s keys; stored as float64).
        manifest: JSON-able metadata (hidden width, action and feature names, command, ...).

    Raises:
        OSError: the folder cannot be written.
    """
    from planner_core.learning import npz_manifest

    # the manifest names its weights, so a crash between the two writes is caught at `load`
    npz_manifest.save(folder, "weights.npz",
                      {k: np.asarray(params[k], dtype=np.float64) for k in _NAMES},
                      "manifest.json", manifest)


def load(folder: str | Path) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Read a checkpoint folder written by `save`.

    Args:
        folder: the checkpoint folder.

    Returns:
        (params, manifest).

    Raises:
        ValueError: one line naming the checkpoint when a file is missing or damaged, an
            array is missing or misshaped, the weights are not those the manifest names, its
            max_points is not a whole number, or it was trained on other actions or features
            than today's.
    """
    import zipfile

    from planner_core.learning.npz_manifest import check_digest
    from planner_core.learning.schedule_env import FEATURES
    from planner_core.pipeline.schedule import ACTIONS
    from planner_core.textio import InputError, printable, read_bytes, read_json

    folder = Path(folder)
    # the shared reader: regular files only (a FIFO never blocks), bounded size and depth
    for name in ("manifest.json", "weights.npz"):
        try:
            if name == "manifest.json":
                manifest = read_json(folder / name)
            else:
                raw = read_bytes(folder / name)
        except InputError as exc:
            raise ValueError(f"checkpoint: cannot read {printable(folder / name)}: {exc}") from None
    try:
        with np.load(io.BytesIO(raw), allow_pickle=False) as z:
            params = {k: np.asarray(z[k], dtype=float) for k in _NAMES}
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise ValueError(f"checkpoint: cannot read {folder}: {exc}") from None
    if not isinstance(manifest, dict):
        raise ValueError(f"checkpoint: {folder}/manifest.json: must be a JSON object")
    stale = check_digest(raw, manifest, "weights.npz", "manifest.json")
    if stale:
        raise ValueError(f"checkpoint: {folder}: {stale}")
    mp = manifest.get("max_points")
    if mp is not None and (not isinstance(mp, int) or isinstance(mp, bool) or mp < 1):
        raise ValueError(f"checkpoint: {folder}: max_points must be a whole number >= 1, "
                         f"got {mp!r}")
    if tuple(manifest.get("actions", ())) != ACTIONS:
        raise ValueError(f"checkpoint: {folder} was trained on actions "
                         f"{manifest.get('actions')}, not today's {list(ACTIONS)}")
    if tuple(manifest.get("features", ())) != FEATURES:
        raise ValueError(f"checkpoint: {folder} was trained on other features than today's "
                         f"{len(FEATURES)}")
    F, A = len(FEATURES), len(ACTIONS)
    H = params["W1"].shape[1] if params["W1"].ndim == 2 else -1
    want = {"mu": (F,), "sd": (F,), "W1": (F, H), "b1": (H,), "W2": (H, H), "b2": (H,),
            "Wpi": (H, A), "bpi": (A,), "Wv": (H, 1), "bv": (1,)}
    bad = [k for k, s in want.items() if params[k].shape != s]
    if bad or H < 1:
        raise ValueError(f"checkpoint: {folder}: misshaped arrays {bad}")
    return params, manifest


_SHIPPED: dict[tuple[str, int | None], tuple[dict[str, np.ndarray], dict[str, Any]]] = {}


class PolicyScheduler:
    """`--scheduler lamde-s-ppo`: the learned policy's most probable action at each decision
    (`forward` on `ScheduleFeatures` of the observation); "stop" after `IDLE_ROUNDS` idle
    actions, as every scheduler.

    Beyond the sizes it was trained on (I_max, `Problem.hover_limit`, above the manifest's
    "max_points") it follows `DefaultScheduler`: the features of a larger map lie outside the
    training data, and there the default's rebuilding rounds are measured (docs/scheduler.md).

    Args:
        checkpoint: a folder written by `save` (None: the shipped `DEFAULT_CHECKPOINT`).
        params: weights to use instead of a checkpoint (training's own evaluation).
        max_points: the largest I_max it acts on (with `params`; a checkpoint's manifest
            says its own); None: every size.
        deadline: whether it was trained with time limits (a checkpoint's manifest says,
            "time_limits", default False); if not, its time-left feature reads 1 whatever
            the run's `--time-limit`.

    Raises:
        ValueError: the checkpoint cannot be read (see `load`).
    """

    name = "lamde-s-ppo"

    def __init__(self, checkpoint: str | Path | None = None,
                 params: dict[str, np.ndarray] | None = None,
                 max_points: int | None = None, deadline: bool = False) -> None:
        if params is None:
            folder = Path(checkpoint or DEFAULT_CHECKPOINT)
            try:  # a folder written again in this process is read again
                stamp = (folder / "weights.npz").stat().st_mtime_ns
            except OSError:
                stamp = None
            key = (str(folder), stamp)
            if key not in _SHIPPED:
                _SHIPPED[key] = load(folder)
            params, manifest = _SHIPPED[key]
            max_points = manifest.get("max_points", max_points)
            deadline = bool(manifest.get("time_limits", False))
        self.params = params
        self.max_points = max_points
        self.deadline = deadline
        self._features: Any = None
        self._default: Any = None

    @classmethod
    def from_checkpoint(cls, folder: str | Path) -> PolicyScheduler:
        """The scheduler of a checkpoint folder (`--scheduler lamde-s-ppo:DIR`).

        Args:
            folder: a folder written by `save`.

        Returns:
            The `PolicyScheduler`.

        Raises:
            ValueError: "scheduler: checkpoint: ..." when the folder does not load (`load`).
        """
        try:
            return cls(checkpoint=folder)
        except ValueError as exc:
            raise ValueError(f"scheduler: {exc}") from None

    def reset(self, problem: Any, config: Any) -> None:
        """Start a stage: new feature memory for `problem`; beyond "max_points" the stage is
        handed to a `DefaultScheduler` (``template`` "default").

        Args:
            problem: the run's `Problem`.
            config: its `PlanConfig` (a time limit is dropped from the features' view when
                the policy was trained without one).
        """
        from planner_core.learning.schedule_env import ScheduleFeatures
        from planner_core.pipeline.schedule import DefaultScheduler

        if not self.deadline and getattr(config, "time_limit", None) is not None:
            # trained without a deadline: the policy reads the run as it was trained (time
            # left 1), so a --time-limit that does not bind leaves the plan unchanged; the
            # deadline still ends the stage
            config = config.replace(time_limit=None)
        self._features = ScheduleFeatures(problem, config)
        self._default = None
        #: "default" when it hands the stage to the default's rounds (recorded in the plan as
        #: `config["scheduler_choice"]`, printed by `plan`), else None
        self.template: str | None = None
        if self.max_points is not None and int(problem.hover_limit) > int(self.max_points):
            # beyond the sizes it was trained on: the default's rounds
            self._default = DefaultScheduler()
            self._default.reset(problem, config)
            self.template = "default"

    def choose(self, observation: Any) -> str:
        """The most probable action of the observation's features.

        Args:
            observation: the improving stage's `schedule.Observation`.

        Returns:
            An action name of `schedule.ACTIONS`: "stop" after `IDLE_ROUNDS` idle actions,
            the default's choice beyond "max_points".
        """
        from planner_core.pipeline.schedule import ACTIONS, IDLE_ROUNDS

        if self._default is not None:
            return self._default.choose(observation)
        x = self._features(observation)
        if observation.idle >= IDLE_ROUNDS:
            return "stop"
        logits, _ = forward(self.params, x)
        return ACTIONS[int(np.argmax(logits[0]))]


# ---------------------------------------------------------------------------- rollouts
_ENVS: dict[tuple[int, int | None, str], Any] = {}


def rollout(job: dict[str, Any]) -> dict[str, Any]:
    """One episode of the scheduling MDP (a training actor's job; numpy only, runs in an
    executor's worker). Each worker keeps one `ScheduleEnv` per budget with `cache`, so a case
    it has seen before starts from a copy of its prefix.

    Args:
        job: {"map": map data (dict), "key": its name, "plan_seed": int, "budget": int,
            "population": int or None, "reference": the env's reward unit ("default" or
            "percent"; default "default"), "params": the policy's weights, or None for the
            default scheduler's choices (a demonstration), "sample_seed": int to sample
            actions from the policy, None to take the most probable}.

    Returns:
        {"key", "plan_seed", "obs" (T, F) float32, "actions" (T,) int, "logp" (T,), "values"
        (T,), "rewards" (T,), "imax" (the map's I_max), "f", "phi", "f_start", "f_reference",
        "seconds" (wall), "cpu" (this process's CPU seconds)}; T counts the
        decisions (a stop forced after `IDLE_ROUNDS` idle actions is not one).
    """
    import time

    from planner_core.learning.schedule_env import ScheduleEnv
    from planner_core.pipeline.schedule import ACTIONS, IDLE_ROUNDS, DefaultScheduler

    t0, c0 = time.perf_counter(), time.process_time()
    budget, reference = int(job["budget"]), job.get("reference", "default")
    where = (budget, job.get("population"), reference)
    env = _ENVS.get(where)
    if env is None:
        env = _ENVS.setdefault(where, ScheduleEnv(None, budget=budget, cache=True,
                                                  population=job.get("population"),
                                                  reference=reference))
    x, info = env.reset(seed=0, options={"map": job["map"], "key": job["key"],
                                         "plan_seed": int(job["plan_seed"])})
    params, seed = job.get("params"), job.get("sample_seed")
    rng = np.random.default_rng(seed) if seed is not None else None
    default = None
    if params is None:
        default = DefaultScheduler(plan_windows=False)  # the env's actions only
        default.reset(env.problem, env.cfg)
    obs, acts, logps, vals, rews = [], [], [], [], []
    done, stop = False, ACTIONS.index("stop")
    while not done:
        seen = env.observation()
        if default is not None:
            a, lp, v = ACTIONS.index(default.choose(seen)), 0.0, 0.0
        else:
            logits, value = forward(params, x)
            z = logits[0] - logits[0].max()
            logp_all = z - np.log(np.exp(z).sum())
            a = (int(rng.choice(len(z), p=np.exp(logp_all))) if rng is not None
                 else int(np.argmax(z)))
            lp, v = float(logp_all[a]), float(value[0])
        if seen.idle >= IDLE_ROUNDS:
            a = stop  # every scheduler's rule, not the policy's decision
            x, r, done, _, step = env.step(a)
            if rews:
                rews[-1] += r
            continue
        obs.append(x)
        acts.append(a)
        logps.append(lp)
        vals.append(v)
        x, r, done, _, step = env.step(a)
        rews.append(r)
    return {"key": job["key"], "plan_seed": int(job["plan_seed"]),
            "obs": np.asarray(obs, dtype=np.float32).reshape(-1, len(x)),
            "actions": np.asarray(acts, dtype=np.int64), "logp": np.asarray(logps),
            "values": np.asarray(vals), "rewards": np.asarray(rews),
            "imax": int(env.problem.hover_limit),
            "f": float(step["f"]), "phi": float(step["phi"]), "f_start": info["f_start"],
            "f_reference": info["f_reference"], "seconds": time.perf_counter() - t0,
            "cpu": time.process_time() - c0}
