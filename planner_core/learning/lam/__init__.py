"""The landscape-aware module (paper Sec. 4.3): synthetic training problems like the tasks.

Pieces, in data-flow order:

- :mod:`~planner_core.learning.lam.bbob`: D_syn, BBOB instances keyed by (function, dimension,
  instance) through ``ioh``; :data:`~planner_core.learning.lam.bbob.FULL` is the paper's 14,400,
  :data:`~planner_core.learning.lam.bbob.DEFAULT` the 360 used here by default.
- :mod:`~planner_core.learning.lam.probe`: LHS probes (N_probe = 100) in the unit box.
- Feature extractors with one interface (``name``, ``dim``, ``identity``, ``standardise``,
  ``__call__(U, y) -> (dim,)``, invariant to ``y -> a y + b``, ``a > 0``):
  :mod:`~planner_core.learning.lam.ela` (classical ELA subset, 16 features) and
  :mod:`~planner_core.learning.lam.encoder` (NeurELA-shaped set encoder, 16-d, numpy inference of
  weights trained by :mod:`~planner_core.learning.lam.train_encoder`).
- :mod:`~planner_core.learning.lam.database`: features of D_syn, computed once, cached by content
hash.
- :mod:`~planner_core.learning.lam.query`: the two-stage query, ablations, :class:`PairProblem`.
- :mod:`~planner_core.learning.lam.trainset`: the ``lam select`` JSON file (format documented there)
  and :func:`load_trainset` ``(path) -> list[PairProblem]`` for policy training.
- :func:`select`: all of the above for a list of tasks.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planner_core.learning.lam.bbob import DEFAULT, FULL, BBOBProblem, DatabaseSpec, InstanceKey
from planner_core.learning.lam.database import Database, default_cache_dir, make_extractors
from planner_core.learning.lam.probe import N_PROBE, Probe, lhs, probe
from planner_core.learning.lam.query import (
    RHO_RANGE,
    SELECTIONS,
    PairProblem,
    TaskFeatures,
    match,
    standardiser,
    task_features,
    threshold_for,
)
from planner_core.learning.lam.trainset import FORMAT, key_json, load_trainset, read_trainset

__all__ = [
    "DEFAULT",
    "FULL",
    "N_PROBE",
    "SELECTIONS",
    "BBOBProblem",
    "Database",
    "DatabaseSpec",
    "InstanceKey",
    "PairProblem",
    "Probe",
    "TaskFeatures",
    "default_cache_dir",
    "lhs",
    "load_trainset",
    "make_extractors",
    "match",
    "probe",
    "read_trainset",
    "select",
    "task_features",
    "threshold_for",
]


def select(
    db: Database,
    tasks: list[Any],
    names: list[str],
    *,
    k: int = 64,
    seed: int = 0,
    selection: str = "global",
    features: str = "learned",
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Run the landscape-aware module: probe the tasks, query D_syn, build the pairs. Same
    inputs and seed -> the same document.

    Args:
        db: the database, built (``Database.build``) for the ``features`` extractor.
        tasks: the task problems (box problems: ``lower``, ``upper``, ``evaluate``).
        names: the tasks' names, as the document records them.
        k: pairs to select.
        seed: seed of the task probes and the query.
        selection: the query's selection mode (one of ``SELECTIONS``).
        features: the extractor: "learned" or "ela".

    Returns:
        (document, arrays): the training-set document (format in
        :mod:`planner_core.learning.lam.trainset`) and the arrays used for plotting: ``Z``
        database features after standardisation, ``z_f``, ``z_phi``, ``objective`` and
        ``constraint`` indices.

    Raises:
        ValueError: ``features`` not in the database, no tasks, or a bad query argument
            (`match`).
        FileNotFoundError: the database is not built for ``features`` (``Database.load``).
    """
    if features not in db.extractors:
        raise ValueError(f"features: {features!r} not in the database ({sorted(db.extractors)})")
    if not tasks:
        raise ValueError("tasks: none given")
    extractor = db.extractors[features]
    keys, Z = db.load(features)
    tf = task_features(tasks, names, extractor, db.n_probe, seed)
    z_f, z_phi = tf.z_f, tf.z_phi
    if extractor.standardise:
        mu, sd = standardiser(Z)
        Z, z_f, z_phi = (Z - mu) / sd, (z_f - mu) / sd, (z_phi - mu) / sd
    picked = match(keys, Z, z_f, z_phi, k, selection, seed)
    rho_tasks = float(np.mean(tf.feasible_fraction))
    rho = float(np.clip(rho_tasks, *RHO_RANGE))
    problems = []
    for sel in picked:
        con = keys[sel.constraint]
        t, scale = threshold_for(con, rho, db.n_probe, db.seed)
        problems.append(
            {
                "objective": key_json(keys[sel.objective]),
                "constraint": key_json(con),
                "threshold": t,
                "scale": scale,
                "task": tf.names[sel.task],
                "distance_f": round(sel.distance_f, 12),
                "distance_phi": round(sel.distance_phi, 12),
            }
        )
    doc = {
        "format": FORMAT,
        "options": {
            "k": int(k),
            "seed": int(seed),
            "selection": selection,
            "features": features,
            "n_probe": int(db.n_probe),
            "database": {
                **db.spec.to_json(),
                "seed": int(db.seed),
                "extractor": extractor.identity,
            },
            "tasks": list(tf.names),
            "task_dimensions": list(tf.dimensions),
            "task_feasible_fraction": [float(v) for v in tf.feasible_fraction],
            "rho": rho,
        },
        "problems": problems,
    }
    arrays = {
        "Z": Z,
        "z_f": z_f,
        "z_phi": z_phi,
        "objective": np.array([s.objective for s in picked]),
        "constraint": np.array([s.constraint for s in picked]),
    }
    return doc, arrays
