"""The ablation study (paper Sec. 5.3, Table 3, Fig. 3): build, train and evaluate every variant.

Every variant is the same policy network trained with the same PPO settings, the same number of
training problems (K) and the same budget; they differ only in what they are trained on or in
the encoding:

============  ==================================================================================
LAMDE         ``lam select --selection global --features learned``: global centroid matching
              of the learned (NeurELA-like) features; variable-length encoding
LAMDE-F       LAMDE's training set, ``train --fixed-length``; evaluated fixed-length (all I_max
              hover points active). The synthetic pairs have no hover points, so on them the
              training is LAMDE's own (same specs, same seed, same weights: it is trained once)
LAMDE-R       ``lam select --selection random``: K synthetic pairs at random, no landscape
              guidance
LAMDE-E       ``lam select --features ela``: classical ELA features in the same matching
LAMDE-L       ``lam select --selection local``: per task, its own nearest instances
LAMDE-O       ``train --bbob K``: no landscape-aware module, K plain (unconstrained) BBOB
              instances, the original setting of existing MetaBBO methods
============  ==================================================================================

Steps, each resumable (rerun the same command after an interruption; finished steps are
skipped, an unfinished training continues from its last epoch, the evaluation from its last
finished run):

1. the training sets: ``OUT/trainsets/<variant>.json`` (``lamde-mission lam select``, which
   builds the feature database first if it is not cached);
2. the trainings: ``OUT/train/<variant>/`` (``lamde-mission train --resume``), up to ``--jobs``
   at a time, one torch thread each;
3. the evaluation: ``OUT/results.jsonl`` and ``OUT/meta.json`` through the benchmark runner
   (``planner_core.bench.runner.run_bench``, the bench's protocol: same seeds for every
   variant, default ``--init uniform``, the paper's). The landscape-aware variants are charged
   their task probes (N_probe evaluations) within the budget, as the paper counts them;
   LAMDE-O probes nothing;
4. the report (``--report FILE``): ``lamde-mission report OUT``, which finds the ablation entry
   in ``OUT/meta.json`` and adds the normalised performance table and figure (final / initial
   penalised score per run, aggregated over tasks x runs, Wilcoxon against LAMDE) to the
   per-task score table with +/~/- marks against LAMDE (paper Table 3).

The paper's protocol (16 tasks x 25 runs, 10,000 evaluations; training as the shipped policy's):

    python benchmarks/ablations.py --out results-ablations --jobs 2 --report ablations.md

A reduced run (REDUCED, not the paper's protocol) is in ``docs/reduced/``.
"""

from __future__ import annotations

import argparse
import json
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:  # run as a script from anywhere
    sys.path.insert(0, str(ROOT))

from lamde_mission.cli import main as cli  # noqa: E402
from planner_core.bench._io import read_json, write_json_atomic  # noqa: E402
from planner_core.bench.ablation import META_KEY  # noqa: E402

#: variant -> (how its training set is made, training encoding, evaluation encoding, text)
VARIANTS: dict[str, dict[str, Any]] = {
    "LAMDE": {"selection": "global", "features": "learned", "fixed": False,
              "text": "LAM: global centroid matching, learned features; variable length"},
    "LAMDE-F": {"selection": "global", "features": "learned", "fixed": True,
                "text": "LAMDE's training set; fixed-length encoding in training and use"},
    "LAMDE-R": {"selection": "random", "features": "learned", "fixed": False,
                "text": "K synthetic pairs drawn at random (no landscape guidance)"},
    "LAMDE-E": {"selection": "global", "features": "ela", "fixed": False,
                "text": "classical ELA features in the same global matching"},
    "LAMDE-L": {"selection": "local", "features": "learned", "fixed": False,
                "text": "per-task nearest synthetic instances (local retrieval)"},
    "LAMDE-O": {"selection": None, "features": None, "fixed": False,
                "text": "no LAM: K plain BBOB instances (functions 1..24 cycled over the "
                "database's dimensions)"},
}
REFERENCE = "LAMDE"


def _log(args: argparse.Namespace, msg: str) -> None:
    if not args.quiet:
        print(msg, flush=True)


def _tasks_dir(args: argparse.Namespace, out: Path) -> Path:
    """The suite folder, or OUT/tasks with copies of the chosen task maps (lam select reads a
    folder)."""
    suite = Path(args.suite)
    if not args.tasks:
        return suite
    folder = out / "tasks"
    folder.mkdir(parents=True, exist_ok=True)
    for t in args.tasks:
        src = suite / f"{t}.json"
        if not src.exists():
            raise SystemExit(f"--tasks: {src} does not exist")
        dst = folder / src.name
        if not dst.exists() or dst.read_bytes() != src.read_bytes():
            shutil.copyfile(src, dst)
    return folder


def _db_args(args: argparse.Namespace) -> list[str]:
    a = ["--n-probe", str(args.n_probe), "--db-seed", "0"]
    if args.full_db:
        a.append("--full")
    else:
        a += ["--functions", args.db_functions, "--dims", args.db_dims,
              "--instances", str(args.db_instances)]
    if args.cache:
        a += ["--cache", args.cache]
    return a


def trainsets(args: argparse.Namespace, out: Path, commands: list[str]) -> dict[str, str]:
    """Step 1: one `lam select` file per distinct (selection, features); variant -> path."""
    tasks = _tasks_dir(args, out)
    paths: dict[str, str] = {}
    for v in args.variants:
        sel, feat = VARIANTS[v]["selection"], VARIANTS[v]["features"]
        if sel is None:
            continue
        path = out / "trainsets" / f"{sel}-{feat}.json"
        paths[v] = str(path)
        argv = ["lam", "select", "--tasks", str(tasks), "--k", str(args.k), "--seed",
                str(args.seed), "--selection", sel, "--features", feat, "-o", str(path),
                "--mkdir", "--jobs", str(args.jobs), "--quiet", *_db_args(args)]
        cmd = shlex.join(["lamde-mission", *argv])
        if cmd in commands:  # LAMDE-F shares LAMDE's set
            continue
        commands.append(cmd)
        if path.exists():
            o = json.loads(path.read_text()).get("options", {})
            want = {"k": args.k, "seed": args.seed, "selection": sel, "features": feat,
                    "n_probe": args.n_probe}
            if {k: o.get(k) for k in want} != want:
                raise SystemExit(f"{path} was made with other options ({o}): use another --out")
            continue
        t0 = time.perf_counter()
        rc = cli(argv)
        if rc != 0:
            raise SystemExit(f"failed (exit {rc}): {cmd}")
        _log(args, f"trainset {path.name} for {v}: {time.perf_counter() - t0:.1f} s")
    return paths


def _train_argv(args: argparse.Namespace, out_dir: Path, source: list[str],
                fixed: bool) -> list[str]:
    argv = ["train", "-o", str(out_dir), *source, "--epochs", str(args.epochs),
            "--seed", str(args.seed), "--envs", str(args.envs),
            "--population", str(args.train_population), "--budget", str(args.train_budget),
            "--init", args.train_init, "--resume", "--quiet"]
    for item in args.set:
        argv += ["--set", item]
    return argv + (["--fixed-length"] if fixed else [])


def _effective_specs(source: list[str], fixed: bool, dims: str) -> list[dict[str, Any]]:
    from planner_core.learning.policy.problems import (
        bbob_training_specs,
        read_trainset,
        with_encoding,
    )

    if source[0] == "--bbob":
        specs = bbob_training_specs(int(source[1]), tuple(int(d) for d in dims.split(",")))
    else:
        specs = read_trainset(source[1])
    return with_encoding(specs, variable_length=not fixed)


def trainings(args: argparse.Namespace, out: Path, sets: dict[str, str],
              commands: list[str]) -> dict[str, dict[str, Any]]:
    """Step 2: train every distinct (training set, encoding) once, `--jobs` at a time; return
    variant -> {checkpoint, command, description}."""
    dims = _bbob_dims(args)
    plans: dict[str, dict[str, Any]] = {}
    done_by: dict[str, str] = {}  # canonical effective specs -> variant that trains them
    for v in args.variants:
        if VARIANTS[v]["selection"] is None:
            source = ["--bbob", str(args.k), "--bbob-dims", dims]
        else:
            source = ["--problems", sets[v]]
        fixed = bool(VARIANTS[v]["fixed"])
        specs = _effective_specs(source, fixed, dims)
        key = json.dumps(specs, sort_keys=True)
        text = VARIANTS[v]["text"]
        if key in done_by:
            owner = done_by[key]
            why = ("; the set holds no UAV problems, so the encoding only differs in use"
                   if fixed != VARIANTS[owner]["fixed"] else "")
            plans[v] = {**plans[owner], "owner": owner,
                        "description": f"{text} (the same training problems, settings and seed "
                        f"as {owner}, so the same weights: trained once{why})"}
            continue
        done_by[key] = v
        argv = _train_argv(args, out / "train" / v, source, fixed)
        plans[v] = {"checkpoint": str(out / "train" / v), "argv": argv, "specs": specs,
                    "command": shlex.join(["lamde-mission", *argv]), "description": text,
                    "trainset": None if source[0] == "--bbob" else source[1]}
    todo = [(v, p) for v, p in plans.items() if "owner" not in p and not _trained(p, args)]
    running: list[tuple[str, subprocess.Popen[bytes], float]] = []
    commands += [p["command"] for p in plans.values() if "owner" not in p]
    while todo or running:
        while todo and len(running) < max(1, args.jobs):
            v, p = todo.pop(0)
            _log(args, f"training {v}: {p['command']}")
            log = (out / "train" / f"{v}.log")
            log.parent.mkdir(parents=True, exist_ok=True)
            with log.open("ab") as fh:
                proc = subprocess.Popen([sys.executable, "-m", "lamde_mission.cli", *p["argv"]],
                                        stdout=fh, stderr=subprocess.STDOUT, cwd=Path.cwd())
            running.append((v, proc, time.perf_counter()))
        time.sleep(0.5)
        for item in list(running):
            v, proc, t0 = item
            if proc.poll() is None:
                continue
            running.remove(item)
            if proc.returncode != 0:
                for _, other, _ in running:
                    other.terminate()
                raise SystemExit(f"training {v} failed (exit {proc.returncode}); see "
                                 f"{out / 'train' / f'{v}.log'}")
            _log(args, f"trained {v}: {time.perf_counter() - t0:.1f} s")
    return plans


def _trained(plan: dict[str, Any], args: argparse.Namespace) -> bool:
    """Finished: as many epochs as asked, on the same problems (else `train --resume` runs and
    continues, or refuses other settings with a clear message)."""
    folder = Path(plan["checkpoint"])
    if not (folder / "config.json").exists() or not (folder / "manifest.json").exists():
        return False
    done = int(json.loads((folder / "config.json").read_text())["training"]["epochs_done"])
    same = json.loads((folder / "manifest.json").read_text())["problems"] == plan["specs"]
    return same and done >= args.epochs


def _bbob_dims(args: argparse.Namespace) -> str:
    if args.full_db:
        from planner_core.learning.lam import FULL

        return ",".join(str(d) for d in FULL.dimensions)
    return args.db_dims


def evaluate(args: argparse.Namespace, out: Path, plans: dict[str, dict[str, Any]],
             command: str) -> None:
    """Step 3: every variant on the suite through the benchmark runner (resumable)."""
    from planner_core.bench.baselines import policy_spec
    from planner_core.bench.runner import run_bench

    specs = []
    for v in args.variants:
        probe = 0 if (VARIANTS[v]["selection"] is None or args.no_probe_charge) else args.n_probe
        specs.append(policy_spec(v, plans[v]["checkpoint"],
                                 variable_length=not VARIANTS[v]["fixed"],
                                 probe_evaluations=probe,
                                 description=f"{VARIANTS[v]['text']}; policy "
                                 f"{plans[v]['checkpoint']}"
                                 + (f", {probe} probe evaluations charged" if probe else "")))
    s = run_bench(args.suite, [*args.variants, *args.baselines], runs=args.runs,
                  budget=args.budget, out=out,
                  tasks=args.tasks or None, jobs=args.jobs, base_seed=args.seed,
                  best_known=False, command=command, log=lambda m: _log(args, m),
                  inits=(args.init,), extra=specs)
    if s.failed:
        raise SystemExit(f"{len(s.failed)} evaluation run(s) failed, first: "
                         f"{s.failed[0]['error']}")


def parse(argv: list[str] | None = None) -> argparse.Namespace:
    from planner_core import defaults as D

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="output folder (all steps write under it)")
    ap.add_argument("--suite", default="examples/maps/suite",
                    help="map folder (default examples/maps/suite, from the repository root)")
    ap.add_argument("--tasks", nargs="+", metavar="T", help="only these tasks (default all)")
    ap.add_argument("--variants", default=",".join(VARIANTS),
                    help=f"comma-separated subset of {','.join(VARIANTS)} (LAMDE always runs)")
    ap.add_argument("--jobs", type=int, default=2, help="trainings / benchmark workers at once")
    ap.add_argument("--seed", type=int, default=0, help="selection, training and run seed")
    g = ap.add_argument_group("training sets (lam select)")
    g.add_argument("--k", type=int, default=16, help="training problems per variant "
                   "(default 16, the shipped policy's count)")
    g.add_argument("--n-probe", type=int, default=100, help="probe size N_probe")
    g.add_argument("--full-db", action="store_true", help="the paper's 14,400-instance database")
    g.add_argument("--db-functions", default="1-24")
    g.add_argument("--db-dims", default="20,40,80")
    g.add_argument("--db-instances", type=int, default=5)
    g.add_argument("--cache", help="feature cache folder (default lam's)")
    g = ap.add_argument_group("training (train; the same for every variant)")
    g.add_argument("--epochs", type=int, default=16)
    g.add_argument("--envs", type=int, default=4)
    g.add_argument("--train-population", type=int, default=50)
    g.add_argument("--train-budget", type=int, default=3000)
    g.add_argument("--train-init", choices=("uniform", "seeded", "both"), default="both")
    g.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="another PPOConfig field for every training (train --set)")
    g = ap.add_argument_group("evaluation (the bench's protocol)")
    g.add_argument("--runs", type=int, default=D.RUNS)
    g.add_argument("--budget", type=int, default=D.BUDGET)
    g.add_argument("--init", choices=("uniform", "seeded"), default="uniform")
    g.add_argument("--baselines", default="", metavar="LIST",
                   help="registry optimisers to run alongside under the same protocol, e.g. "
                   "de-adaptive,cmaes (the paper's Fig. 3 puts LAMDE-F among the baselines; "
                   "default none)")
    g.add_argument("--no-probe-charge", action="store_true",
                   help="do not charge the LAM variants' N_probe task probes to their budget")
    g = ap.add_argument_group("report")
    g.add_argument("--report", metavar="FILE.md", help="write the report here at the end")
    g.add_argument("--no-limits", action="store_true", help="report without the limits section")
    g.add_argument("--title", default="Ablation study", help="the report's first heading")
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args(argv)
    names = [v for v in args.variants.split(",") if v]
    bad = [v for v in names if v not in VARIANTS]
    if bad:
        ap.error(f"--variants: unknown {', '.join(bad)}; choose from {', '.join(VARIANTS)}")
    args.variants = [REFERENCE] + [v for v in VARIANTS if v in names and v != REFERENCE]
    args.tasks = [t for v in (args.tasks or []) for t in v.split(",") if t]
    from planner_core.bench.baselines import REGISTRY

    args.baselines = [b for b in args.baselines.split(",") if b]
    bad = [b for b in args.baselines if b not in REGISTRY]
    if bad:
        ap.error(f"--baselines: unknown {', '.join(bad)}; choose from {', '.join(REGISTRY)}")
    for name in ("k", "epochs", "envs", "runs", "budget", "n_probe"):
        if getattr(args, name) < 1:
            ap.error(f"--{name.replace('_', '-')}: must be >= 1")
    if args.jobs < 0:
        ap.error("--jobs: must be >= 0")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    command = shlex.join(["python", "benchmarks/ablations.py", *(sys.argv[1:] if argv is None
                                                                 else argv)])
    commands: list[str] = []
    t0 = time.perf_counter()
    sets = trainsets(args, out, commands)
    t1 = time.perf_counter()
    plans = trainings(args, out, sets, commands)
    t2 = time.perf_counter()
    meta_path = out / "meta.json"
    meta = read_json(meta_path)  # the entry goes in first: a report of a partial run knows it
    meta[META_KEY] = {
        "reference": REFERENCE,
        "variants": {v: {k: plans[v][k] for k in ("checkpoint", "description")}
                     | {"trainset": sets.get(v), "train_command": plans[v].get("command")}
                     for v in args.variants},
        "driver": command,
        "steps": commands,
    }
    write_json_atomic(meta_path, meta)
    evaluate(args, out, plans, command)
    t3 = time.perf_counter()
    meta = read_json(meta_path)
    meta.setdefault("ablation_timings", []).append(
        {"trainsets_s": round(t1 - t0, 1), "trainings_s": round(t2 - t1, 1),
         "evaluation_s": round(t3 - t2, 1)})
    write_json_atomic(meta_path, meta)
    _log(args, f"steps: training sets {t1 - t0:.1f} s, trainings {t2 - t1:.1f} s, "
               f"evaluation {t3 - t2:.1f} s")
    if args.report:
        # --mkdir: the report comes after hours of runs; its folder is made, as it always was
        argv_r = ["report", str(out), "-o", args.report, "--title", args.title, "--mkdir"]
        if args.no_limits:
            argv_r.append("--no-limits")
        rc = cli(argv_r)
        if rc != 0:
            return rc
    return 0


if __name__ == "__main__":
    sys.exit(main())
