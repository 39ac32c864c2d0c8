"""Benchmark results as JSON lines: one finished run per line, appended and flushed as it ends.

A run killed mid-write leaves a truncated last line: reading skips it, and opening the file for
appending first cuts it off, so the next record starts on a fresh line. A key (optimiser, task,
run, init, i_max) already present is never written again, so an interrupted benchmark resumes
where it stopped.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import IO, Any, NamedTuple

from planner_core.bench._io import read_maybe_gz, stored_path

__all__ = ["RESULTS_FILE", "Key", "key_of", "read_records", "ResultsWriter", "ReadReport",
           "complete_runs", "slim_record", "skipped_parts", "skipped_note"]

#: the results file inside a benchmark output folder
RESULTS_FILE = "results.jsonl"


class Key(NamedTuple):
    """Identity of a run: optimiser, task, run index, start mode and I_max override (None: the
    map's own)."""

    optimiser: str
    task: str
    run: int
    init: str = "seeded"
    i_max: int | None = None


def key_of(record: dict[str, Any]) -> Key:
    """The identity of a run record (records written before start modes existed were seeded).

    Args:
        record: a run record with "optimiser", "task", "run" (and optionally "init", "i_max").

    Returns:
        Its `Key` (init "seeded" and i_max None when absent).

    Raises:
        KeyError: a record without "optimiser", "task" or "run".
    """
    i_max = record.get("i_max")
    return Key(str(record["optimiser"]), str(record["task"]), int(record["run"]),
               str(record.get("init", "seeded")), None if i_max is None else int(i_max))


class ReadReport(NamedTuple):
    """Records read (first of each key), and what was skipped."""

    records: list[dict[str, Any]]
    truncated_tail: bool  # the last line was cut off (an interrupted write)
    bad_lines: list[int]  # 1-based line numbers that were not valid records (tail excluded)
    duplicates: int


_REQUIRED = ("optimiser", "task", "run", "f", "phi", "score", "evaluations")


#: numbers of a run record that the tables and figures average: finite where present
_NUMBERS = ("f", "phi", "score", "evaluations", "wall_s", "budget", "last_feasible_rate")
#: how `textio` says a line is not (whole) JSON text: a cut or garbled line, skipped
_CUT = ("not valid JSON", "not UTF-8", "contains a NUL")
#: lists of numbers of a record's convergence `history`
_HISTORY = ("evaluations", "best_f", "best_phi")


def record_problem(rec: dict[str, Any]) -> str | None:
    """What makes a parsed run record unusable by the report. Checked: the key fields' types,
    the numbers the tables average (finite: a NaN or Infinity score wrote `nan` into a table),
    `feasible` a boolean and `history` an object of lists of finite numbers (as the figures
    read it).

    Args:
        rec: a parsed record holding at least "optimiser" and "task".

    Returns:
        The first problem as "field: problem" (one line; values shown cut), or None.
    """
    from planner_core.textio import quoted

    for k in ("optimiser", "task"):
        if not isinstance(rec[k], str):
            return f"{k}: expected a string, got {quoted(rec[k])}"
    for k in ("run", "i_max"):
        v = rec.get(k)
        if (k == "run" or v is not None) and (isinstance(v, bool) or not isinstance(v, int)):
            return f"{k}: expected an integer, got {quoted(v)}"
    for k in _NUMBERS:
        v = rec.get(k)
        if v is None and k not in _REQUIRED:
            continue
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            return f"{k}: expected a finite number, got {quoted(v)}"
    if "feasible" in rec and not isinstance(rec["feasible"], bool):
        return f"feasible: expected true or false, got {quoted(rec['feasible'])}"
    h = rec.get("history")
    if h is not None:
        if not isinstance(h, dict):
            return f"history: expected an object, got {quoted(h)}"
        for k in _HISTORY:
            v = h.get(k)
            if v is None:
                continue
            if not isinstance(v, list):
                return f"history.{k}: expected a list of numbers, got {quoted(v)}"
            for i, x in enumerate(v):
                if isinstance(x, bool) or not isinstance(x, int | float) or not math.isfinite(x):
                    return f"history.{k}[{i}]: expected a finite number, got {quoted(x)}"
    return None


def read_records(path: str | Path) -> ReadReport:
    """All valid records of a results file (missing file: none), first occurrence per key; a
    name ending in .gz is read gzip-compressed (the records kept under docs/ are), and a plain
    name whose file is absent reads its compressed twin (`stored_path`: `results.jsonl` reads
    `results.jsonl.gz` when only that exists), so every caller finds a run folder's records
    by the plain name.

    Read by the shared reader (`read_maybe_gz`: regular file, bounded size decompressed too;
    each line by `textio.loads_json`: bounded depth). A line that is not JSON, not an object or
    lacks a required field is skipped as unreadable (an interrupted write leaves one); a line
    that is a record with a field of the wrong type or a NaN/Infinity number is refused.

    Args:
        path: the results file, with or without .gz (`stored_path` picks the one stored).

    Returns:
        The `ReadReport`: the records, whether the last line was cut off, the 1-based numbers
        of the other unreadable lines, and how many duplicate keys were skipped.

    Raises:
        ValueError: naming the file, the line and the field, for a refused record (or a line
            too deep or with NaN); naming the file for an unreadable one.
    """
    from planner_core.textio import InputError, decode_text, loads_json, printable

    path = stored_path(path)
    if not path.exists():
        return ReadReport([], False, [], 0)
    data = read_maybe_gz(path)
    lines = data.split(b"\n")
    tail_open = not data.endswith(b"\n") and data != b""
    records: list[dict[str, Any]] = []
    seen: set[Key] = set()
    bad: list[int] = []
    truncated = False
    dup = 0
    for i, raw in enumerate(lines):
        if not raw.strip():
            continue
        last = i == len(lines) - 1
        where = f"{printable(path)}: line {i + 1}"
        try:
            rec = loads_json(decode_text(raw))
        except InputError as exc:  # a cut line is skipped; one too deep, NaN...: refused
            if exc.where or not exc.problem.startswith(_CUT):
                raise ValueError(f"{where}: {exc}") from None
            rec = None
        if not isinstance(rec, dict) or any(k not in rec for k in _REQUIRED):
            if last and tail_open:
                truncated = True
            else:
                bad.append(i + 1)
            continue
        problem = record_problem(rec)
        if problem is not None:
            raise ValueError(f"{where}: {problem}")
        k = key_of(rec)
        if k in seen:
            dup += 1
            continue
        seen.add(k)
        records.append(rec)
    return ReadReport(records, truncated, bad, dup)


def skipped_parts(read: ReadReport) -> list[str]:
    """What a read of a results file left out, one phrase each: "a truncated last line (an
    interrupted write)", "unreadable lines [2, 3]", "1 duplicate run". The one wording of the
    report's note and of the notes `bench` and `report` print.

    Args:
        read: what `read_records` returned.

    Returns:
        The phrases, in that order; [] when nothing was left out.
    """
    from planner_core.textio import counted, for_count

    return ((["a truncated last line (an interrupted write)"] if read.truncated_tail else [])
            + ([f"unreadable {for_count(len(read.bad_lines), 'line')} {read.bad_lines}"]
               if read.bad_lines else [])
            + ([counted(read.duplicates, "duplicate run")] if read.duplicates else []))


def skipped_note(path: str | Path, read: ReadReport) -> str | None:
    """The note a command prints when a read of a results file left lines out: "note: PATH:
    skipped unreadable lines [2, 3]" (`skipped_parts`; the file `stored_path` reads, escaped).

    Args:
        path: the results file read (with or without .gz, as given to `read_records`).
        read: what `read_records` returned for it.

    Returns:
        The note (one line), or None when nothing was left out.
    """
    from planner_core.textio import printable

    parts = skipped_parts(read)
    if not parts:
        return None
    return f"note: {printable(str(stored_path(path)))}: skipped {', '.join(parts)}"


def complete_runs(records: list[dict[str, Any]]) -> tuple[list[dict[str, Any]], list[int]]:
    """The records of the run indices every cell has finished, and the run indices left out.

    The cells are every (optimiser, task, start mode, I_max) combination of the values the
    records hold (the benchmark plans the full product); run r is complete when every cell has
    a record of run r. The benchmark runs run-major (every cell's run 0 before any run 1), so
    an unfinished benchmark leaves only its last run index(es) partial: leaving them out keeps
    every cell at the same number of runs (a fair comparison).

    Args:
        records: run records.

    Returns:
        (the records of complete runs, in their order; the sorted run indices left out).
    """
    keys = [key_of(r) for r in records]
    n_cells = math.prod(len({k[i] for k in keys}) for i in (0, 1, 3, 4))
    have: dict[int, set[tuple[str, str, str, int | None]]] = {}
    for k in keys:
        have.setdefault(k.run, set()).add((k.optimiser, k.task, k.init, k.i_max))
    complete = {run for run, c in have.items() if len(c) == n_cells}
    return ([r for r in records if key_of(r).run in complete],
            sorted(run for run in have if run not in complete))


#: the fields of a run record that the report's tables and study figures read (`slim_record`)
SLIM_FIELDS = ("optimiser", "task", "run", "seed", "budget", "init", "i_max", "schema", "score",
               "f", "phi", "feasible", "evaluations", "wall_s", "n_hover", "n_points",
               "last_feasible_rate")


def slim_record(record: dict[str, Any]) -> dict[str, Any]:
    """A run record cut to what the tables, the I_max study and the ablations' normalised
    performance read (:data:`SLIM_FIELDS`, and the first entry of the convergence trace: the
    incumbent after the first population); the map's hash, the hover points, x and the rest of
    the trace are dropped (they are what makes a record 3-6 kB). The convergence and best-path
    figures cannot be drawn from slim records; every table can, to the same digits.

    Args:
        record: a full run record.

    Returns:
        A new dict: the `SLIM_FIELDS` present, and "history" with the first entry of each of
        "evaluations", "best_f", "best_phi" present when the trace has a "best_f".
    """
    out = {k: record[k] for k in SLIM_FIELDS if k in record}
    h = record.get("history") or {}
    if h.get("best_f"):
        out["history"] = {k: list(h[k][:1]) for k in ("evaluations", "best_f", "best_phi")
                          if k in h}
    return out


def _repair_tail(path: Path) -> None:
    """Cut an unterminated last line (a partial record) or terminate a complete one."""
    if not path.exists():
        return
    with path.open("rb+") as fh:
        fh.seek(0, os.SEEK_END)
        size = fh.tell()
        if size == 0:
            return
        fh.seek(size - 1)
        if fh.read(1) == b"\n":
            return
        fh.seek(0)
        data = fh.read()
        cut = data.rfind(b"\n") + 1  # 0 when there is no newline at all
        tail = data[cut:]
        try:
            complete = isinstance(json.loads(tail), dict)
        except ValueError:
            complete = False
        if complete:
            fh.seek(0, os.SEEK_END)
            fh.write(b"\n")
        else:
            fh.truncate(cut)
        fh.flush()
        os.fsync(fh.fileno())


class ResultsWriter:
    """Appends records to a results file, one line each, flushed and synced per record."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        _repair_tail(self.path)
        self._fh: IO[str] | None = self.path.open("a", encoding="utf-8")

    def write(self, record: dict[str, Any]) -> None:
        """Append one record as a single JSON line and push it to disk (flush and fsync).

        Args:
            record: a JSON-serialisable run record.

        Raises:
            ValueError: the writer is closed.
        """
        if self._fh is None:
            raise ValueError("writer is closed")
        line = json.dumps(record, separators=(",", ":"))
        self._fh.write(line + "\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def __enter__(self) -> ResultsWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
