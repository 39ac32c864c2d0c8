"""Keep a study's runs in the repository, small: ``python benchmarks/store_runs.py SRC DST``.

A benchmark folder's records are 3-6 kB each (hover points, x, the convergence trace), so the
I_max study (2 optimisers x 16 tasks x 25 runs x 5 I_max = 4,000 runs) or the ablation study
(6 variants x 16 tasks x 25 runs) is 10-20 MB. The report's tables, the I_max study and the
ablations' normalised performance read a few fields of each run
(:func:`planner_core.bench.records.slim_record`), so the stored folder DST holds:

- ``results.jsonl``: every record of SRC, slim, sorted by (run, task, start mode, I_max,
  optimiser), so that storing the same runs twice gives the same bytes;
- ``meta.json``: SRC's, plus a ``"stored"`` entry (where from, how many records, which fields);
  when it holds an ablation entry, each variant's policy checkpoint is copied to
  ``DST/train/<folder name>/`` (weights, config, manifest and the training curves; not the
  optimiser state nor TensorBoard logs: a few tens of kB each) and the entry points there, so the
  training cost in the report and the policies themselves travel with the runs.

``lamde-mission report`` reads DST like any benchmark folder (``--imax DST``,
``--ablations DST``), except for the convergence and best-path figures, which need full traces.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

from planner_core.bench._io import read_json, write_json_atomic, write_text_atomic
from planner_core.bench.records import RESULTS_FILE, SLIM_FIELDS, key_of, read_records, slim_record

__all__ = ["CHECKPOINT_FILES", "store_runs"]

#: the files of a policy checkpoint folder that are stored with the runs
CHECKPOINT_FILES = ("config.json", "manifest.json", "weights.npz", "curve.csv", "imitation.csv")


def _order(record: dict[str, Any]) -> tuple[Any, ...]:
    k = key_of(record)
    return (k.run, k.task, k.init, -1 if k.i_max is None else k.i_max, k.optimiser)


def store_runs(src: str | Path, dst: str | Path) -> int:
    """Write the slim copy of benchmark folder `src` to `dst` (see the module).

    Args:
        src: the benchmark folder (its results.jsonl, or results.jsonl.gz stored in its
            place, read by `read_records`; meta.json).
        dst: the folder written (created if missing); not `src`.

    Returns:
        The number of records stored.

    Raises:
        ValueError: `src` has no results or `dst` is `src`; a results file or meta.json
            that cannot be read (`read_records`, `read_json`).
    """
    src, dst = Path(src), Path(dst)
    if src.resolve() == dst.resolve():
        raise ValueError(f"store: the destination {dst} is the source folder")
    read = read_records(src / RESULTS_FILE)
    if not read.records:
        raise ValueError(f"store: no results in {src / RESULTS_FILE}")
    records = sorted((slim_record(r) for r in read.records), key=_order)
    meta = read_json(src / "meta.json")
    from planner_core.bench.ablation import META_KEY

    entry = meta.get(META_KEY)
    if entry:
        copied: dict[str, str] = {}
        for info in entry.get("variants", {}).values():
            ck = info.get("checkpoint")
            if not ck:
                continue
            if ck not in copied:
                target = dst / "train" / Path(ck).name
                target.mkdir(parents=True, exist_ok=True)
                for name in CHECKPOINT_FILES:
                    if (Path(ck) / name).is_file():
                        shutil.copyfile(Path(ck) / name, target / name)
                copied[ck] = target.as_posix()
            info["checkpoint"] = copied[ck]
    meta["stored"] = {"from": src.as_posix(), "records": len(records),
                      "fields": [*SLIM_FIELDS, "history (first entry)"]}
    dst.mkdir(parents=True, exist_ok=True)
    write_text_atomic(dst / RESULTS_FILE, "".join(
        json.dumps(r, separators=(",", ":")) + "\n" for r in records))
    write_json_atomic(dst / "meta.json", meta)
    return len(records)
