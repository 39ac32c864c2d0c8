"""D_syn's landscape features, computed once and cached on disk under a content hash.

The database is cut into chunks, one per (dimension, function): a chunk holds the features of
that function's instances at that dimension; each extractor (``"ela"``, ``"learned"``) has its
own file per chunk, named ``<extractor>-<hash>.npz`` with the sha256 (first 24 hex) of
everything its content depends on: format version, key list, N_probe, probe seed, and the
extractor's identity (ELA definition version; encoder weights digest). Building skips files
that exist, so an interrupted build resumes where it stopped, a database built for one
extractor is reused by the other's build, and changing any input builds new files beside the
old ones.
Each file is written to a temp name and renamed (never half-written).

Probe of instance (f, d, i): LHS with seed ``SeedSequence([seed, f, d, i])``, so a probe does
not depend on which other instances the database holds.

Cache folder: ``$LAMDE_CACHE/lam`` if set, else ``~/.cache/lamde-mission/lam``.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from planner_core.atomic import write_bytes_atomic
from planner_core.learning.lam.bbob import DEFAULT, BBOBProblem, DatabaseSpec, InstanceKey
from planner_core.learning.lam.probe import (
    MAX_N_PROBE,
    N_PROBE,
    Probe,
    blas_single_thread,
    probe,
)

__all__ = [
    "FORMAT",
    "Database",
    "default_cache_dir",
    "instance_probe",
    "make_extractors",
]

FORMAT = "lamde-lam-chunk/1"


def default_cache_dir() -> Path:
    """The database's cache folder.

    Returns:
        ``$LAMDE_CACHE/lam`` if LAMDE_CACHE is set (not empty), else
        ``~/.cache/lamde-mission/lam``.
    """
    root = os.environ.get("LAMDE_CACHE")
    return Path(root) / "lam" if root else Path.home() / ".cache" / "lamde-mission" / "lam"


def make_extractors(names: Sequence[str] = ("ela", "learned")) -> dict[str, Any]:
    """Extractor objects by name.

    Args:
        names: extractor names, "ela" and/or "learned".

    Returns:
        {name: extractor} (``ELAExtractor``, ``LearnedExtractor``).

    Raises:
        ValueError: an unknown name.
    """
    out: dict[str, Any] = {}
    for name in names:
        if name == "ela":
            from planner_core.learning.lam.ela import ELAExtractor

            out[name] = ELAExtractor()
        elif name == "learned":
            from planner_core.learning.lam.encoder import LearnedExtractor

            out[name] = LearnedExtractor()
        else:
            raise ValueError(f"features: unknown extractor {name!r} (ela, learned)")
    return out


def instance_probe(key: InstanceKey, n_probe: int = N_PROBE, seed: int = 0) -> Probe:
    """The database's probe of one instance (module doc): LHS with seed
    ``SeedSequence([seed, f, d, i])``.

    Args:
        key: the instance.
        n_probe: probe points.
        seed: the database's probe seed.

    Returns:
        The `Probe` (U (n_probe, d), f (n_probe,), phi zeros).
    """
    ss = np.random.SeedSequence([int(seed), key.function, key.dimension, key.instance])
    return probe(BBOBProblem(key), n_probe, ss)


@dataclass
class Database:
    """D_syn: spec, probe settings, extractors and the cache folder (module doc)."""

    spec: DatabaseSpec = DEFAULT
    n_probe: int = N_PROBE
    seed: int = 0
    cache_dir: Path | None = None
    extractors: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        if not 4 <= self.n_probe <= MAX_N_PROBE:
            raise ValueError(f"n_probe: must be in [4, {MAX_N_PROBE}], got {self.n_probe}")
        self.cache_dir = Path(self.cache_dir) if self.cache_dir else default_cache_dir()
        if self.extractors is None:
            self.extractors = make_extractors()

    # ------------------------------------------------------------------ chunks
    def chunks(self) -> list[list[InstanceKey]]:
        """Key lists, one per (dimension, function), in spec order.

        Returns:
            One list of `InstanceKey`s per chunk (that function's instances at that dimension).
        """
        return [
            [InstanceKey(f, d, i) for i in self.spec.instances]
            for d in self.spec.dimensions
            for f in self.spec.functions
        ]

    def chunk_hash(self, keys: Sequence[InstanceKey], name: str) -> str:
        """Content hash naming the file of one chunk's features by extractor ``name``.

        Args:
            keys: the chunk's keys.
            name: the extractor's name (its identity enters the hash).

        Returns:
            The first 24 hex digits of the sha256 of the format, keys, N_probe, seed and
            extractor identity.
        """
        blob = json.dumps(
            {
                "format": FORMAT,
                "keys": [list(k) for k in keys],
                "n_probe": self.n_probe,
                "seed": self.seed,
                "extractor": self.extractors[name].identity,
            },
            sort_keys=True,
        )
        return hashlib.sha256(blob.encode()).hexdigest()[:24]

    def chunk_path(self, keys: Sequence[InstanceKey], name: str) -> Path:
        """The file of one chunk's features by extractor ``name``.

        Args:
            keys: the chunk's keys.
            name: the extractor's name.

        Returns:
            ``<cache_dir>/<name>-<chunk_hash>.npz``.
        """
        return Path(self.cache_dir) / f"{name}-{self.chunk_hash(keys, name)}.npz"

    def missing(self, names: Sequence[str] | None = None) -> list[list[InstanceKey]]:
        """Chunks with at least one of the extractors ``names`` (default all) not on disk.

        Args:
            names: extractor names, or None for all of this database's.

        Returns:
            Their key lists, in spec order.
        """
        names = list(self.extractors) if names is None else list(names)
        return [c for c in self.chunks() if any(not self.chunk_path(c, n).exists() for n in names)]

    def build(
        self,
        progress: Callable[[int, int], None] | None = None,
        executor: Any = None,
    ) -> int:
        """Compute and store every missing chunk. Files are written here (atomically), as each
        result arrives.

        Args:
            progress: ``progress(done, total)``, called once before the work and after each chunk
                (done counts cached ones too).
            executor: ``planner_core.execution`` (``map_unordered(fn, items)``), spreads chunks
                over processes; a job carries its keys, extractors (with weights) and probe
                settings, never a path. None computes here, in order.

        Returns:
            How many chunks were computed.
        """
        chunks = self.chunks()
        total = len(chunks)
        jobs = []
        for keys in chunks:
            todo = [n for n in self.extractors if not self.chunk_path(keys, n).exists()]
            if todo:
                jobs.append((keys, {n: self.extractors[n] for n in todo}, self.n_probe, self.seed))
        done = total - len(jobs)
        if progress is not None:
            progress(done, total)
        results = (
            map(_chunk_job, jobs) if executor is None else executor.map_unordered(_chunk_job, jobs)
        )
        for keys, feats in results:
            for n, Z in feats.items():
                buf = io.BytesIO()
                np.savez(buf, keys=np.array([list(k) for k in keys], dtype=np.int64), features=Z)
                write_bytes_atomic(self.chunk_path(keys, n), buf.getvalue())
            done += 1
            if progress is not None:
                progress(done, total)
        return len(jobs)

    # ------------------------------------------------------------------ reading
    def load(self, name: str) -> tuple[list[InstanceKey], np.ndarray]:
        """All keys and the features of extractor ``name``.

        Args:
            name: the extractor's name.

        Returns:
            (keys, (len(keys), dim) features), in chunk order.

        Raises:
            ValueError: ``name`` is not one of this database's extractors.
            FileNotFoundError: naming the count of missing chunks if the build is incomplete.
        """
        if name not in self.extractors:
            raise ValueError(f"features: {name!r} not in this database ({sorted(self.extractors)})")
        missing = self.missing([name])
        if missing:
            raise FileNotFoundError(
                f"{len(missing)} of {len(self.chunks())} feature chunks missing in "
                f"{self.cache_dir}: run `lamde-mission lam build` with the same options"
            )
        keys: list[InstanceKey] = []
        rows = []
        for chunk in self.chunks():
            with np.load(self.chunk_path(chunk, name)) as z:
                keys.extend(InstanceKey(*map(int, k)) for k in z["keys"])
                rows.append(np.array(z["features"], dtype=float))
        return keys, np.concatenate(rows, axis=0)


def _chunk_job(
    job: tuple[list[InstanceKey], dict[str, Any], int, int],
) -> tuple[list[InstanceKey], dict[str, np.ndarray]]:
    """Worker: (keys, extractors, n_probe, seed) -> (keys, {name: (len(keys), dim) features})."""
    keys, extractors, n_probe, seed = job
    feats = {n: np.empty((len(keys), e.dim)) for n, e in extractors.items()}
    with blas_single_thread():
        for r, key in enumerate(keys):
            p = instance_probe(InstanceKey(*key), n_probe, seed)
            for n, e in extractors.items():
                feats[n][r] = e(p.U, p.f)
    return [InstanceKey(*k) for k in keys], feats
