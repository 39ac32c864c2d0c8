"""Fuzz the command line with mutated maps and missions; count how each input ended.

Mutates the shipped maps (examples/maps, the suite included; not the large suite,
examples/maps/large, whose 80-400-sensor plans take 3-60 s by design, past any hang
threshold), the GeoJSON layers of
tests/data/campus.geojson (through `map from-geojson`) and missions written at start by
`lamde-mission plan` into a temporary folder (a .plan and a .waypoints for two maps), with
`lamde_mission.fuzz.mutate` seeded by ``--seed`` and the input's index (same seed, same inputs).

Each mutated map goes through `check`; a refused one also through `plan -o OUT` (it must be
refused too, with nothing written); an accepted one is planned with a small budget and its
mission read back. Each mutated mission goes through `verify`. Runs are in-process (the CLI's
`main()` with stdout/stderr captured) for speed; a sample (and a named pipe given as a map) is
run again in a subprocess under ``--timeout`` to catch hangs.

Prints counts: clean refusals (exit 2, every stderr line prefixed by the command; how many were
a single line), successes (exit 0, or 1 for a mission that fails a constraint / an infeasible
plan), tracebacks (must be 0), hangs over the timeout (0), partial files (0), runs whose peak
resident set exceeds ``--rss-limit`` MiB (0; Linux's high-water mark per run). Exit status 1
if any of the last four is not 0; ``--keep DIR`` saves the offending inputs there.

    python benchmarks/fuzz_inputs.py --n 1000 --seed 0 [--hang-sample 20] [--timeout 30]
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MAPS = ROOT / "examples" / "maps"
CAMPUS = ROOT / "tests" / "data" / "campus.geojson"
sys.path.insert(0, str(ROOT))

from lamde_mission.formats import read_mission  # noqa: E402
from lamde_mission.fuzz import CliOutcome, mutate, run_cli  # noqa: E402


class _PeakRss:
    """The largest resident set size (MiB) of this process while a block runs: Linux's own
    high-water mark (VmHWM in /proc/self/status), reset at the start by writing 5 to
    /proc/self/clear_refs, so it is exact; where that cannot be done, /proc/self/statm sampled
    every 5 ms by a thread. In-process runs share the process, so a run's peak includes what
    is loaded already (the libraries, the compiled kernels): an upper bound on its own."""

    PAGE = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096

    def __init__(self) -> None:
        self.peak = 0.0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._exact = False

    @classmethod
    def now(cls) -> float:
        try:
            with open("/proc/self/statm") as fh:
                return int(fh.read().split()[1]) * cls.PAGE / 2**20
        except (OSError, ValueError, IndexError):
            return 0.0

    @staticmethod
    def high_water() -> float:
        """VmHWM (MiB), 0 where /proc/self/status has none."""
        try:
            with open("/proc/self/status") as fh:
                for line in fh:
                    if line.startswith("VmHWM:"):
                        return int(line.split()[1]) / 1024
        except (OSError, ValueError, IndexError):
            pass
        return 0.0

    def _watch(self) -> None:
        while not self._stop.wait(0.005):
            self.peak = max(self.peak, self.now())

    def start(self) -> _PeakRss:
        self.peak = self.now()
        try:
            with open("/proc/self/clear_refs", "w") as fh:
                fh.write("5")  # reset the high-water mark to the current RSS
            self._exact = self.high_water() > 0
        except OSError:
            self._exact = False
        if not self._exact:
            self._stop.clear()
            self._thread = threading.Thread(target=self._watch, daemon=True)
            self._thread.start()
        return self

    def stop(self) -> None:
        if self._exact:
            self.peak = max(self.peak, self.high_water())
            return
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        self.peak = max(self.peak, self.now())


#: the CLI in a fresh process that says its own peak RSS (KiB) on stderr as it exits: VmHWM,
#: the high-water mark of its own address space (ru_maxrss is not: after a vfork it starts
#: from the parent's high-water mark)
_RSS_WRAPPER = (
    "import runpy, sys\n"
    "sys.argv[0] = 'lamde-mission'\n"
    "try:\n"
    "    runpy.run_module('lamde_mission.cli', run_name='__main__')\n"
    "finally:\n"
    "    hwm = [ln.split()[1] for ln in open('/proc/self/status') if ln.startswith('VmHWM:')]\n"
    "    print('fuzz-rss-kib', hwm[0] if hwm else 0, file=sys.stderr)\n"
)


def _map_files() -> list[Path]:
    out = []
    for p in sorted(MAPS.rglob("*.json")):
        if (MAPS / "large") in p.parents:  # benchmark maps: planning them takes a minute
            continue
        try:
            if "area" in json.loads(p.read_text()):
                out.append(p)
        except ValueError:
            pass
    return out


def _missions(folder: Path) -> list[tuple[Path, Path]]:
    """(map, mission) pairs written by `plan` for the two small example maps."""
    pairs = []
    folder.mkdir(parents=True, exist_ok=True)  # `plan` writes into existing folders only
    for name in ("tiny.json", "small-demo.json"):
        for suffix in (".plan", ".waypoints"):
            out = folder / f"{Path(name).stem}{suffix}"
            res = run_cli(["plan", str(MAPS / name), "-o", str(out), "--budget", "2000",
                           "--quiet", "--allow-infeasible"])  # fmt: skip
            if res.error is not None or not out.exists():
                raise SystemExit(f"could not write the seed mission {out}: {res.stderr}")
            pairs.append((MAPS / name, out))
    return pairs


# plan's refusal of a .plan output for a map that is planned as a directory of sorties
SORTIES_MAP = "a map with a battery or fleet is written as a directory of sorties"


def _clean(res: CliOutcome, command: str) -> bool:
    """Whether stderr is what the contract allows: exit 2 with every line (notes apart)
    prefixed by `lamde-mission COMMAND: `, or any other status with prefixed, note or
    indented lines. COMMAND is the subcommand's words (`check`, `map from-geojson`)."""
    lines = res.stderr.splitlines()
    prefix = f"lamde-mission {command}: "
    if "Traceback" in res.stderr:
        return False
    if res.status == 2:
        errors = [ln for ln in lines if not ln.startswith("note: ")]
        return bool(errors) and all(ln.startswith(prefix) for ln in errors)
    return all(ln.startswith((prefix, "note: ", "  ")) for ln in lines)


def _leftovers(folder: Path, keep: set[str]) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name not in keep)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1000, help="mutated inputs (default 1000)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--timeout", type=float, default=30.0, help="a hang is longer than this (s)")
    ap.add_argument("--hang-sample", type=int, default=20,
                    help="inputs re-run in a subprocess under --timeout (default 20)")
    ap.add_argument("--plan-budget", type=int, default=200,
                    help="evaluations when planning an accepted mutated map (default 200)")
    ap.add_argument("--keep", metavar="DIR", help="save inputs that broke the contract here")
    ap.add_argument("--rss-limit", type=float, default=1024.0, metavar="MIB",
                    help="a run whose peak resident set exceeds this (MiB) counts as broken "
                    "(default 1024)")
    args = ap.parse_args(argv)

    t0 = time.perf_counter()
    work = Path(tempfile.mkdtemp(prefix="fuzz-inputs-"))
    counts: collections.Counter[str] = collections.Counter()
    kinds: collections.Counter[str] = collections.Counter()
    bad: list[tuple[str, str, Path]] = []
    slowest = (0.0, "")
    biggest = (0.0, "")
    child_rss = 0.0
    hang_cases: list[tuple[str, list[str], Path]] = []
    try:
        maps = _map_files()
        missions = _missions(work / "seed")
        sample_every = max(args.n // max(args.hang_sample, 1), 1)
        for i in range(args.n):
            rng = random.Random(f"{args.seed}:{i}")
            case = work / f"case{i:05d}"
            case.mkdir()
            draw = rng.random()
            if draw < 0.15:
                kind = "geojson"
                path = case / "in.geojson"
                path.write_bytes(mutate(CAMPUS.read_bytes(), rng))
                argv_first = ["map", "from-geojson", str(path), "-o", str(case / "map.json")]
            elif draw < 0.55:
                src = rng.choice(maps)
                kind = "map"
                path = case / "map.json"
                path.write_bytes(mutate(src.read_bytes(), rng))
                argv_first = ["check", str(path)]
            else:
                map_path, src = rng.choice(missions)
                kind = src.suffix
                path = case / f"mission{src.suffix}"
                path.write_bytes(mutate(src.read_bytes(), rng))
                argv_first = ["verify", str(map_path), str(path)]
            kinds[kind] += 1
            keep = {path.name}
            if kind == "geojson":
                keep.add("map.json")
            t = time.perf_counter()
            watch = _PeakRss().start()
            res = run_cli(argv_first)
            problem = ""
            if res.error is not None or "Traceback" in res.stderr:
                counts["tracebacks"] += 1
                problem = f"traceback: {res.error!r}"
            elif not _clean(res, " ".join(argv_first[:2] if kind == "geojson" else argv_first[:1])):
                counts["unclean stderr"] += 1
                problem = f"stderr: {res.stderr[:200]!r}"
            elif res.status == 2:
                counts["clean refusals"] += 1
                if len(res.stderr.splitlines()) == 1:
                    counts["refusals in one line"] += 1
            else:
                counts["successes"] += 1
            if kind == "geojson" and not problem:
                written = case / "map.json"
                if res.status == 2 and written.exists():
                    counts["partial files"] += 1
                    problem = "map written although refused"
                elif res.status == 0 and run_cli(["check", str(written)]).status not in (0, 1):
                    # check's 1: a valid map no plan can meet (a mutated required_data), whole
                    counts["partial files"] += 1
                    problem = "written map is refused by check"
                left = _leftovers(case, keep)
                if left and not problem:
                    counts["partial files"] += 1
                    problem = f"left behind: {left}"
            if kind == "map" and not problem:
                out = case / "out.plan"
                if res.status == 2:
                    res2 = run_cli(["plan", str(path), "-o", str(out), "--quiet"])
                    if res2.error is not None:
                        counts["tracebacks"] += 1
                        problem = f"plan traceback: {res2.error!r}"
                    elif res2.status != 2:
                        counts["check/plan disagree"] += 1
                        problem = f"check refused, plan gave {res2.status}"
                else:
                    small = ["--quiet", "--budget", str(args.plan_budget), "--population", "20",
                             "--no-polish"]
                    res2 = run_cli(["plan", str(path), "-o", str(out), *small])
                    if res2.status == 2 and SORTIES_MAP in res2.stderr:
                        # a map with a battery or fleet is planned into a directory of sorties
                        out = case / "sorties"
                        res2 = run_cli(["plan", str(path), "-o", str(out), *small])
                    if res2.error is not None:
                        counts["tracebacks"] += 1
                        problem = f"plan traceback: {res2.error!r}"
                    elif res2.status == 0:
                        keep.add(out.name)
                        try:
                            for written in sorted(out.glob("*.plan")) if out.is_dir() else [out]:
                                read_mission(written)
                        except ValueError as exc:
                            counts["partial files"] += 1
                            problem = f"written mission unreadable: {exc}"
                    elif res2.status == 2:
                        counts["check/plan disagree"] += 1
                        problem = f"check accepted, plan refused: {res2.stderr[:200]!r}"
                left = _leftovers(case, keep)
                if left and not problem:
                    counts["partial files"] += 1
                    problem = f"left behind: {left}"
            dt = time.perf_counter() - t
            watch.stop()
            if watch.peak > biggest[0]:
                biggest = (watch.peak, f"case {i} ({kind})")
            if watch.peak > args.rss_limit:
                counts["over the RSS limit"] += 1
                problem = problem or f"peak RSS {watch.peak:.0f} MiB"
            if dt > slowest[0]:
                slowest = (dt, f"case {i} ({kind})")
            if dt > args.timeout:
                counts["hangs"] += 1
                problem = problem or f"took {dt:.1f} s"
            if problem:
                bad.append((f"case {i} ({kind})", problem, path))
            if i % sample_every == 0:
                hang_cases.append((f"case {i} ({kind})", argv_first, case))
            elif not problem:
                shutil.rmtree(case)
        # hangs: a sample in fresh processes, plus a named pipe given as a map
        if hasattr(os, "mkfifo"):
            fifo = work / "fifo.json"
            os.mkfifo(fifo)
            hang_cases.append(("named pipe as the map", ["check", str(fifo)], work))
        for label, argv_, _case in hang_cases:
            try:
                r = subprocess.run([sys.executable, "-c", _RSS_WRAPPER, *argv_],
                                   capture_output=True, text=True, timeout=args.timeout,
                                   cwd=ROOT)  # fmt: skip
                if "Traceback" in r.stderr:
                    counts["tracebacks"] += 1
                    bad.append((label, "traceback in a subprocess", Path(argv_[-1])))
                rss = [ln for ln in r.stderr.splitlines() if ln.startswith("fuzz-rss-kib ")]
                peak = int(rss[-1].split()[1]) / 1024 if rss else 0.0
                child_rss = max(child_rss, peak)
                if peak > args.rss_limit:
                    counts["over the RSS limit"] += 1
                    bad.append((label, f"peak RSS {peak:.0f} MiB in a subprocess",
                                Path(argv_[-1])))  # fmt: skip
            except subprocess.TimeoutExpired:
                counts["hangs"] += 1
                bad.append((label, f"no answer within {args.timeout:g} s", Path(argv_[-1])))
        if args.keep and bad:
            keep_dir = Path(args.keep)
            keep_dir.mkdir(parents=True, exist_ok=True)
            for label, _problem, p in bad:
                if p.is_file():
                    shutil.copy(p, keep_dir / f"{label.split()[1]}-{p.name}")
    finally:
        shutil.rmtree(work, ignore_errors=True)

    total = time.perf_counter() - t0
    print(f"fuzz_inputs: {args.n} mutated inputs, seed {args.seed}: "
          + ", ".join(f"{kinds[k]} {k if k != 'map' else 'maps'}" for k in sorted(kinds)))
    print(f"  clean refusals       {counts['clean refusals']:6d}  (exit 2; "
          f"{counts['refusals in one line']} in one line, the rest one line per problem)")
    print(f"  successes            {counts['successes']:6d}  (exit 0, or 1: a constraint fails)")
    print(f"  tracebacks           {counts['tracebacks']:6d}")
    print(f"  hangs over {args.timeout:g} s     {counts['hangs']:6d}  (slowest in-process "
          f"{slowest[0]:.2f} s, {slowest[1]}; {len(hang_cases)} re-run in subprocesses)")
    print(f"  partial files        {counts['partial files']:6d}")
    print(f"  unclean stderr       {counts['unclean stderr']:6d}")
    print(f"  check/plan disagree  {counts['check/plan disagree']:6d}")
    print(f"  peak RSS             {biggest[0]:6.0f} MiB  (in-process, the largest of any run: "
          f"{biggest[1]}; {counts['over the RSS limit']} over {args.rss_limit:g} MiB; the "
          f"subprocess re-runs at most {child_rss:.0f} MiB)")
    print(f"  wall time            {total:6.1f} s")
    for label, problem, _p in bad[:20]:
        print(f"  ! {label}: {problem}")
    broken = sum(counts[k] for k in ("tracebacks", "hangs", "partial files", "unclean stderr",
                                     "check/plan disagree", "over the RSS limit"))  # fmt: skip
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
