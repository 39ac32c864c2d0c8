"""What is possible on each suite task: the LB cache and the best-known solutions beside the suite.

Both files sit beside the suite folder, not in it (the folder holds exactly the maps):
for `examples/maps/suite/` they are `examples/maps/suite_lower_bounds.json` and
`examples/maps/suite_best_known.json`. The first caches `planner_core.model.bounds.lower_bound` per
map, keyed by the map file's SHA-256 (a changed map is recomputed); `report` only reads it and
keeps what it computes in the run's folder unless asked (`report --update-lower-bounds`). The
second holds, per task, the best feasible f found so far, its hover points/times, and who
found it (optimiser, seed, budget, command); the map's witness plan is the initial entry, and
any benchmark run that finds a better feasible f replaces it (re-checked on the map before it
is stored; a file lock keeps concurrent runners from losing each other's updates).
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import math
import os
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from planner_core.bench._io import read_json, utc_now, write_json_atomic

__all__ = [
    "BEST_KNOWN_PROTOCOL",
    "BestKnown",
    "best_known_path",
    "lower_bounds_path",
    "file_sha256",
    "suite_task_files",
    "lower_bounds",
    "verify_plan",
    "write_json_atomic",
]


#: the command that runs the best-known protocol (1,000,000 evaluations x 5 runs, strongest
#: optimisers; see lamde_mission.commands.bench)
BEST_KNOWN_PROTOCOL = "lamde-mission bench --best-known --suite examples/maps/suite"


def best_known_path(suite: str | Path) -> Path:
    """The best-known file of a suite, beside the suite folder.

    Args:
        suite: the suite folder.

    Returns:
        `<parent>/<suite name>_best_known.json`.
    """
    folder = Path(suite)
    return folder.parent / f"{folder.name}_best_known.json"


def lower_bounds_path(suite: str | Path) -> Path:
    """The lower-bound cache of a suite, beside the suite folder.

    Args:
        suite: the suite folder.

    Returns:
        `<parent>/<suite name>_lower_bounds.json`.
    """
    folder = Path(suite)
    return folder.parent / f"{folder.name}_lower_bounds.json"


def file_sha256(path: str | Path) -> str:
    """Hex SHA-256 of a file's bytes (identifies the exact map a result belongs to).

    Args:
        path: the file.

    Returns:
        64 hex digits.

    Raises:
        OSError: the file cannot be read.
    """
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def suite_task_files(suite: str | Path) -> dict[str, Path]:
    """Task name (file stem) -> map file, for every map JSON in the suite folder, sorted.

    Args:
        suite: the suite folder; files whose name starts with "." or "_" are skipped.

    Returns:
        {stem: path}, in name order.

    Raises:
        FileNotFoundError: the suite folder does not exist.
    """
    folder = Path(suite)
    if not folder.is_dir():
        raise FileNotFoundError(f"suite folder not found: {folder}")
    out = {}
    for p in sorted(folder.glob("*.json")):
        if p.name.startswith((".", "_")):
            continue
        out[p.stem] = p
    return out


@contextlib.contextmanager
def _locked(path: Path) -> Iterator[None]:
    """An exclusive advisory lock for a read-modify-write of `path`, held on its folder (the file
    itself is replaced atomically, so it cannot carry the lock; no lock file is left behind)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path.parent, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        fcntl.flock(fd, fcntl.LOCK_UN)
        os.close(fd)


# ----------------------------------------------------------------------------- lower bounds


def _entries(path: Path, fields: dict[str, type],
             data: dict[str, Any] | None = None) -> dict[str, dict[str, Any]]:  # fmt: skip
    """The `tasks` object of a per-task JSON file ({} when the file is missing) read by the
    shared reader, each entry an object whose `fields` have their type (float: a finite
    number; `data`: the file's object, already read); ValueError naming the file and the
    field otherwise (a list of tasks, an entry 5, "f": "abc" or NaN were tracebacks or
    kept)."""
    from planner_core.textio import json_path, printable, quoted

    data = read_json(path) if data is None else data
    tasks = data.get("tasks")
    head = printable(path)
    if tasks is None:
        return {}
    if not isinstance(tasks, dict):
        raise ValueError(f"{head}: tasks: expected an object, got {quoted(tasks)}")
    for name, e in tasks.items():
        where = json_path(("tasks", name))
        if not isinstance(e, dict):
            raise ValueError(f"{head}: {where}: expected an object, got {quoted(e)}")
        for key, kind in fields.items():
            v = e.get(key)
            if kind is float:
                ok = (not isinstance(v, bool) and isinstance(v, int | float)
                      and math.isfinite(v))  # fmt: skip
                want = "a finite number"
            else:
                ok, want = isinstance(v, kind), "a string"
            if not ok:
                raise ValueError(f"{head}: {where}.{key}: expected {want}, got {quoted(v)}")
    return tasks


def lower_bounds(
    suite: str | Path,
    tasks: list[str] | None = None,
    *,
    cache: str | Path | None = None,
    compute_missing: bool = True,
    also_read: Sequence[str | Path] = (),
) -> dict[str, dict[str, Any]]:
    """LB per task from the cache (by default the one beside the suite); missing or stale
    entries (the map's SHA-256 changed) are computed (`planner_core.model.bounds.lower_bound`,
    about a second a map) and stored in `cache`, under a lock. The caches of `also_read` are
    read, never written: `report` reads the one beside the suite and stores what it computes
    in the run's folder (`build_report`), so a report on a suite outside the repository's
    leaves no file beside it.

    Args:
        suite: the suite folder.
        tasks: the tasks wanted (None: all; names not in the suite are dropped).
        cache: the cache file read and written (None: `lower_bounds_path(suite)`); written
            only when an entry is computed.
        compute_missing: False leaves missing or stale entries out instead of computing them.
        also_read: further cache files, read only (missing ones skipped), consulted after
            `cache`.

    Returns:
        Task -> entry ("sha256", "lb" in s, and the rest of `LowerBound.to_dict`), in the
        order of `tasks` (or the suite's).

    Raises:
        FileNotFoundError: the suite folder does not exist.
        ValueError: naming the file and the field, for an unreadable or malformed cache.
    """
    from planner_core.model.bounds import DEFAULT_SPACING, lower_bound

    files = suite_task_files(suite)
    names = list(files) if tasks is None else [t for t in tasks if t in files]
    path = Path(cache) if cache is not None else lower_bounds_path(suite)
    out: dict[str, dict[str, Any]] = {}
    todo = []
    kinds = {"sha256": str, "lb": float}
    sources = [_entries(path, kinds), *(_entries(Path(p), kinds) for p in also_read)]
    for name in names:
        sha = file_sha256(files[name])
        e = next((src[name] for src in sources
                  if name in src and src[name].get("sha256") == sha), None)
        if e is not None:
            out[name] = e
        else:
            todo.append((name, sha))
    if todo and compute_missing:
        fresh = {}
        for name, sha in todo:
            lb = lower_bound(files[name], DEFAULT_SPACING)
            fresh[name] = {"sha256": sha, **lb.to_dict()}
        with _locked(path):
            tasks_all = {**_entries(path, {"sha256": str, "lb": float}), **fresh}
            write_json_atomic(path, {
                "description": "Lower bound on f per map (planner_core.model.bounds.lower_bound), "
                "keyed by the map file's SHA-256: LB = alpha * T_fly(|end - start|) + "
                "(1 - alpha) * H_LB (LP over <= 25 m cells; C3, C5 and flight relaxed).",
                "tasks": dict(sorted(tasks_all.items())),
            })
        out.update(fresh)
    return {n: out[n] for n in names if n in out}


# ----------------------------------------------------------------------------- best known


def verify_plan(
    map_path: str | Path, hover_points: Any, hover_times: Any
) -> tuple[float, float]:
    """f and phi of a decoded plan (hover points and times in order) on the map, in the
    variable-length encoding.

    Args:
        map_path: the map file.
        hover_points: (k, 2) hover points, m (reshaped from any layout of 2k numbers).
        hover_times: (k,) hover times, s.

    Returns:
        (f, phi): the objective (paper Eq. 3, s) and the total violation (Eq. 7).

    Raises:
        ValueError: more than I_max hover points (`Problem.encode`), or a map that does not
            load.
    """
    from planner_core.model.problem import Problem

    problem = Problem(map_path, variable_length=True)
    hp = np.asarray(hover_points, dtype=float).reshape(-1, 2)
    ht = np.asarray(hover_times, dtype=float).reshape(-1)
    f, phi = problem.evaluate(problem.encode(hp, ht)[None, :])
    return float(f[0]), float(phi[0])


class BestKnown:
    """The best-known feasible solution per task, stored in `path` (usually beside the suite)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)

    def load(self) -> dict[str, dict[str, Any]]:
        """Task -> entry (f, map_sha256, hover_points, hover_times, optimiser, seed, ...).

        Returns:
            A copy of the file's `tasks` ({} when the file is missing).

        Raises:
            ValueError: naming the file and the field: an unreadable file, or an entry without a
                finite `f` or a string `map_sha256`.
        """
        return dict(self._read().get("tasks") or {})

    def _read(self) -> dict[str, Any]:
        """The file's JSON object ({} when missing) read by the shared reader, each entry of
        `tasks` an object with a finite number `f` and a string `map_sha256` (`_entries`);
        ValueError naming the file and the field otherwise."""
        data = read_json(self.path)
        _entries(self.path, {"f": float, "map_sha256": str}, data)
        return data

    def f_values(self, files: dict[str, Path]) -> dict[str, float]:
        """Best-known f per task whose entry matches the current map file (stale ones left out).

        Args:
            files: task name -> map file.

        Returns:
            Task -> f (s).

        Raises:
            ValueError: an unreadable or malformed best-known file (`load`).
        """
        entries = self.load()
        out = {}
        for name, p in files.items():
            e = entries.get(name)
            if e is not None and e.get("map_sha256") == file_sha256(p):
                out[name] = float(e["f"])
        return out

    def ensure(self, files: dict[str, Path]) -> dict[str, float]:
        """Seed missing or stale entries (the map file changed) from each map's witness plan (when
        feasible on the map), under the file's lock; then read the best-known f back.

        Args:
            files: task name -> map file.

        Returns:
            The best-known f per task (s); tasks without a witness or entry are left out.

        Raises:
            ValueError: an unreadable or malformed best-known file.
        """
        from planner_core.model.mapio import load_map

        with _locked(self.path):
            data = self._read()
            tasks = data.setdefault("tasks", {})
            changed = False
            for name, p in files.items():
                sha = file_sha256(p)
                e = tasks.get(name)
                if e is not None and e.get("map_sha256") == sha:
                    continue
                w = load_map(p).spec.witness
                if w is None:
                    continue
                f, phi = verify_plan(p, w.hover_points, w.hover_times)
                if phi != 0.0:
                    continue
                tasks[name] = {
                    "f": f,
                    "map_sha256": sha,
                    "optimiser": "witness",
                    "seed": None,
                    "budget": None,
                    "run": None,
                    "command": "stored witness of the map (planner_core.suite)",
                    "found": utc_now(),
                    "hover_points": [list(map(float, q)) for q in w.hover_points],
                    "hover_times": [float(t) for t in w.hover_times],
                }
                changed = True
            if changed:
                self._write(data)
        return self.f_values(files)

    def offer(
        self,
        task: str,
        map_path: str | Path,
        hover_points: Any,
        hover_times: Any,
        *,
        optimiser: str,
        seed: int | None,
        budget: int | None,
        run: int | None = None,
        command: str = "",
        replace: bool = False,
    ) -> bool:
        """Store this plan if it is feasible on the map and beats the stored f; True if stored.

        A stored entry for another version of the map (SHA-256 differs) is replaced whatever its
        f. The read-compare-write runs under the file's lock.

        Args:
            task: the task name.
            map_path: its map file.
            hover_points: (k, 2) hover points, m.
            hover_times: (k,) hover times, s.
            optimiser: who found it.
            seed: the run's seed.
            budget: the run's budget (evaluations).
            run: the run index.
            command: the command that ran it.
            replace: store it even when the stored f is lower (for a stored plan that an outside
                check, the simulator's, found infeasible: `benchmarks/refresh_best_known.py`); the
                plan must still be feasible on the map.

        Returns:
            True if stored; False when infeasible (phi > 0 or f not finite) or not better.

        Raises:
            ValueError: an unreadable or malformed best-known file, or a plan `verify_plan` refuses.
        """
        f, phi = verify_plan(map_path, hover_points, hover_times)
        if phi != 0.0 or not math.isfinite(f):
            return False
        sha = file_sha256(map_path)
        with _locked(self.path):
            data = self._read()
            tasks = data.setdefault("tasks", {})
            e = tasks.get(task)
            if (not replace and e is not None and e.get("map_sha256") == sha
                    and float(e["f"]) <= f):
                return False
            tasks[task] = {
                "f": f,
                "map_sha256": sha,
                "optimiser": optimiser,
                "seed": seed,
                "budget": budget,
                "run": run,
                "command": command,
                "found": utc_now(),
                "hover_points": np.asarray(hover_points, dtype=float).reshape(-1, 2).tolist(),
                "hover_times": np.asarray(hover_times, dtype=float).reshape(-1).tolist(),
            }
            self._write(data)
        return True

    def _write(self, data: dict[str, Any]) -> None:
        out = {
            "description": "Best-known feasible f per task (lower is better) with its plan and "
            "provenance: initially the map's witness, replaced whenever a benchmark run finds a "
            "better feasible f (checked on the map before it is stored).",
            "protocol": BEST_KNOWN_PROTOCOL,
            "tasks": dict(sorted(data.get("tasks", {}).items())),
        }
        write_json_atomic(self.path, out)
