"""`lamde-mission train -o OUT`: meta-train the LAMDE policy with PPO (needs torch).

Writes a checkpoint folder OUT every epoch (weights.npz, config.json, manifest.json, curve.csv,
state.pt; TensorBoard scalars under OUT/tb when tensorboard or tensorboardX is installed) that
`plan --configurator lamde` can use through `PolicyConfigurator(checkpoint=OUT)`. The rollouts
run in this process (`--jobs 1`, the default), on a local process pool (`--jobs N`) or on Ray
(`--backend ray [--address ...]`); the learner (torch) stays in this process.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import shlex
import sys
from pathlib import Path

from lamde_mission.commands._common import (
    add_executor_args,
    check_executor_args,
    check_output_folder,
)
from planner_core import defaults as D


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `lamde-mission train` (options, help).

    Args:
        sub: the subcommands of `lamde_mission.cli.build_parser`.

    Returns:
        The command's parser (`build_parser` sets `run` as its `_run`).
    """
    p = sub.add_parser(
        "train",
        help="meta-train the LAMDE policy with PPO and write a checkpoint folder",
        description="Meta-train the meta-level policy (paper Algorithm 1: n-step PPO) on UAV "
        "maps from the suite generator (seeds disjoint from the suite and validation maps) or "
        "on a training-set JSON with a 'problems' list, or on K plain BBOB instances (--bbob, "
        "the ablation LAMDE-O); --fixed-length for LAMDE-F. A checkpoint is written to OUT after "
        "every epoch; --resume continues from it. The DE rollouts (numpy) can run on worker "
        "processes or a Ray cluster (--jobs, --backend), the PPO update stays here. Same seed, "
        "same checkpoint (same machine), whatever the backend and --jobs.",
    )
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="checkpoint folder")
    p.add_argument("--problems", metavar="JSON",
                   help="training-set JSON with a 'problems' list (default: built-in UAV maps)")
    p.add_argument("--maps", type=int, default=8,
                   help="number of built-in training maps when neither --problems nor --bbob "
                   "is given (default %(default)s)")
    p.add_argument("--bbob", type=int, metavar="K",
                   help="train on K plain BBOB instances instead (no landscape-aware module, "
                   "no constraint: the paper's ablation LAMDE-O; functions 1..24 cycled over "
                   "--bbob-dims; default: none, the UAV maps)")
    p.add_argument("--bbob-dims", default="20,40,80", metavar="LIST",
                   help="dimensions of the --bbob problems (default 20,40,80)")
    p.add_argument("--fixed-length", action="store_true",
                   help="fixed-length encoding on the UAV training problems (all I_max hover "
                   "points active; the paper's LAMDE-F; plan with `plan --fixed-length`); "
                   "synthetic problems (lam-pair, bbob) have no hover points and are unchanged")
    h = D.TRAIN_DEFAULTS  # PPOConfig's, read there from the same table
    p.add_argument("--epochs", type=int, help="passes over the training problems (default "
                   f"{h['epochs']}; 0: the warm start alone)")
    p.add_argument("--seed", type=int, help=f"training seed (default {h['seed']})")
    p.add_argument("--envs", type=int, help="problems rolled out together (default "
                   f"{h['envs']})")
    p.add_argument("--population", type=int, help="DE population during training (default "
                   f"{h['population']}; planning uses {D.POPULATION})")
    p.add_argument("--budget", type=int, help="evaluations per training episode, from the "
                   f"population to {D.MAX_BUDGET:,} (default {h['budget']:,})")
    p.add_argument("--init", choices=("uniform", "seeded", "both"), default="both",
                   help="start modes of the training episodes (default both, alternating)")
    p.add_argument("--imitate", metavar="CONFIGURATOR",
                   help="behaviour-cloning warm start: fit the policy to this hand-made "
                   f"configurator's choices before PPO (default {h['imitate']}; 'none' skips "
                   "it)")
    p.add_argument("--imitate-epochs", type=int, metavar="K",
                   help="passes of the warm start over the demonstrations (default "
                   f"{h['imitate_epochs']})")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="any other PPOConfig field (JSON value), e.g. --set lr=1e-3; repeatable "
                   "(default: PPOConfig's, docs/learning.md)")
    p.add_argument("--jobs", type=int, default=1,
                   help="rollout workers (default 1: the rollouts run in this process; N > 1: N "
                   "worker processes, at most --envs busy at a time); with --backend ray and no "
                   "--address: the CPUs of the Ray instance started here (0 = all); ignored "
                   "with --address")
    add_executor_args(p, "rollouts")
    p.add_argument("--resume", action="store_true", help="continue from OUT's last epoch")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p


def _config(args: argparse.Namespace):  # noqa: ANN202 - PPOConfig is imported lazily
    from lamde_mission.errors import UsageError
    from planner_core.learning.policy.network import NetConfig
    from planner_core.learning.policy.ppo import PPOConfig

    kw: dict = {}
    for name in ("epochs", "seed", "envs", "population", "budget"):
        if getattr(args, name) is not None:
            kw[name] = getattr(args, name)
    kw["init_modes"] = ("uniform", "seeded") if args.init == "both" else (args.init,)
    if args.imitate is not None:
        from planner_core.defaults import CONFIGURATORS

        known = sorted(set(CONFIGURATORS) - {"lamde"})
        if args.imitate not in (*known, "none"):
            raise UsageError(f"--imitate: unknown configurator '{args.imitate}' "
                             f"(choose from {', '.join(known)} or none)")
        kw["imitate"] = args.imitate
    if args.imitate_epochs is not None:
        if args.imitate_epochs < 0:
            raise UsageError(f"--imitate-epochs: must be >= 0, got {args.imitate_epochs}")
        kw["imitate_epochs"] = args.imitate_epochs
    fields = {f.name for f in dataclasses.fields(PPOConfig)}
    net_fields = {f.name for f in dataclasses.fields(NetConfig)}
    net_kw: dict = {}
    set_kw: dict = {}  # what --set gave, by its name
    for item in args.set:
        name, sep, value = item.partition("=")
        if not sep:
            raise UsageError(f"--set: '{item}' is not NAME=VALUE")
        try:
            parsed = json.loads(value)
        except json.JSONDecodeError:
            parsed = value
        if name.startswith("net.") and name[4:] in net_fields:
            net_kw[name[4:]] = set_kw[name] = parsed
        elif name in fields and name != "net":
            kw[name] = set_kw[name] = parsed
        else:
            raise UsageError(f"--set: unknown field '{name}' (PPOConfig: "
                             f"{', '.join(sorted(fields))}; network: "
                             f"net.{', net.'.join(sorted(net_fields))})")
    base = PPOConfig()
    for name, value in set_kw.items():
        default = (getattr(base.net, name[4:]) if name.startswith("net.")
                   else getattr(base, name))  # fmt: skip
        _check_set_type(name, value, default)
    try:
        # the network's defaults are PPOConfig's (new trainings read the context)
        cfg = PPOConfig(net=NetConfig(**{**base.net.to_dict(), **net_kw}), **kw)
    except (TypeError, ValueError) as exc:
        raise UsageError(f"--set: {exc}") from None
    for name in ("epochs", "envs", "population", "budget", "n_steps", "update_epochs"):
        least = {"population": D.MIN_POPULATION, "epochs": 0}.get(name, 1)
        if int(getattr(cfg, name)) < least:
            raise UsageError(f"--{name.replace('_', '-')}: must be >= {least}, "
                             f"got {getattr(cfg, name)}")
    if cfg.epochs == 0 and (cfg.imitate == "none" or cfg.imitate_epochs < 1):
        raise UsageError("--epochs: 0 (the warm start alone) needs --imitate and "
                         "--imitate-epochs >= 1")
    try:  # the episodes' runs check it too (`check_run_args`), but only once training started
        D.check_budget(cfg.budget, cfg.population)
    except ValueError as exc:
        raise UsageError(f"--{exc}") from None
    return cfg


def _check_set_type(name: str, value: object, default: object) -> None:
    """UsageError unless a --set value has the field's type (that of its default): a number
    for a number, true/false for a flag, a string for a string, a list for a tuple."""
    from lamde_mission.errors import UsageError

    if default is None:
        return  # an optional field (a path, a checkpoint): the config checks it
    if isinstance(default, bool):
        ok = isinstance(value, bool)
        want = "true or false"
    elif isinstance(default, int | float):
        ok = isinstance(value, int | float) and not isinstance(value, bool) and (
            isinstance(default, float) or float(value).is_integer())
        want = "a number" if isinstance(default, float) else "an integer"
    elif isinstance(default, str):
        ok, want = isinstance(value, str), "a string"
    elif isinstance(default, tuple | list):
        ok, want = isinstance(value, list), "a JSON list"
    else:
        return
    if not ok:
        raise UsageError(f"--set {name}: must be {want} (its default is {default!r}), "
                         f"got {value!r}")


def _need_torch() -> None:
    """UsageError (one line, exit 2) when torch cannot be imported: before anything that
    imports it (the PPO configuration does)."""
    from lamde_mission.errors import UsageError

    try:
        import torch  # noqa: F401
    except ImportError as exc:  # missing, or a broken install (a library it cannot load)
        why = "" if getattr(exc, "name", None) == "torch" else f" ({exc})"
        raise UsageError(f"train needs torch{why}: pip install 'lamde-mission[train]'"[:300]
                         ) from None  # fmt: skip


def run(args: argparse.Namespace) -> int:
    """`train -o OUT`: meta-train the policy with PPO, a checkpoint written every epoch.

    Args:
        args: the parsed options.

    Returns:
        0 when training ends.

    Raises:
        UsageError: torch is missing, a bad option, OUT a file, under a file or not writable,
            an existing checkpoint without --resume, a bad training set, or `ppo.train`
            refuses (one line, exit 2).
    """
    from lamde_mission.errors import UsageError

    _need_torch()
    cfg = _config(args)
    out = Path(args.output)
    if not args.resume and (out / "weights.npz").exists():
        raise UsageError(f"-o {args.output}: holds a checkpoint already: --resume continues "
                         "it; give another folder to train a new one")
    if args.jobs < 0 or (args.jobs == 0 and args.backend == "local"):
        raise UsageError(f"--jobs: must be >= 1 (0 = all CPUs, with --backend ray only), "
                         f"got {args.jobs}")
    check_executor_args(args)
    try:
        from planner_core.learning.policy import ppo
    except ModuleNotFoundError as exc:
        if exc.name == "torch":
            raise UsageError("train needs torch: pip install 'lamde-mission[train]'") from None
        raise
    from planner_core.learning.policy.problems import (
        bbob_training_specs,
        default_training_specs,
        read_trainset,
        with_encoding,
    )

    if args.problems and args.bbob is not None:
        raise UsageError("--bbob: give either --problems or --bbob, not both")
    if args.problems:
        try:
            specs = read_trainset(args.problems)
        except ValueError as exc:
            raise UsageError(str(exc)) from None
    elif args.bbob is not None:
        try:
            dims = tuple(int(v) for v in args.bbob_dims.split(",") if v.strip())
        except ValueError:
            raise UsageError(f"--bbob-dims: expected integers like 20,40, got "
                             f"{args.bbob_dims!r}") from None
        try:
            specs = bbob_training_specs(args.bbob, dims)
        except ValueError as exc:
            raise UsageError(f"--bbob: {exc}") from None
    else:
        try:
            specs = default_training_specs(args.maps)
        except ValueError as exc:
            raise UsageError(f"--maps: {exc}") from None
    specs = with_encoding(specs, variable_length=not args.fixed_length)
    # the last check, before the warm start: a file in the way (it crashed after the warm
    # start), a read-only folder; a missing one is made, as the first checkpoint's write does
    check_output_folder("-o/--output", out, mkdir=True)
    from planner_core.execution import SerialExecutor, make_executor

    progress = None if args.quiet else ppo.text_progress()
    # one local worker = this process (a pool of one would only add the transfers: the learner
    # waits for the rollouts either way)
    executor = (SerialExecutor() if args.backend == "local" and args.jobs == 1
                else make_executor(args.jobs, args.backend, args.address))
    try:
        ppo.train(cfg, specs, args.output, resume=args.resume,
                  log=lambda line: print(line, file=sys.stderr), progress=progress,
                  executor=executor)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    finally:
        executor.close()
    print(f"wrote {args.output} (plan with it: lamde-mission plan MAP -o OUT --configurator "
          f"lamde --policy {shlex.quote(str(args.output))}; in Python "
          f"PolicyConfigurator(checkpoint={str(args.output)!r}))")
    return 0
