"""Training and validation problems for the meta-level, all behind one interface
(``lower``, ``upper``, ``evaluate(X) -> (f, phi)``, the DE core's BoxProblem).

A problem is described by a JSON-able *spec* (so a training manifest is data, not paths):

* ``{"kind": "uav", "size": 5000|10000, "density": 0..7, "seed": int}``: a map from the suite
  generator (:func:`planner_core.suite.generate_map`) built into the UAV :class:`Problem`.
* ``{"kind": "map", "path": "file.json"}`` or ``{"kind": "map", "map": {...}}``: any map.

* ``{"kind": "lam-pair", "objective": {...}, "constraint": {...}, "threshold": t,
  "scale": s}``: a synthetic BBOB pair of the landscape-aware module
  (:class:`planner_core.lam.query.PairProblem`).

A training-set file is JSON with a ``"problems"`` list of such specs, or the landscape-aware
module's own file (``lamde-mission lam select -o trainset.json``, format ``lamde-trainset/1``),
whose entries become ``lam-pair`` specs.

Generator seeds: the suite uses 2025 (:data:`planner_core.suite.SUITE_SEED`); training maps use
:data:`TRAIN_SEED_BASE` + k and validation maps :data:`VALIDATION_SEED_BASE` + k, so the three
sets never share a map.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from planner_core.suite import SUITE_SEED

TRAIN_SEED_BASE = 7000
VALIDATION_SEED_BASE = 8000
assert SUITE_SEED not in range(TRAIN_SEED_BASE, VALIDATION_SEED_BASE + 1000)


def default_training_specs(count: int = 16) -> list[dict[str, Any]]:
    """``count`` UAV maps: alternating 5 km / 10 km, densities cycling 0..7, seeds
    TRAIN_SEED_BASE + k."""
    return [
        {"kind": "uav", "size": (5000, 10000)[k % 2], "density": (k // 2 + 3 * (k % 2)) % 8,
         "seed": TRAIN_SEED_BASE + k}
        for k in range(count)
    ]


def validation_specs(count: int = 4) -> list[dict[str, Any]]:
    """``count`` UAV maps for validation (seeds VALIDATION_SEED_BASE + k), both sizes, spread
    over the densities."""
    return [
        {"kind": "uav", "size": (5000, 10000)[k % 2], "density": (2 * k + 1) % 8,
         "seed": VALIDATION_SEED_BASE + k}
        for k in range(count)
    ]


def spec_name(spec: dict[str, Any]) -> str:
    """A short readable name for a spec."""
    if spec.get("kind") == "uav":
        return f"uav-{spec['size']}-d{spec['density']}-s{spec['seed']}"
    if spec.get("kind") == "map":
        return str(spec.get("path") or spec.get("map", {}).get("name", "map"))
    if spec.get("kind") == "lam-pair":
        o, c = spec["objective"], spec["constraint"]
        return (f"bbob-f{o['function']}i{o['instance']}-c{c['function']}i{c['instance']}"
                f"-d{o['dimension']}")
    return str(spec.get("name", spec.get("kind")))


def build(spec: dict[str, Any]) -> Any:
    """The problem of one spec; raises ValueError naming the bad field."""
    from planner_core.problem import Problem

    kind = spec.get("kind")
    if kind == "uav":
        from planner_core.suite import generate_map

        for key in ("size", "density", "seed"):
            if key not in spec:
                raise ValueError(f"problems: uav spec {spec} lacks '{key}'")
        data = generate_map(int(spec["size"]), int(spec["density"]), int(spec["seed"]),
                            name=spec_name(spec))
        return Problem(data)
    if kind == "map":
        if "map" in spec:
            return Problem(spec["map"])
        if "path" in spec:
            return Problem(str(spec["path"]))
        raise ValueError(f"problems: map spec {spec} needs 'path' or 'map'")
    if kind == "lam-pair":
        from planner_core.lam.query import PairProblem

        try:
            return PairProblem(
                tuple(int(spec["objective"][k]) for k in ("function", "dimension", "instance")),
                tuple(int(spec["constraint"][k]) for k in ("function", "dimension", "instance")),
                float(spec["threshold"]), float(spec["scale"]),
            )
        except (KeyError, TypeError) as exc:
            raise ValueError(f"problems: lam-pair spec lacks {exc}") from None
    raise ValueError(f"problems: unknown problem kind {kind!r} (known: uav, map, lam-pair)")


def read_trainset(path: str | Path) -> list[dict[str, Any]]:
    """The ``problems`` list of a training-set JSON file; raises ValueError on bad content.

    Relative map paths are resolved against the file's folder.
    """
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise ValueError(f"--problems: {path}: no such file") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"--problems: {path}: bad JSON ({exc})") from None
    if isinstance(data, dict) and data.get("format") == "lamde-trainset/1":
        from planner_core.lam.trainset import read_trainset as read_lam

        try:
            doc = read_lam(path)
        except ValueError as exc:
            raise ValueError(f"--problems: {exc}") from None
        keep = ("objective", "constraint", "threshold", "scale")
        return [{"kind": "lam-pair", **{k: p[k] for k in keep}} for p in doc["problems"]]
    problems = data.get("problems") if isinstance(data, dict) else None
    if not isinstance(problems, list) or not problems:
        raise ValueError(f"--problems: {path}: needs a non-empty 'problems' list")
    out = []
    for i, spec in enumerate(problems):
        if not isinstance(spec, dict) or "kind" not in spec:
            raise ValueError(f"--problems: {path}: problems[{i}] must be an object with 'kind'")
        spec = dict(spec)
        if spec["kind"] == "map" and "path" in spec and not Path(spec["path"]).is_absolute():
            spec["path"] = str(path.parent / spec["path"])
        out.append(spec)
    return out
