"""One decoding path for every text input: maps, `.plan`, `.waypoints` and GeoJSON files.

Every reader goes through `read_text` (and `loads_json` for JSON), so every file meets the same
rules before a single number reaches the model, numpy or a MAVLink packer:

- the path must name a regular file: a directory, a named pipe (FIFO), a socket or a device is
  refused from `os.stat` before anything is opened (a FIFO would block a reader forever);
- the file holds at most `limit("bytes")` bytes (default 64 MiB, `LAMDE_MAX_INPUT_BYTES`);
- the bytes are UTF-8 (a UTF-8 byte-order mark is accepted and dropped); anything else is named
  with the offending byte and its offset, and UTF-16/UTF-32 byte-order marks are recognised;
- JSON nests at most `limit("depth")` levels (default 64, `LAMDE_MAX_JSON_DEPTH`), measured by a
  linear scan *before* `json.loads`, so a 50,000-deep file never reaches the recursive parser;
- JSON integers have at most `MAX_INT_DIGITS` digits (every integer field of our formats fits in
  20), numbers overflowing a double (``1e400``) and the non-JSON ``NaN``/``Infinity`` literals are
  refused, and strings holding unpaired UTF-16 surrogates (``"\\ud800"``) are refused; each
  problem names the JSON field where it sits (``uav.max_speed``, ``mission.items[3].params[0]``).

Item counts (sensors, obstacles, vertices, mission items) are limits of the readers that know
the structure; their values live here, in `LIMITS`, so the README's table and the code agree.
A limit a user could need more of is read from an environment variable (a positive integer).

Errors are `InputError` (a ValueError): ``str(err)`` is one line, ``"<field>: <problem>"`` or just
``"<problem>"`` for the file as a whole; callers prefix the file name.

Run records (JSON lines, plain or gzip-compressed: `read_jsonl`, `read_maybe_gz`) are read here
too, so the benchmarks and the schedule selector share one reader; their ValueErrors already
name the file (and the line).
"""

from __future__ import annotations

import codecs
import json
import math
import os
import re
import stat
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "InputError",
    "Limit",
    "LIMITS",
    "MAX_INT_DIGITS",
    "limit",
    "json_path",
    "not_regular",
    "read_bytes",
    "decode_text",
    "read_text",
    "loads_json",
    "read_json",
    "stored_path",
    "read_maybe_gz",
    "read_jsonl",
    "printable",
    "counted",
    "did_you_mean",
    "first_few",
    "for_count",
    "rounded_up",
    "quoted",
]

#: most digits a JSON integer may have: our integer fields fit in 20 (uint64 has 20 digits);
#: Python refuses to convert strings of more than 4300 digits, and big ones cost quadratic time
MAX_INT_DIGITS = 20


@dataclass(frozen=True)
class Limit:
    """A size limit: its default, the environment variable that overrides it (None: fixed),
    and why it exists."""

    default: int
    env: str | None
    why: str


#: every size limit on input files, by name (README "Input limits" lists the same table)
LIMITS: dict[str, Limit] = {
    "bytes": Limit(
        64 * 1024 * 1024,
        "LAMDE_MAX_INPUT_BYTES",
        "size of one input file; the largest valid mission (65,535 items) is about 30 MB as a "
        ".plan",
    ),
    "depth": Limit(
        64,
        "LAMDE_MAX_JSON_DEPTH",
        "JSON nesting; maps nest 7 levels and GeoJSON 8, and a deep file would exhaust the "
        "parser's recursion",
    ),
    "sensors": Limit(
        1_000,
        "LAMDE_MAX_SENSORS",
        "sensors in one map; planning time grows with them: at the default budget ~15 s of "
        "CPU for 400 sensors, ~2-4 min for 1,000 (docs/maps.md, 'Bad files and input limits')",
    ),
    "obstacles": Limit(
        5_000,
        "LAMDE_MAX_OBSTACLES",
        "circles + rectangles + no-fly zones + polygon obstacles in one map; every leg is tested "
        "against each",
    ),
    "zone_vertices": Limit(
        5_000,
        "LAMDE_MAX_ZONE_VERTICES",
        "vertices of one no-fly zone (or polygon)",
    ),
    "vertices": Limit(
        50_000,
        "LAMDE_MAX_VERTICES",
        "vertices of all no-fly zones and polygon obstacles of one map together (holes included)",
    ),
    "results_bytes": Limit(
        256 * 1024 * 1024,
        "LAMDE_MAX_RESULTS_BYTES",
        "a benchmark's run records (results.jsonl, counted decompressed when gzip-compressed); "
        "a full benchmark (51 runs x 29 tasks x 10 optimisers, ~6 kB a record) is ~90 MB",
    ),
    "mission_items": Limit(
        65_535,
        None,
        "items in one mission or fence: MAVLink numbers them with a uint16 (seq, count)",
    ),
}


class InputError(ValueError):
    """Bad input found while decoding: `where` names the field ("" for the whole file)."""

    def __init__(self, problem: str, where: str = ""):
        self.problem = problem
        self.where = where
        super().__init__(f"{where}: {problem}" if where else problem)


def limit(name: str) -> int:
    """The limit `name` in force: its environment variable if set (not blank), else the
    default (`LIMITS`).

    Args:
        name: a key of `LIMITS` ("bytes", "depth", "sensors", ...).

    Returns:
        The limit (a count: bytes, levels, items or vertices, as `LIMITS[name]` says).

    Raises:
        InputError: the variable is set to anything but a positive integer of at most 12
            digits (underscores allowed); its `where` names the variable.
        KeyError: `name` is not a key of `LIMITS` (a bug in the caller).
    """
    lim = LIMITS[name]
    if lim.env is None:
        return lim.default
    raw = os.environ.get(lim.env)
    if raw is None or raw.strip() == "":
        return lim.default
    s = raw.strip().replace("_", "")
    if not (s.isascii() and s.isdigit()) or len(s) > 12 or int(s) < 1:
        raise InputError(f"must be a positive integer (at most 12 digits), got {raw[:40]!r}",
                         lim.env)  # fmt: skip
    return int(s)


def json_path(parts: Any) -> str:
    """The dotted name of a field in a JSON document, for error messages.

    Args:
        parts: the path from the top: keys (any object, shown as str) and list indices
            (ints), e.g. ``("uav", "max_speed")`` or ``("mission", "items", 3)``.

    Returns:
        E.g. "uav.max_speed" or "mission.items[3]" ("" for no parts); a key that is not
        printable or is longer than 80 characters is shown by `ascii` of its first 80, so the
        name stays one line.
    """
    out = ""
    for part in parts:
        if isinstance(part, int):
            out += f"[{part}]"
            continue
        name = str(part)
        if not name.isprintable() or len(name) > 80:  # a key with a newline stays one line
            name = ascii(name[:80])
        out += f".{name}" if out else name
    return out


# ----------------------------------------------------------------------------- bytes


_KINDS = (
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISFIFO, "a named pipe (FIFO)"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
)


def not_regular(mode: int) -> str:
    """Why a file of this mode cannot be read or written as a file.

    Args:
        mode: an `os.stat_result.st_mode` that is not a regular file's.

    Returns:
        E.g. "is a directory, not a regular file" or "is a named pipe (FIFO), not a regular
        file" (to follow the file's name in a message).
    """
    for test, name in _KINDS:
        if test(mode):
            return f"is {name}, not a regular file"
    return "is not a regular file"


def read_bytes(path: str | Path, *, max_bytes: int | None = None, limit_name: str = "bytes",
               gunzip: bool = False) -> bytes:  # fmt: skip
    """The bytes of a regular file, bounded.

    A non-regular file is refused from `os.stat` before it is opened; the file is then opened
    non-blocking and checked again (it may have been swapped).

    Args:
        path: the file.
        max_bytes: the most bytes it may hold (None: `limit(limit_name)`).
        limit_name: the `LIMITS` entry that bounds it when `max_bytes` is None, and whose
            variable the "too big" message names.
        gunzip: the file is gzip (RFC 1952; one or more members): its decompressed bytes are
            returned, bounded by the same limit while they are decompressed (a 3 MB file of
            zeros never becomes gigabytes).

    Returns:
        The file's bytes (decompressed with `gunzip`).

    Raises:
        InputError: a missing, unreadable, non-regular, oversized or (gunzip) corrupt or
            truncated file, with no `where`; or the limit's variable set to a bad value
            (`limit`), naming it.
    """
    env = LIMITS[limit_name].env
    cap = limit(limit_name) if max_bytes is None else int(max_bytes)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise InputError("file not found") from None
    except OSError as exc:
        raise InputError(f"cannot read ({exc.strerror or exc})") from None
    except ValueError as exc:  # embedded NUL in the path
        raise InputError(f"not a usable path ({exc})") from None
    if not stat.S_ISREG(st.st_mode):
        raise InputError(not_regular(st.st_mode))
    if st.st_size > cap:
        raise InputError(_too_big(st.st_size, cap, env))
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as exc:
        raise InputError(f"cannot read ({exc.strerror or exc})") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise InputError(not_regular(st.st_mode))
        with os.fdopen(fd, "rb", closefd=False) as fh:
            # the size it has, plus one byte to see it grow (a read of cap + 1 bytes would
            # allocate the whole limit, 64 MiB, for every small file)
            data = fh.read(min(cap, st.st_size) + 1)
            if st.st_size < len(data) <= cap:  # it grew while read: up to the limit
                data += fh.read(cap + 1 - len(data))
    except OSError as exc:
        raise InputError(f"cannot read ({exc.strerror or exc})") from None
    finally:
        os.close(fd)
    if len(data) > cap:
        raise InputError(_too_big(len(data), cap, env))
    return _gunzip(data, cap, env) if gunzip else data


def _too_big(size: int, cap: int, env: str | None) -> str:
    return f"file is {size:,} bytes, more than the limit of {cap:,} (raise it with {env})"


def _gunzip(data: bytes, cap: int, env: str | None) -> bytes:
    """The decompressed bytes of gzip `data` (members one after another, as `gzip.decompress`
    reads them; zero padding after the last ignored), never more than `cap`: InputError once
    more would come, or for data that is not gzip or ends mid-stream."""
    import zlib

    out = bytearray()
    rest = data
    while rest and rest.strip(b"\x00"):
        d = zlib.decompressobj(wbits=31)
        try:
            out += d.decompress(rest, cap + 1 - len(out))
        except zlib.error as exc:
            raise InputError(f"not valid gzip data ({exc})") from None
        if len(out) > cap:
            raise InputError(f"decompresses to more than the limit of {cap:,} bytes (raise it "
                             f"with {env})")  # fmt: skip
        if not d.eof:
            raise InputError("the gzip data ends before its stream does (a truncated file)")
        rest = d.unused_data
    return bytes(out)


_FOREIGN_BOMS = (
    (codecs.BOM_UTF32_LE, "UTF-32 (little-endian)"),
    (codecs.BOM_UTF32_BE, "UTF-32 (big-endian)"),
    (codecs.BOM_UTF16_LE, "UTF-16 (little-endian)"),
    (codecs.BOM_UTF16_BE, "UTF-16 (big-endian)"),
)


def decode_text(data: bytes) -> str:
    """Bytes as UTF-8 text (RFC 3629), a leading UTF-8 byte-order mark dropped.

    Args:
        data: a file's bytes.

    Returns:
        The text.

    Raises:
        InputError: the bytes are not UTF-8 (the message names the first offending byte, its
            offset in the file and its line), start with a UTF-16/UTF-32 byte-order mark (the
            message names that encoding), or hold a NUL character.
    """
    skip = 0
    if data.startswith(codecs.BOM_UTF8):
        skip = len(codecs.BOM_UTF8)
    else:
        for bom, name in _FOREIGN_BOMS:
            if data.startswith(bom):
                raise InputError(f"not UTF-8: the file starts with a {name} byte-order mark; "
                                 "save it as UTF-8")  # fmt: skip
    try:
        text = data[skip:].decode("utf-8")
    except UnicodeDecodeError as exc:
        off = skip + exc.start
        line = data.count(b"\n", 0, off) + 1
        raise InputError(f"not UTF-8 (byte 0x{data[off]:02X} at offset {off}, line {line}); "
                         "save the file as UTF-8") from None  # fmt: skip
    nul = text.find("\x00")
    if nul >= 0:
        line = text.count("\n", 0, nul) + 1
        raise InputError(f"contains a NUL character (offset {nul + skip}, line {line}); "
                         "a text file in UTF-8 is expected (UTF-16 without a byte-order mark?)")
    return text


def read_text(path: str | Path, *, max_bytes: int | None = None, limit_name: str = "bytes",
              gunzip: bool = False) -> str:  # fmt: skip
    """The text of a regular, bounded, UTF-8 file: `read_bytes` then `decode_text`.

    Args:
        path, max_bytes, limit_name, gunzip: as for `read_bytes`.

    Returns:
        The text (a UTF-8 byte-order mark dropped).

    Raises:
        InputError: as `read_bytes` and `decode_text` raise it.
    """
    return decode_text(read_bytes(path, max_bytes=max_bytes, limit_name=limit_name,
                                  gunzip=gunzip))


# ----------------------------------------------------------------------------- JSON

# a JSON string (unrolled loop: no backtracking per character), or one structural character
_STRING = r'"[^"\\]*(?:\\.[^"\\]*)*"'
_TOKEN_RE = re.compile(_STRING + r"|[\[\]{}:,]", re.S)
_SURROGATE_ESCAPE = re.compile(r"\\u[dD][89a-fA-F]")
_OPEN = np.zeros(256, dtype=np.int8)
_OPEN[[ord("["), ord("{")]] = 1
_OPEN[[ord("]"), ord("}")]] = -1


def _may_exceed_depth(text: str, max_depth: int) -> bool:
    """A fast screen over every bracket, strings included (numpy, no regex).

    Brackets inside strings can only mislead it in two ways: openers make it say True (the
    exact `_depth_error` scan then decides), and closers hide real depth (a file would need as
    many "]" in strings as levels of nesting; `loads_json` still catches the RecursionError).
    """
    if text.count("[") + text.count("{") <= max_depth:
        return False
    steps = _OPEN[np.frombuffer(text.encode("utf-8", "surrogatepass"), dtype=np.uint8)]
    steps = steps[steps != 0].astype(np.int32)
    return bool(steps.size) and int(np.cumsum(steps).max()) > max_depth


def _depth_error(text: str, max_depth: int) -> InputError | None:
    """Walk the tokens, tracking the path, up to the first container deeper than `max_depth`."""
    stack: list[list[Any]] = []  # [kind, key or index, expecting a key]
    for tok in _TOKEN_RE.finditer(text):
        c = tok.group()
        if c in "[{":
            if len(stack) >= max_depth:
                parts = [e[1] for e in stack if e[1] is not None]
                shown = json_path(parts[:6]) + ("..." if len(parts) > 6 else "")
                off = tok.start()
                line = text.count("\n", 0, off) + 1
                col = off - (text.rfind("\n", 0, off) + 1) + 1
                return InputError(
                    f"nested deeper than {max_depth} levels of arrays/objects (line {line}, "
                    f"column {col}; limit {LIMITS['depth'].env})",
                    shown or "(top level)",
                )
            stack.append(["obj", None, True] if c == "{" else ["arr", 0, False])
        elif c in "]}":
            if not stack:
                return None  # malformed: json.loads will say where
            stack.pop()
        elif c == ",":
            if stack and stack[-1][0] == "arr":
                stack[-1][1] += 1
            elif stack:
                stack[-1][2] = True
        elif c == ":":
            if stack:
                stack[-1][2] = False
        elif stack and stack[-1][0] == "obj" and stack[-1][2]:
            try:
                stack[-1][1] = json.loads(c)
            except ValueError:
                stack[-1][1] = c[1:-1]
    return None


class _Bad:
    """Placeholder the number hooks return for a refused number; the walk finds its path."""

    __slots__ = ("problem",)

    def __init__(self, problem: str):
        self.problem = problem


def _walk(data: Any) -> Iterator[tuple[tuple[Any, ...], Any, bool]]:
    """(path, value, is_key) for every node, depth first, without recursion."""
    todo: list[tuple[tuple[Any, ...], Any]] = [((), data)]
    while todo:
        path, v = todo.pop()
        yield path, v, False
        if isinstance(v, dict):
            for k in reversed(list(v)):
                yield path + (k,), k, True
                todo.append((path + (k,), v[k]))
        elif isinstance(v, list):
            todo.extend((path + (i,), v[i]) for i in range(len(v) - 1, -1, -1))


def _lone_surrogate(s: str) -> bool:
    try:
        s.encode("utf-8")
    except UnicodeEncodeError:
        return True
    return False


def loads_json(text: str, *, max_depth: int | None = None) -> Any:
    """Parse JSON text (RFC 8259) under the module's rules.

    Args:
        text: the JSON text.
        max_depth: the most levels of arrays/objects (None: `limit("depth")`).

    Returns:
        The value (dict, list, str, int, float, bool or None); every float is finite.

    Raises:
        InputError: text that is not JSON (line and column), nests deeper than `max_depth`,
            or holds an integer longer than `MAX_INT_DIGITS` digits, a number beyond a
            double's range, a NaN/Infinity literal, an unpaired surrogate or a key repeated
            within one object (Python's json keeps the last silently; RFC 8259 says names
            SHOULD be unique); `where` names the field.
    """
    depth = limit("depth") if max_depth is None else int(max_depth)
    if _may_exceed_depth(text, depth):
        err = _depth_error(text, depth)
        if err is not None:
            raise err
    bad: list[_Bad] = []

    def parse_int(s: str) -> Any:
        digits = len(s) - (s[0] == "-")
        if digits > MAX_INT_DIGITS:
            b = _Bad(f"an integer of {digits} digits is out of range (at most {MAX_INT_DIGITS})")
            bad.append(b)
            return b
        return int(s)

    def parse_float(s: str) -> Any:
        v = float(s)
        if not math.isfinite(v):
            b = _Bad(f"{s[:24]}{'...' if len(s) > 24 else ''} is beyond the range of a double "
                     "(about 1.8e308)")  # fmt: skip
            bad.append(b)
            return b
        return v

    def parse_constant(s: str) -> Any:
        b = _Bad(f"{s} is not a JSON number (JSON has no NaN or Infinity)")
        bad.append(b)
        return b

    dups: list[tuple[dict, str]] = []

    def pairs(items: list[tuple[str, Any]]) -> dict:
        obj = dict(items)
        if len(obj) != len(items) and not dups:  # RFC 8259: names SHOULD be unique
            seen: set[str] = set()
            for k, _ in items:
                if k in seen:
                    dups.append((obj, k))
                    break
                seen.add(k)
        return obj

    try:
        data = json.loads(text, parse_int=parse_int, parse_float=parse_float,
                          parse_constant=parse_constant, object_pairs_hook=pairs)  # fmt: skip
    except json.JSONDecodeError as exc:
        raise InputError(f"not valid JSON ({exc.msg} at line {exc.lineno}, column {exc.colno})"
                         ) from None  # fmt: skip
    except RecursionError:  # only when strings full of "]" hid the depth from the screen
        raise InputError(f"nested too deeply to parse (limit {LIMITS['depth'].env})") from None
    if dups:
        obj, key = dups[0]
        for path, v, _is_key in _walk(data):
            if v is obj:
                raise InputError("this key appears more than once in its object (JSON leaves "
                                 "open which one counts; keep one)",
                                 json_path((*path, key)))  # fmt: skip
    if bad:
        first = bad[0]
        for path, v, _is_key in _walk(data):
            if v is first:
                raise InputError(first.problem, json_path(path) or "(top level)")
        raise InputError(first.problem)  # a dict key cannot be a number: not reached
    if _SURROGATE_ESCAPE.search(text):
        for path, v, is_key in _walk(data):
            if isinstance(v, str) and _lone_surrogate(v):
                what = "key" if is_key else "string"
                where = json_path(path[:-1] if is_key else path) or "(top level)"
                raise InputError(f"a {what} holds an unpaired UTF-16 surrogate "
                                 "(\\ud800-\\udfff escape); not valid Unicode", where)
    return data


def read_json(path: str | Path, *, max_bytes: int | None = None,
              max_depth: int | None = None) -> Any:  # fmt: skip
    """The JSON value of a file, under every rule of the module: `read_text` then
    `loads_json`.

    Args:
        path: the file.
        max_bytes: the most bytes it may hold (None: `limit("bytes")`).
        max_depth: the most levels of nesting (None: `limit("depth")`).

    Returns:
        The value, as `loads_json` returns it.

    Raises:
        InputError: as `read_text` and `loads_json` raise it.
    """
    return loads_json(read_text(path, max_bytes=max_bytes), max_depth=max_depth)


def stored_path(path: str | Path) -> Path:
    """`path` as stored: itself when it exists, else its gzip-compressed twin (`path` + .gz,
    or `path` without .gz) when that exists, else `path` unchanged.

    Args:
        path: the file as named (with or without .gz).

    Returns:
        The path to read, as a Path.
    """
    path = Path(path)
    if path.exists():
        return path
    twin = path.with_name(path.name[:-3]) if path.name.endswith(".gz") else \
        path.with_name(path.name + ".gz")
    return twin if twin.exists() else path


def read_maybe_gz(path: str | Path) -> bytes:
    """The bytes of a file, decompressed when it is gzip-compressed (name ending in .gz);
    `results.jsonl` reads `results.jsonl.gz` when only that exists (`stored_path`). Read by
    `read_bytes`: a regular file (a FIFO or device is refused, never waited on), at most
    `limit("results_bytes")` bytes, decompressed ones included.

    Args:
        path: the file; its gzip twin is read when only that exists.

    Returns:
        The file's bytes, decompressed when the stored name ends in .gz.

    Raises:
        ValueError: naming the file, for a missing, unreadable, non-regular, oversized or
            corrupt (gzip) file (the `InputError` of `read_bytes`).
    """
    path = stored_path(path)
    try:
        return read_bytes(path, limit_name="results_bytes", gunzip=path.name.endswith(".gz"))
    except InputError as exc:
        raise ValueError(f"{printable(path)}: {exc}") from None


def read_jsonl(path: str | Path) -> list[dict[str, Any]]:
    """Every record of a JSON-lines file (run records: the benchmarks', the schedule
    selector's), compressed or not (`read_maybe_gz`).

    Args:
        path: the file; a name ending in .gz is gzip-compressed.

    Returns:
        The records in file order, each line parsed by `loads_json` (bounded depth, no NaN);
        blank lines skipped.

    Raises:
        ValueError: naming the file (and the line) for a missing, non-regular, oversized,
            corrupt or non-UTF-8 file or a line that is not JSON under these rules.
    """
    try:
        text = decode_text(read_maybe_gz(path))
    except InputError as exc:
        raise ValueError(f"{printable(path)}: {exc}") from None
    out = []
    for n, line in enumerate(text.splitlines(), 1):
        if line.strip():
            try:
                out.append(loads_json(line))
            except InputError as exc:
                raise ValueError(f"{printable(path)}: line {n}: {exc}") from None
    return out


_ESCAPES = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}


def printable(text: object) -> str:
    """Text safe to print on a terminal: control characters (C0, DEL, C1), format characters
    (bidi overrides, zero-width), line/paragraph separators and lone surrogates (Unicode
    general categories Cc, Cf, Zl, Zp, Cs) shown as escapes (``\\n``, ``\\x1b``,
    ``\\u202e``), so a map's name or a sensor id cannot forge lines of a summary or send
    terminal escape codes. Other text (accents, CJK) is kept as it is.

    Args:
        text: anything; its `str` is escaped.

    Returns:
        The escaped text (one line).
    """
    import unicodedata

    out = []
    for ch in str(text):
        cat = unicodedata.category(ch)
        if cat in ("Cc", "Cf", "Zl", "Zp", "Cs"):
            if ch in _ESCAPES:
                out.append(_ESCAPES[ch])
            elif ord(ch) < 0x100:
                out.append(f"\\x{ord(ch):02x}")
            else:
                out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return "".join(out)


def quoted(value: object, width: int = 40) -> str:
    """`repr(value)` for a one-line message, cut short and escaped by `printable`: a file's
    multi-megabyte string (or list, or object) is never copied whole into an error line, nor
    are its control characters. `reprlib` abbreviates long strings and containers before
    anything is joined (no copy of the whole value).

    Args:
        value: anything.
        width: about how many characters to keep (at least 8 per abbreviated part); a longer
            repr is cut to width - 3 characters and "...".

    Returns:
        The quoted, escaped text (its escapes may make it longer than `width`).
    """
    import reprlib

    r = reprlib.Repr()
    r.maxlevel, r.maxdict, r.maxlist, r.maxtuple, r.maxset = 2, 4, 6, 6, 6
    r.maxstring = r.maxother = r.maxlong = max(width, 8)
    text = r.repr(value)
    if len(text) > width:
        text = text[: max(width - 3, 1)] + "..."
    return printable(text)


def for_count(n: int, one: str, many: str | None = None) -> str:
    """The word that goes with a count of n, singular for 1 only: a noun after a list of
    names ("unknown optimiser x", "optimisers x, y") or a verb agreeing with a count ("the 1
    depot feature replaces", "the 2 ... replace"). The one place lines choose the plural
    (`counted` goes through it).

    Args:
        n: the count.
        one: the form for 1 ("optimiser", "replaces").
        many: the form for any other count where it is not one + "s" ("replace", "vertices").

    Returns:
        `one` or `many`.
    """
    return one if n == 1 else (many or one + "s")


def did_you_mean(word: object, known: Iterable[str]) -> str:
    """The hint after an unknown field: " (did you mean 'x'?)" naming the known name nearest
    to `word` (difflib's ratio, at least 0.6), "" when none is near. The one hint the map
    reader and fleet.json's reader give. O(len(known)).

    Args:
        word: the field as given.
        known: the names the place holds.

    Returns:
        The hint, with its leading space, or "".
    """
    import difflib

    close = difflib.get_close_matches(str(word), list(known), n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


def first_few(items: Sequence[str], most: int = 3, total: int | None = None) -> str:
    """"a, b, c and 4 more": the first `most` of `items` joined by commas, then how many
    more there are; the way a one-line message names a long list. O(most).

    Args:
        items: the names, already quoted or formatted as the message shows them.
        most: how many to name.
        total: how many there are in all (None: len(items)), where the caller holds only
            the first few.

    Returns:
        The words ("" for no items).
    """
    n = len(items) if total is None else int(total)
    return ", ".join(items[:most]) + (f" and {n - most} more" if n > most else "")


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """"1 obstacle", "0 obstacles", "1,001 sorties": a count (thousands separated) and its
    noun, singular for 1 only (`for_count`). What the CLI's lines count goes through it ("1
    obstacles", "1 battery swaps" were printed).

    Args:
        n: the count.
        noun: the singular ("battery swap", "no-fly zone").
        plural: the plural where it is not noun + "s".

    Returns:
        "{n:,} {noun}" or "{n:,} {plural}".
    """
    return f"{n:,} {for_count(n, noun, plural)}"


def rounded_up(x: float, places: int = 0) -> float:
    """The least multiple of 10^-places not below x: a value a message suggests (a battery
    that would do), printed with `places` decimals, that still does once printed (14.3076 Wh
    prints 14.31, 15.2615 prints 15.27 where round-to-nearest would print a too-small 15.26).

    Args:
        x: the value, finite.
        places: decimals it is printed with (0: a whole number).

    Returns:
        The rounded-up value, >= x; print it with f"{v:.{places}f}".
    """
    scale = 10.0**places
    k = math.ceil(x * scale)
    if k / scale < x:  # x * scale rounded down in floating point
        k += 1
    return k / scale
