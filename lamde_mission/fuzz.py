"""Seeded mutations of input files, for the robustness tests and `benchmarks/fuzz_inputs.py`.

`mutate(data, rng)` returns a hostile variant of a file's bytes: JSON files are mutated as
trees (a value replaced by a hostile one, a key dropped or added, a list blown up, deep
nesting) and every file as bytes or text (bytes that are not UTF-8, NUL, a UTF-16 re-encoding,
truncation, a huge digit run, a field of a `.waypoints` line replaced). Same `rng` state, same
bytes. `run_cli(argv)` runs the command line in this process and captures its outcome.
"""

from __future__ import annotations

import codecs
import contextlib
import io
import json
import random
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

__all__ = ["HOSTILE_VALUES", "HOSTILE_TOKENS", "mutate", "run_cli", "CliOutcome"]

#: values a JSON mutation may put anywhere (floats beyond float32, int32, uint16 ... edges)
HOSTILE_VALUES: tuple[Any, ...] = (
    0, -1, 1, -5, 0.5, 1e-9, 1e-300, 1e39, -1e39, 3.5e38, 1e308, -1e308, 255, 256, 65535,
    65536, 99999, 2**31, -(2**31) - 1, 2**63, 2**64, 90.0000001, -180.5, 1e7, 1e15,
    "", "x", "16", "\u00e9", "\ud800", None, True, False, [], {}, [0], [1e308, 1e308],
    {"a": 1},
)  # fmt: skip

#: tokens for text formats (`.waypoints` fields) and for raw JSON number positions
HOSTILE_TOKENS: tuple[str, ...] = (
    "nan", "NaN", "inf", "-inf", "Infinity", "1e39", "-1e39", "1e308", "1e400", "99999",
    "-1", "256", "65536", "4294967296", "abc", "", "0x10", "1_0", "9" * 30, "9" * 5000,
    "\u00e9", "\t", "null", "true", "[", "}",
)  # fmt: skip


def _paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = [prefix]
    todo = [(prefix, node)]
    while todo:
        path, v = todo.pop()
        children: list[tuple[Any, Any]] = []
        if isinstance(v, dict):
            children = list(v.items())
        elif isinstance(v, list):
            children = list(enumerate(v))
        for k, c in children:
            out.append(path + (k,))
            todo.append((path + (k,), c))
    return out


def _get(node: Any, path: tuple[Any, ...]) -> Any:
    for k in path:
        node = node[k]
    return node


def _hostile_value(rng: random.Random) -> Any:
    r = rng.random()
    if r < 0.75:
        return rng.choice(HOSTILE_VALUES)
    if r < 0.85:
        depth = rng.choice((10, 70, 200))
        v: Any = 0
        for _ in range(depth):
            v = [v]
        return v
    if r < 0.95:
        return [rng.choice((0, 1.5, "a", None))] * rng.choice((10, 300, 3000))
    return rng.uniform(-1e6, 1e6)


def _mutate_tree(doc: Any, rng: random.Random) -> Any:
    paths = _paths(doc)
    if rng.random() < 0.25:  # a gentle change that often keeps the file valid: go deeper
        numeric = [p for p in paths if p and isinstance(_get(doc, p), int | float)
                   and not isinstance(_get(doc, p), bool)]  # fmt: skip
        if numeric:
            path = rng.choice(numeric)
            parent = _get(doc, path[:-1])
            parent[path[-1]] = parent[path[-1]] * rng.uniform(0.5, 1.5)
            return doc
    path = rng.choice(paths)
    op = rng.random()
    if not path or op < 0.55:
        if not path:
            return _hostile_value(rng)
        parent = _get(doc, path[:-1])
        parent[path[-1]] = _hostile_value(rng)
        return doc
    parent = _get(doc, path[:-1])
    if op < 0.7:
        del parent[path[-1]]
    elif op < 0.8 and isinstance(parent, dict):
        parent[rng.choice(("extra", "x", "max_sped", path[-1] + "_"))
               if isinstance(path[-1], str) else "extra"] = _hostile_value(rng)  # fmt: skip
    elif isinstance(parent, list):
        item = parent[path[-1]]
        parent.extend([json.loads(json.dumps(item))] * rng.choice((1, 5, 50, 500)))
    else:
        v = parent[path[-1]]
        if isinstance(v, int | float) and not isinstance(v, bool):
            parent[path[-1]] = v * rng.choice((-1, 0, 1e-12, 1e12, 1e300))
        else:
            parent[path[-1]] = _hostile_value(rng)
    return doc


_NUMBER = re.compile(rb"-?\d+(?:\.\d+)?(?:[eE][+-]?\d+)?")


def _mutate_bytes(data: bytes, rng: random.Random) -> bytes:
    op = rng.randrange(10)
    n = len(data)
    pos = rng.randrange(n + 1) if n else 0
    if op == 0 and n:  # flip one byte
        return data[:pos] + bytes([rng.randrange(256)]) + data[pos + 1 :]
    if op == 1:  # bytes that are not UTF-8, or NUL
        return data[:pos] + rng.choice((b"\xe9", b"\xff\xfe", b"\x00", b"\xc3", b"\xed\xa0\x80")) \
            + data[pos:]  # fmt: skip
    if op == 2:  # truncated
        return data[:pos]
    if op == 3:  # another encoding or a byte-order mark
        text = data.decode("utf-8", "replace")
        enc = rng.choice(("utf-16", "utf-16-le", "utf-32", "latin-1"))
        bom = codecs.BOM_UTF8 if rng.random() < 0.5 else b""
        return bom + text.encode(enc, "replace") if enc == "latin-1" else text.encode(enc)
    if op == 4:  # a number replaced by a hostile token
        nums = list(_NUMBER.finditer(data))
        if nums:
            m = rng.choice(nums)
            tok = rng.choice(HOSTILE_TOKENS).encode("utf-8")
            return data[: m.start()] + tok + data[m.end() :]
    if op == 5 and n:  # a slice repeated
        a = rng.randrange(n)
        b = min(n, a + rng.randrange(1, 200))
        return data[:b] + data[a:b] * rng.choice((2, 10, 100)) + data[b:]
    if op == 6:  # deep brackets
        return data[:pos] + b"[" * rng.choice((65, 1000, 50_000)) + data[pos:]
    if op == 7:  # a UTF-8 byte-order mark (allowed) plus another mutation
        return codecs.BOM_UTF8 + _mutate_bytes(data, rng)
    if op == 8:  # a tab-separated field replaced (.waypoints lines)
        lines = data.split(b"\n")
        k = rng.randrange(len(lines))
        fields = lines[k].split(b"\t")
        j = rng.randrange(len(fields))
        fields[j] = rng.choice(HOSTILE_TOKENS).encode("utf-8")
        lines[k] = b"\t".join(fields)
        return b"\n".join(lines)
    # a line duplicated many times
    lines = data.split(b"\n")
    k = rng.randrange(len(lines))
    return b"\n".join(lines[:k] + [lines[k]] * rng.choice((2, 100, 70_000)) + lines[k:])


def mutate(data: bytes, rng: random.Random, *, rounds: int | None = None) -> bytes:
    """A hostile variant of `data` (1-3 mutations; tree mutations when it is JSON).

    Args:
        data: the input file's bytes.
        rng: the random source (same seed, same variant).
        rounds: how many mutations; None: 1, 1, 2 or 3 drawn from `rng`.

    Returns:
        The mutated bytes (each round a tree mutation with probability 0.6 when `data` is
        JSON the standard parser reads, else a byte mutation).
    """
    k = rounds if rounds is not None else rng.choice((1, 1, 2, 3))
    for _ in range(k):
        tree = rng.random() < 0.6
        indent = rng.choice((None, 1))
        if tree:
            try:  # a tree mutation when the input is JSON the standard parser can hold
                doc = _mutate_tree(json.loads(data), rng)
                data = json.dumps(doc, indent=indent).encode("utf-8", "surrogatepass")
                continue
            except (ValueError, RecursionError):
                pass
        data = _mutate_bytes(data, rng)
    return data


@dataclass(frozen=True)
class CliOutcome:
    """What one in-process run of the command line did."""

    status: int | None  # exit status; None when it raised
    stdout: str
    stderr: str
    error: BaseException | None  # an exception that escaped main() (a traceback)


def run_cli(argv: Sequence[str]) -> CliOutcome:
    """Run `lamde-mission argv` in this process with stdout/stderr captured.

    Args:
        argv: the arguments after `lamde-mission`.

    Returns:
        The `CliOutcome`: the exit status (a SystemExit's code, 2 when it is not an int),
        or None and the exception when one escaped `main`.
    """
    from lamde_mission.cli import main

    out, err = io.StringIO(), io.StringIO()
    status: int | None = None
    error: BaseException | None = None
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main(list(argv))
        except SystemExit as exc:  # argparse
            status = exc.code if isinstance(exc.code, int) else 2
        except Exception as exc:  # noqa: BLE001 - reported, not hidden
            error = exc
    return CliOutcome(status, out.getvalue(), err.getvalue(), error)
