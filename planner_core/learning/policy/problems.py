"""Training and validation problems for the meta-level, all behind one interface
(``lower``, ``upper``, ``evaluate(X) -> (f, phi)``, the DE core's BoxProblem).

A problem is described by a JSON-able *spec* (so a training manifest is data, not paths):

* ``{"kind": "uav", "size": 5000|10000, "density": 0..7, "seed": int}``: a map from the suite
  generator (:func:`planner_core.suite.generate_map`) built into the UAV :class:`Problem`.
* ``{"kind": "map", "path": "file.json"}`` or ``{"kind": "map", "map": {...}}``: any map.

  Both UAV kinds take an optional ``"variable_length": false``: the fixed-length encoding (every
  one of the I_max hover points active; the paper's LAMDE-F), see :func:`with_encoding`.
* ``{"kind": "bbob", "function": 1..24, "dimension": d, "instance": i}``: one plain
  (unconstrained, phi = 0) BBOB instance on the unit box
  (:class:`planner_core.learning.lam.bbob.BBOBProblem`); the training set of the paper's LAMDE-O,
  "the
  original setting of existing MetaBBO baselines", :func:`bbob_training_specs`.

* ``{"kind": "lam-pair", "objective": {...}, "constraint": {...}, "threshold": t,
  "scale": s}``: a synthetic BBOB pair of the landscape-aware module
  (:class:`planner_core.learning.lam.query.PairProblem`).

A training-set file is JSON with a ``"problems"`` list of such specs, or the landscape-aware
module's own file (``lamde-mission lam select -o trainset.json``, format ``lamde-trainset/1``),
whose entries become ``lam-pair`` specs.

Generator seeds: the suite uses 2025 (:data:`planner_core.suite.SUITE_SEED`); training maps use
:data:`TRAIN_SEED_BASE` + k and validation maps :data:`VALIDATION_SEED_BASE` + k, so the three
sets never share a map.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from planner_core.suite import SUITE_SEED

TRAIN_SEED_BASE = 7000
VALIDATION_SEED_BASE = 8000
#: the most built-in training maps (`train --maps`): map k has seed TRAIN_SEED_BASE + k, which
#: must stay below the validation maps' seeds
MAX_TRAIN_MAPS = VALIDATION_SEED_BASE - TRAIN_SEED_BASE
assert SUITE_SEED not in range(TRAIN_SEED_BASE, VALIDATION_SEED_BASE + 1000)


def default_training_specs(count: int = 16) -> list[dict[str, Any]]:
    """``count`` UAV maps: alternating 5 km / 10 km, densities cycling 0..7, seeds
    TRAIN_SEED_BASE + k.

    Args:
        count: maps, 1 to ``MAX_TRAIN_MAPS`` (the training seeds stop where the validation
            maps' begin, ``VALIDATION_SEED_BASE``).

    Returns:
        ``count`` ``uav`` specs.

    Raises:
        ValueError: ``count`` outside [1, ``MAX_TRAIN_MAPS``].
    """
    if not 1 <= count <= MAX_TRAIN_MAPS:
        raise ValueError(f"must be an integer in [1, {MAX_TRAIN_MAPS:,}] (the training maps' "
                         f"seeds {TRAIN_SEED_BASE}.. stop where the validation maps' begin), "
                         f"got {count}")
    return [
        {"kind": "uav", "size": (5000, 10000)[k % 2], "density": (k // 2 + 3 * (k % 2)) % 8,
         "seed": TRAIN_SEED_BASE + k}
        for k in range(count)
    ]


def bbob_training_specs(count: int, dimensions: tuple[int, ...] = (20, 40, 80)
                        ) -> list[dict[str, Any]]:
    """``count`` plain BBOB instances (no LAM, no constraint; the paper's LAMDE-O): problem k is
    function ``1 + k % 24``, dimension ``dimensions[(k // 24) % len(dimensions)]``, instance
    ``1 + k // (24 * len(dimensions))``, so the 24 functions are covered evenly before any
    repeats.

    Args:
        count: instances, 1 to ``MAX_PROBLEMS`` (`planner_core.learning.lam.trainset`).
        dimensions: the dimensions cycled through, each >= 2.

    Returns:
        ``count`` ``bbob`` specs.

    Raises:
        ValueError: count outside [1, MAX_PROBLEMS], no dimensions or a dimension < 2.
    """
    from planner_core.learning.lam.trainset import MAX_PROBLEMS

    dims = tuple(int(d) for d in dimensions)
    if not 1 <= count <= MAX_PROBLEMS:  # each is an episode's problem, built in memory
        raise ValueError(f"count must be an integer in [1, {MAX_PROBLEMS:,}], got {count}")
    if not dims or min(dims) < 2:
        raise ValueError(f"dimensions must be >= 2, got {list(dims)}")
    return [
        {"kind": "bbob", "function": 1 + k % 24, "dimension": dims[(k // 24) % len(dims)],
         "instance": 1 + k // (24 * len(dims))}
        for k in range(count)
    ]


def with_encoding(specs: list[dict[str, Any]], variable_length: bool) -> list[dict[str, Any]]:
    """The specs with the UAV encoding set: ``variable_length=False`` adds
    ``"variable_length": false`` to every ``uav``/``map`` spec (LAMDE-F), True removes the key.
    Synthetic problems (``lam-pair``, ``bbob``) have no hover points and pass unchanged, so on a
    set of synthetic problems only the encoding at use differs between LAMDE and LAMDE-F.

    Args:
        specs: problem specs (not modified).
        variable_length: the encoding.

    Returns:
        New spec dicts, in order.
    """
    out = []
    for spec in specs:
        spec = dict(spec)
        if spec.get("kind") in ("uav", "map"):
            spec.pop("variable_length", None)
            if not variable_length:
                spec["variable_length"] = False
        out.append(spec)
    return out


def validation_specs(count: int = 4) -> list[dict[str, Any]]:
    """``count`` UAV maps for validation (seeds VALIDATION_SEED_BASE + k), both sizes, spread
    over the densities.

    Args:
        count: maps.

    Returns:
        ``count`` ``uav`` specs.
    """
    return [
        {"kind": "uav", "size": (5000, 10000)[k % 2], "density": (2 * k + 1) % 8,
         "seed": VALIDATION_SEED_BASE + k}
        for k in range(count)
    ]


def spec_name(spec: dict[str, Any]) -> str:
    """A short readable name for a spec.

    Args:
        spec: a problem spec.

    Returns:
        E.g. "uav-5000-d1-s7000" ("-fixedlen" appended for the fixed-length encoding),
        "bbob-f3i1-d20", "bbob-f3i1-c7i2-d20", a map's path or name.

    Raises:
        KeyError: a ``uav``, ``bbob`` or ``lam-pair`` spec without a field its name shows.
    """
    fixed = "" if spec.get("variable_length", True) else "-fixedlen"
    if spec.get("kind") == "uav":
        return f"uav-{spec['size']}-d{spec['density']}-s{spec['seed']}{fixed}"
    if spec.get("kind") == "map":
        return str(spec.get("path") or spec.get("map", {}).get("name", "map")) + fixed
    if spec.get("kind") == "bbob":
        return f"bbob-f{spec['function']}i{spec['instance']}-d{spec['dimension']}"
    if spec.get("kind") == "lam-pair":
        o, c = spec["objective"], spec["constraint"]
        return (f"bbob-f{o['function']}i{o['instance']}-c{c['function']}i{c['instance']}"
                f"-d{o['dimension']}")
    return str(spec.get("name", spec.get("kind")))


def build(spec: dict[str, Any]) -> Any:
    """The problem of one spec.

    Args:
        spec: a problem spec (module doc).

    Returns:
        The problem: a UAV `Problem`, a `BBOBProblem` or a `PairProblem`.

    Raises:
        ValueError: naming the bad field: an unknown kind, a missing or out-of-range field, a
            ``uav`` size, density or seed that is not a JSON integer, a non-boolean
            ``variable_length``, or a map that does not load.
    """
    from planner_core.model.problem import Problem

    kind = spec.get("kind")
    variable_length = spec.get("variable_length", True)
    if not isinstance(variable_length, bool):
        raise ValueError(f"problems: spec {spec}: variable_length must be true or false")
    if kind == "uav":
        from planner_core.suite import generate_map

        for key in ("size", "density", "seed"):
            if key not in spec:
                raise ValueError(f"problems: uav spec {spec} lacks '{key}'")
            v = spec[key]
            if isinstance(v, bool) or not isinstance(v, int):  # int() took null, "7", 7.9
                raise ValueError(f"problems: uav spec {spec}: {key} must be an integer, "
                                 f"got {v!r}")
        try:
            data = generate_map(spec["size"], spec["density"], spec["seed"],
                                name=spec_name(spec))
        except ValueError as exc:  # the generator's range checks, naming the field
            raise ValueError(f"problems: uav spec {spec}: {exc}") from None
        return Problem(data, variable_length=variable_length)
    if kind == "map":
        if "map" in spec:
            return Problem(spec["map"], variable_length=variable_length)
        if "path" in spec:
            return Problem(str(spec["path"]), variable_length=variable_length)
        raise ValueError(f"problems: map spec {spec} needs 'path' or 'map'")
    if kind == "bbob":
        from planner_core.learning.lam.bbob import BBOBProblem, DatabaseSpec

        try:
            key = tuple(int(spec[k]) for k in ("function", "dimension", "instance"))
        except KeyError as exc:
            raise ValueError(f"problems: bbob spec lacks {exc}") from None
        except (TypeError, ValueError):
            raise ValueError(f"problems: bbob spec {spec}: function, dimension and instance "
                             "must be integers") from None
        try:
            DatabaseSpec(*((v,) for v in key))  # the range checks
        except ValueError as exc:
            raise ValueError(f"problems: bbob spec: {exc}") from None
        return BBOBProblem(key)
    if kind == "lam-pair":
        from planner_core.learning.lam.query import PairProblem

        try:
            return PairProblem(
                tuple(int(spec["objective"][k]) for k in ("function", "dimension", "instance")),
                tuple(int(spec["constraint"][k]) for k in ("function", "dimension", "instance")),
                float(spec["threshold"]), float(spec["scale"]),
            )
        except (KeyError, TypeError) as exc:
            raise ValueError(f"problems: lam-pair spec lacks {exc}") from None
    raise ValueError(f"problems: unknown problem kind {kind!r} (known: uav, map, lam-pair, "
                     "bbob)")


def read_json_file(path: Path, field: str) -> Any:
    """The JSON content of ``path`` through the project's one reader (`planner_core.textio`:
    its size limit, encodings and nesting bound).

    Args:
        path: the JSON file.
        field: the setting that gave the path (the message's first word).

    Returns:
        The JSON value.

    Raises:
        ValueError: "<field>: <path>: ..." (one line naming the setting that gave the path: no
            such file, bad JSON, too large).
    """
    from planner_core import textio

    try:
        return textio.read_json(path)
    except textio.InputError as exc:
        raise ValueError(f"{field}: {path}: {exc}") from None


def read_trainset(path: str | Path) -> list[dict[str, Any]]:
    """The ``problems`` list of a training-set JSON file (or of the landscape-aware module's
    ``lamde-trainset/1`` file, whose entries become ``lam-pair`` specs).

    Relative map paths are resolved against the file's folder.

    Args:
        path: the training-set file.

    Returns:
        The specs, in order.

    Raises:
        ValueError: on bad content: unreadable, a ``format`` other than ``lamde-trainset/1``
            (the message names both), no non-empty ``problems`` list, more than
            ``MAX_PROBLEMS`` problems, an entry that is not an object with ``kind``.
    """
    path = Path(path)
    data = read_json_file(path, "--problems")
    if isinstance(data, dict) and "format" in data:  # a file of specs has none: lam select's,
        # whose reader refuses a format (version) other than the one it reads, naming both
        from planner_core.learning.lam.trainset import read_trainset as read_lam

        try:
            doc = read_lam(path)
        except ValueError as exc:
            raise ValueError(f"--problems: {exc}") from None
        keep = ("objective", "constraint", "threshold", "scale")
        return [{"kind": "lam-pair", **{k: p[k] for k in keep}} for p in doc["problems"]]
    problems = data.get("problems") if isinstance(data, dict) else None
    if not isinstance(problems, list) or not problems:
        raise ValueError(f"--problems: {path}: needs a non-empty 'problems' list")
    from planner_core.learning.lam.trainset import MAX_PROBLEMS

    if len(problems) > MAX_PROBLEMS:  # each is an episode's problem, built in memory
        raise ValueError(f"--problems: {path}: {len(problems)} problems, more than "
                         f"{MAX_PROBLEMS} (the full BBOB database's size)")
    out = []
    for i, spec in enumerate(problems):
        if not isinstance(spec, dict) or "kind" not in spec:
            raise ValueError(f"--problems: {path}: problems[{i}] must be an object with 'kind'")
        spec = dict(spec)
        if spec["kind"] == "map" and "path" in spec and not Path(spec["path"]).is_absolute():
            spec["path"] = str(path.parent / spec["path"])
        out.append(spec)
    return out
