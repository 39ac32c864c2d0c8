"""Readers and writers under hostile input (an adversarial review): outputs that are devices
or FIFOs are never replaced, malformed sections are one line naming the field (exit 2, no
traceback), reads are bounded, printed text is escaped."""

from __future__ import annotations

import json
import os
import re
import warnings
from pathlib import Path

import pytest

from lamde_mission.cli import main
from tests.conftest import MAPS

TINY = MAPS / "tiny.json"


def _run(capsys: pytest.CaptureFixture[str], *args: str | Path) -> tuple[int, str, str]:
    """`lamde-mission ARGS` in this process: (status, stdout, stderr)."""
    rc = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return rc, out, err


def _one_line(rc: int, err: str) -> str:
    assert rc == 2, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    return lines[0]


@pytest.fixture()
def tiny_geojson(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> Path:
    out = tmp_path / "tiny.geojson"
    assert _run(capsys, "map", "to-geojson", TINY, "-o", out)[0] == 0
    return out


# ----------------------------------------------------------------------------- 1: outputs


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
def test_map_commands_never_replace_a_fifo_or_make_folders(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tiny_geojson: Path
) -> None:
    fifo = tmp_path / "out.fifo"
    os.mkfifo(fifo)
    for i, args in enumerate((("from-geojson", tiny_geojson), ("to-geojson", TINY))):
        rc, out, err = _run(capsys, "map", *args, "-o", fifo)
        assert "not a regular file" in _one_line(rc, err) and "-o/--output" in err
        assert out == "" and fifo.is_fifo()
        deep = tmp_path / f"new{i}" / "sub" / "x.json"
        rc, out, err = _run(capsys, "map", *args, "-o", deep)
        assert "--mkdir" in _one_line(rc, err) and not (tmp_path / f"new{i}").exists()
        rc, out, err = _run(capsys, "map", *args, "-o", deep, "--mkdir")
        assert rc == 0 and deep.is_file(), err


# ----------------------------------------------------------------------------- 2: tracebacks

FLY = Path(__file__).parent / "data" / "flyable"
RALLY = FLY / "rally-and-jump.plan"


def _plan_with(tmp_path: Path, change) -> Path:
    doc = json.loads(RALLY.read_text())
    change(doc)
    out = tmp_path / "bad.plan"
    out.write_text(json.dumps(doc))
    return out


_SECTIONS = {
    "geoFence.polygons": lambda d: d["geoFence"].__setitem__("polygons", 5),
    "geoFence.circles": lambda d: d["geoFence"].__setitem__("circles", 7),
    "geoFence.polygons: expected a list, got true":
        lambda d: d["geoFence"].__setitem__("polygons", True),
    "rallyPoints.points": lambda d: d["rallyPoints"].__setitem__("points", 7),
    "geoFence: expected an object": lambda d: d.__setitem__("geoFence", [1]),
    "mission: expected an object": lambda d: d.__setitem__("mission", [1]),
}


@pytest.mark.parametrize("needle", list(_SECTIONS))
def test_plan_sections_of_the_wrong_type_are_one_line(
    needle: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = _plan_with(tmp_path, _SECTIONS[needle])
    for args in (("verify", FLY / "tiny-map.json", bad),
                 ("upload", bad, "--connect", "udpout:127.0.0.1:9", "--timeout", "1"),
                 ("map", "from-geojson", bad, "-o", tmp_path / "m.json")):  # fmt: skip
        rc, out, err = _run(capsys, *args)
        line = _one_line(rc, err)
        assert needle in line and str(bad) in line, (args, err)


def test_geojson_crs_properties_not_an_object(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    src = tmp_path / "c.geojson"
    src.write_text('{"type":"FeatureCollection","crs":{"properties":[1]},"features":[]}')
    rc, out, err = _run(capsys, "map", "from-geojson", src, "-o", tmp_path / "m.json")
    assert "crs" in _one_line(rc, err) and "not WGS84" in err


def _fc(*features: dict) -> dict:
    return {"type": "FeatureCollection", "features": list(features)}


def _pt(kind: str, lon: float, lat: float, **props: object) -> dict:
    return {"type": "Feature", "geometry": {"type": "Point", "coordinates": [lon, lat]},
            "properties": {"kind": kind, **props}}  # fmt: skip


_BASE = [_pt("sensor", 114.176, 22.324, id="s1"), _pt("start", 114.175, 22.323),
         _pt("end", 114.177, 22.325)]  # fmt: skip
_SQUARE = [[114.1754, 22.3234], [114.1756, 22.3234], [114.1756, 22.3236],
           [114.1754, 22.3236], [114.1754, 22.3234]]  # fmt: skip


@pytest.mark.parametrize("feature, field", [
    ({"type": "Feature", "geometry": {"type": "Polygon", "coordinates": [_SQUARE]},
      "properties": {"kind": "building", "shape": "rectangle", "center": [114.1755, 22.3235],
                     "length_m": 1e308, "width_m": 5, "angle_deg": 0}}, "length_m"),
    ({"type": "Feature", "geometry": None,
      "properties": {"kind": "circle", "center": [114.1755, 22.3235], "radius_m": 1e308}},
     "radius_m"),
])  # fmt: skip
def test_huge_obstacle_sizes_are_one_line_naming_the_field(
    feature: dict, field: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    src = tmp_path / "big.geojson"
    src.write_text(json.dumps(_fc(*_BASE, feature)))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning of an overflow either
        rc, out, err = _run(capsys, "map", "from-geojson", src, "-o", tmp_path / "m.json")
    line = _one_line(rc, err)
    assert f"features[3] {field}: 1e+308 m is more than" in line, err


# ----------------------------------------------------------------------------- report's reads

RUNS = Path(__file__).resolve().parent.parent / "docs" / "reduced" / "runs"


def _records(n: int = 3) -> list[dict]:
    import gzip

    lines = gzip.decompress((RUNS / "results.jsonl.gz").read_bytes()).decode().splitlines()
    return [json.loads(ln) for ln in lines[:n]]


def _results(folder: Path, records: list[dict] | None = None, meta: str | None = None) -> Path:
    folder.mkdir(exist_ok=True)
    recs = _records() if records is None else records
    (folder / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))
    (folder / "meta.json").write_text((RUNS / "meta.json").read_text() if meta is None else meta)
    return folder


def _report_refuses(capsys, folder: Path, needle: str) -> str:
    rc, out, err = _run(capsys, "report", folder, "-o", folder / "r.md")
    line = _one_line(rc, err)
    assert needle in line, err
    assert not (folder / "r.md").exists()
    return line


def test_report_bounds_a_gzip_bomb(tmp_path: Path, capsys, monkeypatch) -> None:
    import zlib

    monkeypatch.setenv("LAMDE_MAX_RESULTS_BYTES", "1000000")
    folder = tmp_path / "bomb"
    folder.mkdir()
    c = zlib.compressobj(9, zlib.DEFLATED, 31)
    (folder / "results.jsonl.gz").write_bytes(c.compress(b" " * 3_000_000) + c.flush())
    _report_refuses(capsys, folder, "decompresses to more than the limit of 1,000,000 bytes")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
@pytest.mark.timeout(60)  # a FIFO read would wait for a writer forever
def test_report_refuses_devices_and_fifos_without_reading(tmp_path: Path, capsys) -> None:
    folder = _results(tmp_path / "dev")
    (folder / "results.jsonl").unlink()
    (folder / "results.jsonl").symlink_to("/dev/zero")
    _report_refuses(capsys, folder, "results.jsonl: is a character device")
    (folder / "results.jsonl").unlink()
    os.mkfifo(folder / "results.jsonl")
    _report_refuses(capsys, folder, "results.jsonl: is a named pipe (FIFO)")
    folder = _results(tmp_path / "meta")
    (folder / "meta.json").unlink()
    os.mkfifo(folder / "meta.json")
    _report_refuses(capsys, folder, "meta.json: is a named pipe (FIFO)")


def test_report_refuses_deep_nan_and_malformed_records_naming_the_field(
    tmp_path: Path, capsys
) -> None:
    folder = _results(tmp_path / "deep")
    (folder / "results.jsonl").write_text("[" * 100_000 + "]" * 100_000 + "\n")
    _report_refuses(capsys, folder, "results.jsonl: line 1: [0][0]")
    recs = _records()
    (folder / "results.jsonl").write_text(json.dumps(recs[0]) + "\n")
    (folder / "meta.json").write_text('{"a":' * 100_000 + "1" + "}" * 100_000)
    _report_refuses(capsys, folder, "meta.json: a.a.a")
    (folder / "meta.json").write_bytes(b'\xff{}')
    _report_refuses(capsys, folder, "meta.json: not UTF-8")
    for meta, needle in (('{"commands": [1]}', "meta.json: commands[0]: expected an object"),
                         ('{"suite": 5}', "meta.json: suite: expected a string")):  # fmt: skip
        (folder / "meta.json").write_text(meta)
        _report_refuses(capsys, folder, needle)
    for field, value, needle in (("score", "NaN", "line 2: score: NaN is not a JSON number"),
                                 ("f", "Infinity", "line 2: f: Infinity is not"),
                                 ("history", "[1]", "line 2: history: expected an object"),
                                 ("history", '{"best_f": 5}', "line 2: history.best_f: "
                                  "expected a list")):  # fmt: skip
        bad = json.dumps({**recs[1], field: "@"}).replace('"@"', value)
        folder = _results(tmp_path / f"bad-{field}-{len(value)}", records=[])
        (folder / "results.jsonl").write_text(json.dumps(recs[0]) + "\n" + bad + "\n")
        _report_refuses(capsys, folder, needle)


def test_report_says_on_stderr_which_lines_it_skipped(tmp_path: Path, capsys) -> None:
    """A garbage line or a record without "task" in the middle of results.jsonl was skipped
    with a note inside the markdown only: exit 0 and tables over fewer runs, nothing on the
    terminal. Now the note `bench` prints when it resumes the folder (file and line numbers)
    is on stderr too; still exit 0, as bench runs those runs again and goes on (an error here
    would refuse a folder bench calls whole)."""
    r0, r1, r2 = _records()
    folder = _results(tmp_path / "runs", records=[])
    lines = [json.dumps(r0), "garbage{", json.dumps({k: v for k, v in r1.items() if k != "task"}),
             json.dumps(r2), json.dumps(r0)]
    results = folder / "results.jsonl"
    results.write_text("\n".join(lines) + "\n" + json.dumps(r1)[:40])  # a cut last line
    rc, out, err = _run(capsys, "report", folder, "-o", tmp_path / "r.md", "--no-limits")
    assert rc == 0, err
    assert err.splitlines() == [f"note: {results}: skipped a truncated last line (an "
                                "interrupted write), unreadable lines [2, 3], 1 duplicate run; "
                                "their runs are not in the report"]
    (line,) = out.splitlines()  # the report, and where its figures went (a reviewer's nit)
    assert line.startswith(f"report: wrote {tmp_path / 'r.md'} and ") and line.endswith(
        f" figures in {tmp_path / 'r'}/")
    assert ("Note: skipped in the results file: a truncated last line (an interrupted write), "
            "unreadable lines [2, 3], 1 duplicate run.") in (tmp_path / "r.md").read_text()
    # a whole file: no note
    _results(folder, records=[r0, r1, r2])
    rc, out, err = _run(capsys, "report", folder, "-o", tmp_path / "r.md", "--no-limits")
    assert rc == 0 and err == "", err


def _tree(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


def test_report_outputs_under_a_file_are_one_line_before_any_figure(tmp_path: Path,
                                                                     capsys) -> None:
    """A report or figures path under a file ended in a NotADirectoryError traceback (exit 1)
    after the report's figures were drawn; now one line naming the option, exit 2, nothing
    written (as `plan -o` and `lam select -o`)."""
    folder = _results(tmp_path / "runs")
    afile = tmp_path / "afile"
    afile.write_text("x")
    (tmp_path / "r").write_text("mine")  # where r.md's figures would go
    before = _tree(tmp_path)
    for args, needle in (
        (["-o", afile / "sub" / "r.md"], f"-o/--output: {afile / 'sub' / 'r.md'}: {afile} is "
         "a file, not a folder"),
        (["-o", tmp_path / "x.md", "--figures", afile / "f"], f"--figures: {afile / 'f'}: "
         f"{afile} is a file, not a folder"),
        (["-o", tmp_path / "r.md"], f"-o/--output (its figures' folder): {tmp_path / 'r'}: is "
         "a file, not a folder"),
    ):
        rc, _out, err = _run(capsys, "report", folder, *args, "--no-limits")
        line = _one_line(rc, err)
        assert line == f"lamde-mission report: {needle}", err
        assert _tree(tmp_path) == before, args


def test_report_makes_missing_folders_only_with_mkdir(tmp_path: Path, capsys) -> None:
    """`report -o` made missing folders where `plan`, `map` and `lam select` refuse them
    without --mkdir (exit 2); now report does as they do, for -o and --figures."""
    folder = _results(tmp_path / "runs")
    md = tmp_path / "new" / "deep" / "r.md"
    rc, _out, err = _run(capsys, "report", folder, "-o", md, "--no-limits")
    assert _one_line(rc, err) == (f"lamde-mission report: -o/--output: {md}: the folder "
                                  f"{md.parent} does not exist (create it, or pass --mkdir)")
    figs = tmp_path / "figs" / "f"
    rc, _out, err = _run(capsys, "report", folder, "-o", tmp_path / "x.md", "--figures", figs,
                         "--no-limits")
    assert "--figures: " in _one_line(rc, err) and "pass --mkdir" in err
    assert not (tmp_path / "new").exists() and not (tmp_path / "figs").exists()
    assert not (tmp_path / "x.md").exists()
    rc, out, err = _run(capsys, "report", folder, "-o", md, "--figures", figs, "--no-limits",
                        "--mkdir")
    assert rc == 0, err
    assert md.read_text().startswith("# Benchmark results") and any(figs.glob("*.png"))
    assert "--mkdir" not in md.read_text()  # not part of the command the report records


# ----------------------------------------------------------------------------- bench's reads

SUITE = MAPS / "suite"


@pytest.mark.timeout(120)  # a FIFO read would wait for a writer forever
def test_bench_refuses_a_bad_best_known_file_before_writing(tmp_path: Path, capsys) -> None:
    import hashlib

    sha = hashlib.sha256((SUITE / "T01.json").read_bytes()).hexdigest()
    bk = tmp_path / "bk.json"
    cases = {
        '{"tasks": [1]}': "tasks: expected an object",
        '{"tasks": {"T01": 5}}': "tasks.T01: expected an object",
        f'{{"tasks": {{"T01": {{"f": "abc", "map_sha256": "{sha}"}}}}}}':
            "tasks.T01.f: expected a finite number, got 'abc'",
        f'{{"tasks": {{"T01": {{"f": NaN, "map_sha256": "{sha}"}}}}}}': "tasks.T01.f: NaN",
        '{"tasks": {"T01": {"f": 1.5}}}': "tasks.T01.map_sha256: expected a string",
        b"\xff{}": "not UTF-8",
        None: "is a named pipe (FIFO)",
    }
    for text, needle in cases.items():
        if bk.exists():
            bk.unlink()
        if text is None:
            os.mkfifo(bk)
        else:
            bk.write_bytes(text if isinstance(text, bytes) else text.encode())
        out = tmp_path / "out"
        rc, _, err = _run(capsys, "bench", "--suite", SUITE, "--tasks", "T01", "--optimizers",
                          "random-search", "--runs", "1", "--budget", "100", "--jobs", "1",
                          "--best-known-file", bk, "--out", out, "--quiet")  # fmt: skip
        line = _one_line(rc, err)
        assert f"{bk}: {needle}" in line, err
        assert not out.exists()  # refused before meta.json or results are written


# ----------------------------------------------------------------------------- --policy DIR

V2 = Path(__file__).resolve().parent.parent / "planner_core/learning/policy/checkpoints/lamde-v2"


def _policy_copy(tmp_path: Path, name: str) -> Path:
    import shutil

    return Path(shutil.copytree(V2, tmp_path / name))


@pytest.mark.timeout(120)  # a FIFO read would wait for a writer forever
def test_plan_policy_checkpoint_files_are_read_bounded(tmp_path: Path, capsys) -> None:
    cases = {
        "list": ("config.json", b"[1]", "config.json: expected a JSON object"),
        "utf8": ("config.json", b"\xff{}", "config.json: not UTF-8"),
        "deep": ("config.json", b"[" * 100_000 + b"]" * 100_000, "config.json: [0][0]"),
        "text": ("weights.npz", b"hello\n", "weights.npz: not a readable numpy .npz archive"),
        "fifo": ("config.json", None, "config.json: is a named pipe (FIFO)"),
    }
    for name, (file, data, needle) in cases.items():
        ck = _policy_copy(tmp_path, name)
        (ck / file).unlink()
        if data is None:
            os.mkfifo(ck / file)
        else:
            (ck / file).write_bytes(data)
        rc, _, err = _run(capsys, "plan", TINY, "-o", tmp_path / f"{name}.plan", "--quiet",
                          "--budget", "2000", "--configurator", "lamde", "--policy", ck)
        assert "--policy" in _one_line(rc, err) and needle in err, (name, err)


def test_policy_weights_shapes_are_checked_before_decompressing(tmp_path: Path) -> None:
    import tracemalloc

    import numpy as np

    from planner_core.learning.policy.checkpoint import CheckpointError, load

    ck = _policy_copy(tmp_path, "bomb")
    with np.load(ck / "weights.npz") as z:
        params = {k: z[k] for k in z.files}
    params["embed.weight"] = np.zeros((5, 5_000_000), dtype=np.float32)  # 100 MB of zeros
    np.savez_compressed(ck / "weights.npz", **params)
    assert (ck / "weights.npz").stat().st_size < 1_000_000
    tracemalloc.start()
    try:
        with pytest.raises(CheckpointError, match=r"embed\.weight has shape \(5, 5000000\), "
                           r"expected \(5, 16\)"):  # fmt: skip
            load(ck)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 20_000_000, peak  # the archive and the small arrays, never the 100 MB one


# ----------------------------------------------------------------------------- 4: import counts


def _tri(kind: str = "obstacle") -> dict:
    ring = [[114.1760, 22.3240], [114.17601, 22.3240], [114.1760, 22.32401], [114.1760, 22.3240]]
    return {"type": "Feature", "geometry": {"type": "Polygon", "coordinates": [ring]},
            "properties": {"kind": kind}}  # fmt: skip


def _import(tmp_path: Path, capsys, features: list[dict]) -> tuple[int, str]:
    src = tmp_path / "in.geojson"
    src.write_text(json.dumps(_fc(*_BASE, *features)))
    rc, _, err = _run(capsys, "map", "from-geojson", src, "-o", tmp_path / "m.json")
    return rc, err


def test_import_stops_at_the_first_count_over_a_limit(tmp_path: Path, capsys,
                                                      monkeypatch) -> None:  # fmt: skip
    monkeypatch.setenv("LAMDE_MAX_ZONE_VERTICES", "10")
    ring = [[114.176 + 1e-4 * (i % 7), 22.324 + 1e-5 * i] for i in range(50)]
    big = {"type": "Feature", "geometry": {"type": "Polygon", "coordinates": [ring]},
           "properties": {"kind": "obstacle"}}  # fmt: skip
    rc, err = _import(tmp_path, capsys, [big, _tri("nonsense")])
    line = _one_line(rc, err)  # the bad feature after it is never read
    assert "features[3] ring 0: 50 vertices in one ring, more than the limit of 10" in line
    assert "LAMDE_MAX_ZONE_VERTICES" in line
    monkeypatch.delenv("LAMDE_MAX_ZONE_VERTICES")
    monkeypatch.setenv("LAMDE_MAX_SENSORS", "10")
    many = {"type": "Feature", "properties": {"kind": "sensor"},
            "geometry": {"type": "MultiPoint", "coordinates": [[114.176, 22.324]] * 30}}
    rc, err = _import(tmp_path, capsys, [many, _tri("nonsense")])
    line = _one_line(rc, err)
    assert "features[3]: more than the limit of 10 sensors" in line, err
    monkeypatch.setenv("LAMDE_MAX_OBSTACLES", "10")
    rc, err = _import(tmp_path, capsys, [_tri()] * 30 + [_tri("nonsense")])
    line = _one_line(rc, err)
    assert "features[13]: more than the limit of 10 obstacles" in line, err


def test_import_prints_at_most_20_problems(tmp_path: Path, capsys) -> None:
    rc, err = _import(tmp_path, capsys, [_tri("nonsense")] * 50)
    lines = err.strip().splitlines()
    assert rc == 2 and len(lines) == 21, err
    assert all("unknown kind 'nonsense'" in ln for ln in lines[:20])
    assert lines[-1].endswith("... and 30 more problems")


# ----------------------------------------------------------------------------- 5: control chars

_CONTROLS = ("\x85", "\u202e", "\u2028", "\x9b", "\u2066", "\x1b")


@pytest.mark.parametrize("ch", _CONTROLS)
def test_map_names_and_ids_refuse_c1_separators_and_bidi(ch: str, tmp_path: Path,
                                                        capsys) -> None:  # fmt: skip
    doc = json.loads(TINY.read_text())
    doc["name"] = f"a{ch}b"
    doc["sensors"][0]["id"] = f"s{ch}1"
    src = tmp_path / "m.json"
    src.write_text(json.dumps(doc))
    rc, out, err = _run(capsys, "check", src)
    assert rc == 2 and "name: must be printable text" in err and "id: must be printable" in err
    assert ch not in err + out
    rc, out, err = _run(capsys, "generate", tmp_path / "g.json", "--name", f"a{ch}b")
    assert "--name" in _one_line(rc, err) and ch not in err


def test_paths_and_feature_names_are_escaped_in_messages(tmp_path: Path, capsys) -> None:
    bad = tmp_path / "m\x1b[31m\u2028x\nnew.json"
    bad.write_text("[]")
    rc, out, err = _run(capsys, "check", bad)
    line = _one_line(rc, err)
    assert "m\\x1b[31m\\u2028x\\nnew.json" in line and "\x1b" not in err
    mission = tmp_path / "mis\x1bsion\n.plan"
    mission.write_text("{}")
    rc, out, err = _run(capsys, "verify", FLY / "tiny-map.json", mission)
    assert "mis\\x1bsion\\n.plan" in _one_line(rc, err) and "\x1b" not in err
    feat = _tri("nonsense")
    feat["properties"]["name"] = "evil\x1b[2J\x07\nlamde-mission map: wrote x"
    rc, err = _import(tmp_path, capsys, [feat])
    line = _one_line(rc, err)
    assert "'evil\\x1b[2J\\x07\\nlamde-mission map: wrote x'" in line


def test_verify_header_escapes_the_mission_path(tmp_path: Path, capsys) -> None:
    import shutil

    mission = tmp_path / "a\x1b]0;x\x07b.plan"
    shutil.copy(RALLY, mission)
    rc, out, err = _run(capsys, "verify", FLY / "tiny-map.json", mission)
    assert "\x1b" not in out + err and "\x07" not in out + err
    assert "a\\x1b]0;x\\x07b.plan" in out.splitlines()[0], out


def test_show_refuses_a_title_with_control_characters(tmp_path: Path, capsys) -> None:
    svg = tmp_path / "s.svg"
    rc, out, err = _run(capsys, "show", TINY, "-o", svg, "--title", "a\x01b")
    assert "--title" in _one_line(rc, err) and "\\x01" in err and not svg.exists()


# ----------------------------------------------------------------------------- 6: long values

_HUGE = "x" * 5_000_000


@pytest.mark.parametrize("where", ["params", "type", "version", "command", "doJumpId"])
def test_plan_messages_never_copy_a_huge_string(where: str, tmp_path: Path, capsys) -> None:
    def change(d: dict) -> None:
        item = d["mission"]["items"][0]
        if where == "params":
            item["params"][0] = _HUGE
        elif where == "version":
            d["version"] = _HUGE
        else:
            item[where] = _HUGE

    bad = _plan_with(tmp_path, change)
    rc, out, err = _run(capsys, "verify", FLY / "tiny-map.json", bad)
    line = _one_line(rc, err)
    assert len(line) < 400 and "xxx..." in line, line[:400]


def test_geojson_messages_never_copy_a_huge_string(tmp_path: Path, capsys) -> None:
    kind = {"type": "Feature", "geometry": None, "properties": {"kind": _HUGE}}
    for doc in (_fc(kind), {"type": _HUGE}):
        src = tmp_path / "k.geojson"
        src.write_text(json.dumps(doc))
        rc, out, err = _run(capsys, "map", "from-geojson", src, "-o", tmp_path / "m.json")
        line = _one_line(rc, err)
        assert len(line) < 400 and "xxx..." in line, line[:400]
    src = tmp_path / "w.waypoints"
    for text in (_HUGE + "\n", "QGC WPL 111 " + _HUGE + "\n"):
        src.write_text(text)
        rc, out, err = _run(capsys, "verify", FLY / "tiny-map.json", src)
        assert len(_one_line(rc, err)) < 400, err[:400]


# ----------------------------------------------------------------------------- 7: silent accepts


def test_duplicate_do_jump_ids_and_unordered_waypoint_rows_are_refused(tmp_path: Path,
                                                                       capsys) -> None:  # fmt: skip
    bad = _plan_with(tmp_path, lambda d: d["mission"]["items"][2].__setitem__("doJumpId", 1))
    rc, out, err = _run(capsys, "verify", FLY / "tiny-map.json", bad)
    assert "mission.items[2].doJumpId: 1 is also the doJumpId of mission.items[0]" in \
        _one_line(rc, err)  # fmt: skip
    lines = (FLY / "do-jump.waypoints").read_text().splitlines()
    lines[3], lines[4] = lines[4], lines[3]  # rows 2 and 3 swapped: seq 3 before 2
    wp = tmp_path / "swapped.waypoints"
    wp.write_text("\n".join(lines) + "\n")
    rc, out, err = _run(capsys, "verify", FLY / "tiny-map.json", wp)
    assert "line 4: seq 3 out of order" in _one_line(rc, err) and "expected 2" in err


@pytest.mark.parametrize("feature, needle", [
    ({"type": "Feature", "geometry": {"type": "MultiPolygon", "coordinates": []},
      "properties": {"kind": "obstacle"}}, "a MultiPolygon with no polygons"),
    (_pt("sensor", 114.1761, 22.3241) | {"geometry": {"type": "Point", "coordinates":
                                                      [114.1761, 22.3241, "x", None]}},
     "a position is [longitude, latitude] or [longitude, latitude, altitude]"),
    (_pt("sensor", 114.1761, 22.3241, id={"a": 1}), "properties.id: a sensor id is text"),
    (_pt("sensor", 114.1761, 22.3241, name={"a": 1}), "properties.name: a name is text"),
])  # fmt: skip
def test_geojson_values_that_were_silently_kept_are_refused(feature: dict, needle: str,
                                                            tmp_path: Path, capsys) -> None:
    rc, err = _import(tmp_path, capsys, [feature])
    line = _one_line(rc, err)
    assert "features[3]" in line and needle in line, err


@pytest.mark.slow  # measured 12.3 s on a loaded machine (default suite <= 5 min)
def test_report_reads_a_policy_curve_through_the_shared_reader(tmp_path: Path, capsys) -> None:
    folder = _results(tmp_path / "runs")
    ck = tmp_path / "ck"
    ck.mkdir()
    for text, needle in (("epoch,seconds\n1,abc\n", "curve.csv: line 2: seconds: expected a "
                          "number, got 'abc'"),
                         ("epoch,seconds\n1,nan\n", "line 2: seconds: expected a finite"),
                         ("epoch,other\n1,2\n", "line 2: seconds: expected a number, got None"),
                         (b"epoch,seconds\n1,\xff\n", "curve.csv: not UTF-8")):  # fmt: skip
        (ck / "curve.csv").write_bytes(text if isinstance(text, bytes) else text.encode())
        rc, out, err = _run(capsys, "report", folder, "-o", folder / "r.md",
                            "--policy-checkpoint", ck, "--no-limits")
        assert needle in _one_line(rc, err), err


def test_report_refuses_a_malformed_lower_bounds_cache(tmp_path: Path, capsys) -> None:
    import shutil

    suite = tmp_path / "suite"
    suite.mkdir()
    shutil.copy(SUITE / "T01.json", suite / "T01.json")
    folder = _results(tmp_path / "runs", records=[r for r in _records(20)
                                                  if r["task"] == "T01"][:2])
    for text, needle in (('{"tasks": [1]}', "tasks: expected an object"),
                         ('{"tasks": {"T01": 5}}', "tasks.T01: expected an object"),
                         ('{"tasks": {"T01": {"sha256": "x", "lb": "abc"}}}',
                          "tasks.T01.lb: expected a finite number")):  # fmt: skip
        (tmp_path / "suite_lower_bounds.json").write_text(text)
        rc, out, err = _run(capsys, "report", folder, "-o", folder / "r.md", "--suite", suite)
        assert f"suite_lower_bounds.json: {needle}" in _one_line(rc, err), err


@pytest.mark.timeout(120)  # a FIFO read would wait for a writer forever
def test_schedule_checkpoint_files_are_read_bounded(tmp_path: Path) -> None:
    import shutil

    from planner_core.learning.schedule_policy import DEFAULT_CHECKPOINT, load

    for name, data, needle in (("manifest.json", None, "manifest.json: is a named pipe"),
                               ("weights.npz", None, "weights.npz: is a named pipe"),
                               ("manifest.json", b"[" * 100_000 + b"]" * 100_000,
                                "manifest.json: [0][0]")):  # fmt: skip
        ck = Path(shutil.copytree(DEFAULT_CHECKPOINT, tmp_path / f"{name}-{data is None}"))
        (ck / name).unlink()
        if data is None:
            os.mkfifo(ck / name)
        else:
            (ck / name).write_bytes(data)
        with pytest.raises(ValueError, match=re.escape(needle)):
            load(ck)
