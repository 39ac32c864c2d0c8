"""Planning speed and memory: `plan` on the largest suite map at 10,000 evaluations.

Prints the wall time of `plan()` split by the pipeline's stages (`Plan.stages`: constructive
plans, their descents, the DE, the polish, the final stage, the second structure, the
improving rounds), the kernel compile apart, peak memory (ru_maxrss) and whether torch or
matplotlib were imported on the planning path.

Two measurements:

* cold: a fresh process making one `plan` call, as `lamde-mission plan` does (median over
  ``--cold`` processes). It includes loading the compiled kernels from numba's disk cache
  (reported as `compile`, apart from planning).
* warm: repeated `plan` calls in one process after a first one (medians), the per-plan cost
  a notebook, a benchmark run or a batch of maps pays.

``--compare CHECKOUT`` also times warm `plan` calls of another checkout of this project (its
`lamde_mission` first on the path, e.g. a `git worktree` of an earlier commit), interleaved
with ours in the same run, and prints the ratio of the medians (wall and process CPU time),
with the f each reaches: how a change moves speed and quality on one machine at one time.

All calls plan the same map with seeds 0, 1, ... (the same work on both sides); cold
processes and warm calls are interleaved so that a drifting machine speed affects both alike.
Targets on a 2-core machine: cold plan() <= 2 s; <= 300 MB without torch/matplotlib; with
--compare, warm time <= 1.2x the other checkout's.

    python benchmarks/bench_plan.py [MAP] [--seed 0] [--budget 10000] [--cold 3] [--warm 5]
        [--compare CHECKOUT]

MAP may be `campus-N`: the generated campus of N non-convex footprints (seed 0, see
`lamde_mission.gis.synthetic`), written to a temporary file first. Real scale (issue 15):
`python benchmarks/bench_plan.py campus-500`; target there: cold plan() under 5 s.

``--large [DIR]`` (issue 31) plans every map of the large suite (`examples/maps/large/`, or
DIR) and T16, each in a fresh process after the kernels are loaded (``--cold`` processes per
map, medians), and prints per map the sensors, I_max, the plan time (process CPU of `plan()`;
wall beside it, which a loaded machine stretches), its ratio to T16's in the same run (T16
measured first and last), f, feasibility and the peak RSS. Targets: <= 5x T16 up to 160
sensors, <= 20x up to 400, peak RSS <= 2 GB.
`LAMDE_MAX_SENSORS` is raised for the children to the suite's largest map when needed.
With ``--show`` each child also writes its plan as a `.plan` file and draws it as
`lamde-mission show MAP MISSION -o OUT` does, in the same process (the CLI's `main`): once to
PNG (the first drawing, so matplotlib's import counts, as in a fresh `show`) and then to SVG;
the table adds the CPU seconds of each (medians), the records `show_png` and `show_svg`.

    python benchmarks/bench_plan.py --large [DIR] [--cold 1] [--maps L01 L02] [--show]
        [-o runs.jsonl]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_MAP = ROOT / "examples" / "maps" / "suite" / "T16.json"


def _stages(p: Any) -> dict[str, float]:
    """Seconds per stage of a plan (an older checkout without `stages`: its timings)."""
    stages = getattr(p, "stages", ())
    if stages:
        return {s.name: s.seconds for s in stages}
    return {k: v for k, v in p.timings.items() if k not in ("total", "compile")}


def _plan(map_: str, seed: int, budget: int, plans: list[Any] | None = None) -> dict[str, Any]:
    """One timed `plan()`, its record (the plan itself appended to `plans` when given)."""
    import lamde_mission

    c0, t0 = time.process_time(), time.perf_counter()
    p = lamde_mission.plan(map_, seed=seed, budget=budget)
    if plans is not None:
        plans.append(p)
    return {"wall": time.perf_counter() - t0, "cpu": time.process_time() - c0,
            "compile": p.timings.get("compile", 0.0), "setup": p.timings.get("setup", 0.0),
            "stages": _stages(p), "f": p.f,
            "feasible": bool(p.feasible), "evaluations": p.evaluations,
            "summary": f"map {p.map_name}: f {p.f:.2f}, phi {p.phi:.3g}, feasible "
                       f"{p.feasible}, {p.n_hover} hover points, {p.evaluations} evaluations"}


def _show(map_: str, plan: Any) -> dict[str, Any]:
    """`--show`: `plan` (made on `map_`) written as a .plan file and drawn by `lamde-mission
    show` in this process, to PNG and then SVG: the CPU and wall seconds of each drawing
    (`show_png`, `show_svg`: {"cpu": s, "wall": s})."""
    import tempfile

    from lamde_mission.cli import main
    from lamde_mission.formats import write_mission
    from planner_core.model.mapio import load_map

    out: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp:
        mission = Path(tmp) / "mission.plan"
        write_mission(mission, plan, load_map(map_))
        for fmt in ("png", "svg"):
            c0, t0 = time.process_time(), time.perf_counter()
            with contextlib.redirect_stdout(sys.stderr):  # "wrote ..." kept off the record
                rc = main(["show", map_, str(mission), "-o", str(Path(tmp) / f"show.{fmt}")])
            if rc != 0:
                raise SystemExit(f"show {map_} -o show.{fmt}: exit {rc}")
            out[f"show_{fmt}"] = {"cpu": time.process_time() - c0,
                                  "wall": time.perf_counter() - t0}  # fmt: skip
    return out


def child(args: argparse.Namespace) -> None:
    """One cold plan() in this fresh process; prints a JSON line for the parent. With
    `--warm-up` the kernels are loaded first (`planner_core.pipeline.warmup`), so the record's
    times are planning alone (what `--large` compares)."""
    if args.warm_up:
        from planner_core.pipeline.warmup import warm_up

        warm_up()
    t0 = time.perf_counter()
    plans: list[Any] = []
    r = _plan(args.map, args.seed, args.budget, plans)
    r["process_wall"] = time.perf_counter() - t0
    r["rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    r["heavy"] = [m for m in ("torch", "matplotlib") if m in sys.modules]
    if args.show:  # after planning's memory and imports are recorded
        r.update(_show(args.map, plans[0]))
    print(json.dumps(r))


def warm_child(args: argparse.Namespace) -> None:
    """Warm plan() calls in this process (after one to load the kernels), one JSON line each:
    what `--compare` runs with the other checkout first on the path."""
    _plan(args.map, args.seed, args.budget)
    for i in range(args.warm):
        print(json.dumps(_plan(args.map, args.seed + i, args.budget)), flush=True)


def _median_stages(runs: list[dict[str, Any]]) -> str:
    names = list(runs[0]["stages"])
    return ", ".join(f"{k} {statistics.median(r['stages'].get(k, 0.0) for r in runs):.3f} s"
                     for k in names)


LARGE = ROOT / "examples" / "maps" / "large"


def _cold(path: str, seed: int, budget: int, env: dict[str, str] | None = None,
          show: bool = False) -> dict[str, Any]:
    """One plan() in a fresh process of this script (`child`), its JSON record (with `show`,
    the plan drawn too: `_show`)."""
    cmd = [sys.executable, str(Path(__file__).resolve()), path, "--seed", str(seed),
           "--budget", str(budget), "--child", "--warm-up", *(["--show"] if show else [])]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True, env=env).stdout
    return json.loads(out.strip().splitlines()[-1])


def large(folder: Path, names: list[str] | None, seed: int, budget: int, runs: int,
          output: str | None, show: bool = False) -> int:
    """`--large`: the large suite's plan times as ratios to T16's (module docstring). Returns
    0 when every target is met, else 1."""
    maps = sorted(folder.glob("*.json"))
    if names:
        maps = [m for m in maps if m.stem in names]
    if not maps:
        print(f"no maps in {folder}", file=sys.stderr)
        return 2
    info = {}
    for m in maps:
        doc = json.loads(m.read_text())
        info[m.stem] = (len(doc["sensors"]), doc.get("uav", {}).get("max_hover_points"))
    most = max(n for n, _ in info.values())
    env = dict(os.environ)
    from planner_core.textio import LIMITS

    if most > LIMITS["sensors"].default:
        env["LAMDE_MAX_SENSORS"] = str(most)
    records: list[dict[str, Any]] = []

    def measure(path: Path) -> list[dict[str, Any]]:
        out = []
        for i in range(runs):
            r = _cold(str(path), seed + i, budget, env, show)
            r.update(map=path.stem, seed=seed + i, budget=budget)
            out.append(r)
            records.append(r)
        return out

    t16 = measure(DEFAULT_MAP)
    rows = {m.stem: measure(m) for m in maps}
    t16 += measure(DEFAULT_MAP)  # first and last: a drifting machine shows in both
    base = statistics.median(r["cpu"] for r in t16)
    print(f"T16: plan() {base:.2f} s CPU (median of {len(t16)} fresh processes after a "
          f"warm-up, first and last), wall {statistics.median(r['wall'] for r in t16):.2f} s")
    print("map    sensors  I_max   plan CPU s  wall s   x T16   target   feasible   f"
          "            peak RSS MB" + ("  show PNG s  SVG s" if show else ""))
    ok = True
    for name, rs in rows.items():
        n, imax = info[name]
        cpu = statistics.median(r["cpu"] for r in rs)
        wall = statistics.median(r["wall"] for r in rs)
        ratio = cpu / base
        target = 5.0 if n <= 160 else 20.0 if n <= 400 else None
        feas = sum(r["feasible"] for r in rs)
        rss = max(r["rss_mb"] for r in rs)
        met = (target is None or ratio <= target) and rss <= 2048
        ok &= met and feas == len(rs)
        tgt = f"<= {target:g}x" if target else "-"
        drawn = ""
        if show:  # CPU seconds of `show` to PNG (with matplotlib's import) and then to SVG
            drawn = "".join(f"  {statistics.median(r[f'show_{x}']['cpu'] for r in rs):>{w}.2f}"
                            for x, w in (("png", 8), ("svg", 5)))  # fmt: skip
        print(f"{name:<6} {n:>7}  {imax!s:>5}  {cpu:>11.2f}  {wall:>6.2f}  {ratio:>6.1f}  "
              f"{tgt:>7}  {feas}/{len(rs):<8} {statistics.fmean(r['f'] for r in rs):<12.2f} "
              f"{rss:>8.0f}  {'met' if met else 'NOT met'}{drawn}")
    with contextlib.suppress(OSError):
        print(f"load average while measuring: {os.getloadavg()[0]:.2f} (1 min) on "
              f"{os.cpu_count()} CPUs")
    if output:
        with open(output, "w") as fh:
            for r in records:
                fh.write(json.dumps({k: v for k, v in r.items() if k != "summary"}) + "\n")
    return 0 if ok else 1


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("map", nargs="?", default=str(DEFAULT_MAP))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--budget", type=int, default=10_000)
    ap.add_argument("--cold", type=int, default=3, help="fresh processes, one plan() each")
    ap.add_argument("--warm", type=int, default=5, help="warm plan() calls in this process")
    ap.add_argument("--compare", metavar="CHECKOUT",
                    help="another checkout of this project to time warm plan() calls of")
    ap.add_argument("--large", nargs="?", const=str(LARGE), metavar="DIR",
                    help="plan the large suite (default examples/maps/large) against T16")
    ap.add_argument("--maps", nargs="+", help="with --large: only these maps (e.g. L01 L02)")
    ap.add_argument("-o", "--output", help="with --large: write every run as JSON lines")
    ap.add_argument("--show", action="store_true",
                    help="with --large: also time `lamde-mission show` of each plan (PNG, SVG)")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--warm-up", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--warm-child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args)
        return
    if args.warm_child:
        warm_child(args)
        return
    if args.cold < 1 or args.warm < 1:
        ap.error("--cold and --warm must be >= 1")
    if args.show and args.large is None:
        ap.error("--show: only with --large")
    if args.large is not None:
        sys.exit(large(Path(args.large), args.maps, args.seed, args.budget, args.cold,
                       args.output, args.show))
    cold_limit = 2.0
    if args.map.startswith("campus-") and args.map[7:].isdigit():
        cold_limit = 5.0  # issue 15: a campus of hundreds of footprints plans in seconds
        import tempfile

        from lamde_mission.gis.synthetic import campus_map
        from planner_core.suite import dumps_map

        tmp = Path(tempfile.mkdtemp()) / f"{args.map}.json"
        tmp.write_text(dumps_map(campus_map(int(args.map[7:]), seed=0)))
        args.map = str(tmp)
    args.map = str(Path(args.map).resolve())
    base = [sys.executable, str(Path(__file__).resolve()), args.map, "--seed", str(args.seed),
            "--budget", str(args.budget)]
    theirs: list[dict[str, Any]] = []
    other_env = None
    if args.compare:
        other = Path(args.compare).resolve()
        if not (other / "lamde_mission").is_dir():
            ap.error(f"--compare: {other} holds no lamde_mission package")
        other_env = {**os.environ, "PYTHONPATH": str(other)}
    _plan(args.map, args.seed, args.budget)  # loads the kernels here
    colds: list[dict[str, Any]] = []
    warms: list[dict[str, Any]] = []
    for i in range(max(args.cold, args.warm)):
        if i < args.cold:
            out = subprocess.run([*base, "--child"], capture_output=True, text=True,
                                 check=True).stdout
            colds.append(json.loads(out.strip().splitlines()[-1]))
        if i < args.warm:
            warms.append(_plan(args.map, args.seed + i, args.budget))
            if other_env is not None:  # one warm call of theirs beside each of ours
                out = subprocess.run([*base, "--warm-child", "--warm", "1", "--seed",
                                      str(args.seed + i)], capture_output=True, text=True,
                                     check=True, env=other_env, cwd=args.compare).stdout
                theirs.append(json.loads(out.strip().splitlines()[-1]))
    print(colds[0]["summary"])
    cold_wall = statistics.median(c["wall"] - c["compile"] for c in colds)
    print(f"cold (median of {len(colds)} fresh processes): plan() {cold_wall:.3f} s without "
          f"the kernels (set-up {statistics.median(c.get('setup', 0.0) for c in colds):.3f} s: "
          "reading the map and its first-call imports) "
          f"+ {statistics.median(c['compile'] for c in colds):.3f} s loading the kernels; "
          f"process wall incl. imports {statistics.median(c['process_wall'] for c in colds):.3f}"
          " s")
    print(f"cold stages: {_median_stages(colds)}")
    rss_mb = max(c["rss_mb"] for c in colds)
    heavy = sorted({m for c in colds for m in c["heavy"]})
    print(f"peak memory {rss_mb:.0f} MB; imported on the planning path: "
          f"{', '.join(heavy) if heavy else 'neither torch nor matplotlib'}")
    w_wall = statistics.median(w["wall"] for w in warms)
    w_cpu = statistics.median(w["cpu"] for w in warms)
    print(f"warm (median of {len(warms)} calls, seeds {args.seed}..{args.seed + len(warms) - 1})"
          f": plan() {w_wall:.3f} s wall, {w_cpu:.3f} s CPU; mean f "
          f"{statistics.fmean(w['f'] for w in warms):.3f}")
    print(f"warm stages: {_median_stages(warms)}")
    ratio = None
    if theirs:
        t_wall = statistics.median(t["wall"] for t in theirs)
        t_cpu = statistics.median(t["cpu"] for t in theirs)
        ratio = w_wall / t_wall
        print(f"{args.compare} warm (median of {len(theirs)}, the same seeds, interleaved): "
              f"plan() {t_wall:.3f} s wall, {t_cpu:.3f} s CPU; mean f "
              f"{statistics.fmean(t['f'] for t in theirs):.3f}")
        print(f"ratio ours / theirs: wall {ratio:.2f}, CPU {w_cpu / t_cpu:.2f}")
    with contextlib.suppress(OSError):
        print(f"load average while measuring: {os.getloadavg()[0]:.2f} (1 min) on "
              f"{os.cpu_count()} CPUs")
    ok = [cold_wall <= cold_limit, rss_mb <= 300 and not heavy]
    text = [f"cold plan() <= {cold_limit:g} s", "<= 300 MB without torch/matplotlib"]
    if ratio is not None:
        ok.append(ratio <= 1.2)
        text.append("warm <= 1.2x the other checkout")
    print("targets: " + ", ".join(f"{t} [{'met' if x else 'NOT met'}]"
                                  for t, x in zip(text, ok, strict=True)))


if __name__ == "__main__":
    main()
