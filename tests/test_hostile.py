"""Hostile input: every reader refuses bad files with one line naming the field, exit status 2.

The regression cases (tests/data/hostile, from ../shared/cases/hostile) each ended in a
traceback, a huge allocation or a hang before `planner_core.textio`; the fuzz tests mutate the
shipped map and missions with `lamde_mission.fuzz` under hypothesis and check the contract:
exit 2 (refused) or 0/1 (read and judged), no exception escaping, stderr lines all prefixed by
the command, and no output file when `plan` refuses a map.
"""

from __future__ import annotations

import contextlib
import json
import os
import random
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lamde_mission.formats import read_mission
from lamde_mission.fuzz import mutate, run_cli
from planner_core import textio
from planner_core.model.mapio import MapError, load_map

DATA = Path(__file__).resolve().parent / "data" / "hostile"
TINY = DATA / "tiny-map.json"


def _refused(argv: list[str], field: str) -> str:
    """Run the CLI; assert exit 2 with exactly one stderr line naming `field`; return it."""
    out = run_cli(argv)
    assert out.error is None, f"{argv}: {out.error!r}"
    lines = out.stderr.splitlines()
    assert out.status == 2, (argv, out.status, out.stderr)
    assert len(lines) == 1, lines
    # the subcommand too: `map from-geojson` (as argparse names it)
    name = " ".join(argv[:2]) if argv[0] in ("map", "lam") else argv[0]
    assert lines[0].startswith(f"lamde-mission {name}: "), lines
    assert field in lines[0], (field, lines[0])
    return lines[0]


MAP_CASES = {
    "latin1-bytes.json": "not UTF-8 (byte 0xE9 at offset 13",
    "deep-nesting.json": "notes[0][0]",
    "huge-integer.json": "extra: an integer of 5000 digits",
    "rect-1e308.json": "obstacles.rectangles[0].length:",
    "altitude-1e308.json": "uav.altitude:",
    "max-speed-tiny.json": "uav.max_speed:",
    "activation-zero.json": "uav.activation_threshold:",
}

PLAN_CASES = {
    "hover-1e39.plan": "mission.items[2].params[0]: 1e+39 is beyond float32",
    "lat-1e308.plan": "mission.items[2].params[4]: latitude 1e+308",
    "command-99999.plan": "mission.items[2].command: 99999",
    "frame-999.plan": "mission.items[2].frame: 999",
}


@pytest.mark.parametrize("name", sorted(MAP_CASES))
def test_hostile_map_check_and_plan_agree(name: str, tmp_path: Path) -> None:
    path = str(DATA / name)
    line = _refused(["check", path], MAP_CASES[name])
    out = tmp_path / "out.plan"
    line2 = _refused(["plan", path, "-o", str(out), "--quiet"], MAP_CASES[name])
    assert line2.split(": ", 1)[1] == line.split(": ", 1)[1]
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", sorted(PLAN_CASES))
def test_hostile_mission_verify(name: str) -> None:
    _refused(["verify", str(TINY), str(DATA / name)], PLAN_CASES[name])


@pytest.mark.parametrize("via", ["mavsdk", "pymavlink"])
@pytest.mark.parametrize("name", sorted(PLAN_CASES))
def test_hostile_mission_upload_refused_before_sending(name: str, via: str) -> None:
    # the file is refused while reading: no vehicle is needed (none listens on this port)
    _refused(["upload", str(DATA / name), "--via", via, "--connect", "udpin://127.0.0.1:1",
              "--timeout", "1", "--attempts", "1"], PLAN_CASES[name])  # fmt: skip


@pytest.mark.timeout(30)
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
def test_named_pipe_and_directory_are_refused_at_once(tmp_path: Path) -> None:
    fifo = tmp_path / "map.json"
    os.mkfifo(fifo)
    _refused(["check", str(fifo)], "is a named pipe (FIFO), not a regular file")
    _refused(["verify", str(TINY), str(fifo)], "is a named pipe (FIFO)")
    _refused(["check", str(tmp_path)], "is a directory, not a regular file")
    with pytest.raises(textio.InputError, match="character device"):
        textio.read_text("/dev/null")


def _tiny() -> dict:
    return json.loads(TINY.read_text())


def _write(tmp_path: Path, name: str, data: str | bytes) -> str:
    p = tmp_path / name
    p.write_bytes(data if isinstance(data, bytes) else data.encode("utf-8"))
    return str(p)


@pytest.mark.slow  # measured 5 s (issue 35: default suite <= 5 min)
def test_too_many_sensors_obstacles_and_vertices(tmp_path: Path) -> None:
    d = _tiny()
    d["sensors"] = [{"id": f"s{i}", "x": 10.0, "y": 10.0} for i in range(100_000)]
    _refused(["check", _write(tmp_path, "s.json", json.dumps(d))],
             "sensors: 100,000 sensors, more than the limit of 1,000")  # fmt: skip
    d = _tiny()
    d["obstacles"]["circles"] = [{"x": 5.0, "y": 5.0, "radius": 1.0}] * 100_000
    _refused(["check", _write(tmp_path, "o.json", json.dumps(d))], "obstacles: 100,001 obstacles")
    d = _tiny()
    d["obstacles"]["no_fly_zones"] = [{"vertices": [[float(i), 0.0] for i in range(100_000)]}]
    _refused(["check", _write(tmp_path, "v.json", json.dumps(d))],
             "obstacles.no_fly_zones[0].vertices: 100,000 vertices")  # fmt: skip


def test_limits_can_be_raised_by_environment(tmp_path: Path, monkeypatch) -> None:
    d = _tiny()
    d["sensors"] += [{"id": f"s{i}", "x": 100.0 + i, "y": 1000.0} for i in range(5)]
    path = _write(tmp_path, "m.json", json.dumps(d))
    monkeypatch.setenv("LAMDE_MAX_SENSORS", "4")
    _refused(["check", path], "LAMDE_MAX_SENSORS")
    monkeypatch.setenv("LAMDE_MAX_SENSORS", "8")
    assert run_cli(["check", path]).status == 0
    monkeypatch.setenv("LAMDE_MAX_SENSORS", "lots")
    _refused(["check", path], "LAMDE_MAX_SENSORS: must be a positive integer")
    monkeypatch.setenv("LAMDE_MAX_INPUT_BYTES", "100")
    _refused(["check", path], "more than the limit of 100 (raise it with LAMDE_MAX_INPUT_BYTES)")


def test_encodings(tmp_path: Path) -> None:
    text = TINY.read_text()
    assert run_cli(["check", _write(tmp_path, "bom.json", b"\xef\xbb\xbf" + text.encode())]
                   ).status == 0  # fmt: skip
    _refused(["check", _write(tmp_path, "u16.json", text.encode("utf-16"))],
             "UTF-16 (little-endian) byte-order mark")  # fmt: skip
    _refused(["check", _write(tmp_path, "u16le.json", text.encode("utf-16-le"))],
             "NUL character")  # fmt: skip
    d = _tiny()
    d["name"] = "\ud800"
    _refused(["check", _write(tmp_path, "sur.json", json.dumps(d))],
             "name: a string holds an unpaired UTF-16 surrogate")  # fmt: skip
    d = _tiny()
    d["sensors"][1]["x"] = float("nan")
    _refused(["check", _write(tmp_path, "nan.json", json.dumps(d))],
             "sensors[1].x: NaN is not a JSON number")  # fmt: skip
    d["sensors"][1]["x"] = 1e300 * 1e300
    _refused(["check", _write(tmp_path, "inf.json", json.dumps(d))], "sensors[1].x: Infinity")


@pytest.mark.slow  # measured 12 s (issue 35: default suite <= 5 min)
def test_big_missions_are_refused_by_count(tmp_path: Path) -> None:
    line = "1\t0\t3\t16\t0\t0\t0\t0\t46.2\t7.3\t100\t1\n"
    wpl = "QGC WPL 110\n" + line * 1_000_000
    _refused(["verify", str(TINY), _write(tmp_path, "big.waypoints", wpl)],
             "1,000,001 lines, far more than the 65,535 items")  # fmt: skip
    item = {"type": "SimpleItem", "command": 16, "frame": 3, "autoContinue": True,
            "params": [0, 0, 0, 0, 46.2, 7.3, 100]}  # fmt: skip
    doc = {"fileType": "Plan", "version": 1, "mission": {"items": [item] * 200_000}}
    _refused(["verify", str(TINY), _write(tmp_path, "big.plan", json.dumps(doc))],
             "mission.items: 200,000 items, more than MAVLink's 65,535")  # fmt: skip


def test_waypoints_fields_named_by_line(tmp_path: Path) -> None:
    head = "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t46.2\t7.3\t500\t1\n"
    cases = {
        "1\t0\t3\t19\tinf\t0\t0\t0\t46.2\t7.3\t100\t1\n": "line 3: param1: inf is beyond",
        "1\t0\t3\t19\t1\t0\t0\t0\t46.2\t1e308\t100\t1\n": "line 3: longitude: longitude 1e+308",
        "1\t0\t3\t70000\t1\t0\t0\t0\t46.2\t7.3\t100\t1\n": "line 3: command: 70000",
        "1\t0\t3\t16\t1\t0\t0\t0\t46.2\t7.3\tnan\t1\n": "line 3: altitude: altitude nan",
        "1\t0\t3\t16\t1\t0\t0\t0\t46.2\t7.3\t100\t" + "9" * 5000 + "\n":
            "line 3: autocontinue: '99999999999999999999'... is not an integer",
        # Python's float() and int() read these; no autopilot does (issue 32, item 5)
        "1\t0\t3\t16\t1\t0\t0\t0\t46.2\t7.3\t1_00.0\t1\n":
            "line 3: altitude: '1_00.0' is not a number (ASCII digits, no underscores)",
        "1\t0\t3\t16\t1\t0\t0\t0\t46.2\t7.3\t\u0661\u0660\u0660\t1\n":
            "line 3: altitude: '\\u0661\\u0660\\u0660' is not a number",
        "1\t0\t3\t1\u0666\t1\t0\t0\t0\t46.2\t7.3\t100\t1\n":
            "line 3: command: '1\\u0666' is not an integer",
        "\u0661\t0\t3\t16\t1\t0\t0\t0\t46.2\t7.3\t100\t1\n": "line 3: seq: '\\u0661'",
        "1\t0\t3\t16\t1_0\t0\t0\t0\t46.2\t7.3\t100\t1\n": "line 3: param1: '1_0'",
        "1\t0\t3\t16\t1\t0\t0\t0\t46.2\t7.3\t0x10\t1\n": "line 3: altitude: '0x10'",
    }
    for k, (row, field) in enumerate(cases.items()):
        _refused(["verify", str(TINY), _write(tmp_path, f"w{k}.waypoints", head + row)], field)


def test_plan_result_json_is_range_checked(tmp_path: Path) -> None:
    doc = {"hover_points": [[300.0, 900.0]], "hover_times": [1e39]}
    _refused(["verify", str(TINY), _write(tmp_path, "r.json", json.dumps(doc))],
             "hover_times[0]: 1e+39 is outside [0, 3.40282e+38]")  # fmt: skip
    doc = {"hover_points": [[1e300, 900.0]], "hover_times": [10]}
    _refused(["verify", str(TINY), _write(tmp_path, "r2.json", json.dumps(doc))],
             "hover_points[0][0]: 1e+300 is outside")  # fmt: skip


def test_schema_gives_the_reason_for_each_range() -> None:
    from planner_core.model.mapio import map_json_schema

    uav = map_json_schema()["$defs"]["Uav"]["properties"]
    assert "range [0.1, 200]" in uav["max_speed"]["description"]
    assert uav["max_speed"]["x-range-reason"]
    assert uav["activation_threshold"]["exclusiveMinimum"] == 0


# ----------------------------------------------------------------------------- fuzz

_FUZZ = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                 suppress_health_check=[HealthCheck.too_slow])  # fmt: skip


def _accepts_or_refuses(argv: list[str]) -> int:
    out = run_cli(argv)
    if out.error is not None:
        raise AssertionError(f"{argv[0]}: exception {out.error!r}") from out.error
    assert out.status in (0, 1, 2), out.status
    lines = out.stderr.splitlines()
    for line in lines:
        assert line.startswith((f"lamde-mission {argv[0]}: ", "note: ")), line
    if out.status == 2:
        assert lines and not lines[0].startswith("note: "), out.stderr
    return int(out.status)


@pytest.fixture(scope="module")
def missions(tmp_path_factory) -> dict[str, bytes]:
    """A .plan and a .waypoints for the tiny map, written by the planner's own writers."""
    from lamde_mission.formats import write_mission

    d = tmp_path_factory.mktemp("missions")
    m = load_map(TINY)
    plan = type("P", (), {"hover_points": [[300.0, 880.0], [700.0, 800.0], [850.0, 370.0]],
                          "hover_times": [40.0, 30.0, 40.0]})()  # fmt: skip
    out = {}
    for suffix in (".plan", ".waypoints"):
        out[suffix] = write_mission(d / f"m{suffix}", plan, m).read_bytes()
    return out


@given(rng=st.randoms(use_true_random=False))
@_FUZZ
def test_fuzz_map(rng: random.Random, tmp_path_factory) -> None:
    d = tmp_path_factory.mktemp("fuzzmap")
    path = d / "map.json"
    path.write_bytes(mutate(TINY.read_bytes(), rng))
    status = _accepts_or_refuses(["check", str(path)])
    if status == 2:
        out = d / "out.plan"
        assert _accepts_or_refuses(["plan", str(path), "-o", str(out), "--quiet"]) == 2
        assert sorted(p.name for p in d.iterdir()) == ["map.json"]


@pytest.mark.parametrize("suffix", [".plan", ".waypoints"])
@given(rng=st.randoms(use_true_random=False))
@_FUZZ
@pytest.mark.slow  # measured 10 s over 2 cases (issue 35: default suite <= 5 min)
def test_fuzz_missions(suffix: str, rng: random.Random, missions, tmp_path_factory) -> None:
    d = tmp_path_factory.mktemp("fuzzmission")
    path = d / f"m{suffix}"
    path.write_bytes(mutate(missions[suffix], rng))
    _accepts_or_refuses(["verify", str(TINY), str(path)])
    with contextlib.suppress(ValueError):  # the API raises only its ValueErrors
        read_mission(path)


CAMPUS = Path(__file__).resolve().parent / "data" / "campus.geojson"


@given(rng=st.randoms(use_true_random=False))
@_FUZZ
@pytest.mark.slow  # measured 16 s (issue 35: default suite <= 5 min)
def test_fuzz_geojson(rng: random.Random, tmp_path_factory) -> None:
    """`map from-geojson` on mutated GeoJSON: a map is written or nothing at all."""
    d = tmp_path_factory.mktemp("fuzzgeojson")
    path = d / "in.geojson"
    path.write_bytes(mutate(CAMPUS.read_bytes(), rng))
    out = d / "map.json"
    out_ = run_cli(["map", "from-geojson", str(path), "-o", str(out)])
    assert out_.error is None, f"exception {out_.error!r}"
    assert out_.status in (0, 2), (out_.status, out_.stderr)
    for line in out_.stderr.splitlines():
        assert line.startswith(("lamde-mission map from-geojson: ", "note: ")), line
    if out_.status == 2:
        assert sorted(p.name for p in d.iterdir()) == ["in.geojson"]
    else:
        assert run_cli(["check", str(out)]).status == 0


def test_hostile_geojson_is_refused_by_the_same_decoder(tmp_path: Path) -> None:
    text = CAMPUS.read_text(encoding="utf-8")
    _refused(["map", "from-geojson", _write(tmp_path, "a.geojson", text.encode("utf-16")),
              "-o", str(tmp_path / "m.json")], "UTF-16")  # fmt: skip
    deep = text.replace('"features"', '"x": ' + "[" * 70_000 + "]" * 70_000 + ', "features"', 1)
    _refused(["map", "from-geojson", _write(tmp_path, "b.geojson", deep),
              "-o", str(tmp_path / "m.json")], "x[0][0]")  # fmt: skip
    assert not (tmp_path / "m.json").exists()


def test_readers_raise_only_their_errors() -> None:
    """The Python API: a mutated map raises MapError, never another exception."""
    rng = random.Random(7)
    base = TINY.read_bytes()
    for _ in range(40):
        try:
            load_map(textio.loads_json(textio.decode_text(mutate(base, rng))))
        except (MapError, textio.InputError):
            pass
        except TypeError:  # a JSON array/number at the top: load_map's documented TypeError
            pass


def test_long_hover_replays_at_bounded_cost(tmp_path: Path) -> None:
    """A float32-valid hover of 3e38 s is read; the sim samples it coarsely and C2 fails."""
    doc = json.loads((DATA / "hover-1e39.plan").read_text())
    doc["mission"]["items"][2]["params"][0] = 3e38
    out = run_cli(["verify", "--json", str(TINY), _write(tmp_path, "long.plan", json.dumps(doc))])
    assert out.error is None and out.status == 1, out.stderr
    verdicts = json.loads(out.stdout)
    assert verdicts["totals"]["t_hover"] == pytest.approx(3e38)


def test_every_map_number_is_refused_just_outside_its_range() -> None:
    """Each ranged map field: the bound itself (when closed) passes, just outside is refused
    with a line naming the field and the reason (so `check` and `plan` agree on it)."""
    import math

    from planner_core.defaults import MAP_DEFAULTS, interval_text

    for name, d in MAP_DEFAULTS.items():
        assert d.bounds is not None and d.why, name
        lo, hi, lo_open, hi_open = d.bounds
        *sections, key = name.split(".")
        for bound, is_open, outside in ((lo, lo_open, -1), (hi, hi_open, 1)):
            step = 1 if isinstance(bound, int) else max(abs(bound), 1.0) * 1e-9
            cases = [(bound + outside * step, False), (bound, not is_open)]
            for value, ok in cases:
                data = _tiny()
                node = data
                for section in sections:
                    node = node.setdefault(section, {})
                if sections == ["uav", "battery"]:  # a battery section gives its energy
                    node.setdefault("energy_wh", 100.0)
                if name == "radio.required_data":  # planned x (1 + margin): the paper's 0
                    data["safety"] = {"data_margin": 0.0}
                node[key] = value
                if ok:
                    load_map(data)
                    continue
                with pytest.raises(MapError) as info:
                    load_map(data)
                line = info.value.problems[0]
                assert line.startswith(f"{name}: "), (name, value, line)
                assert f": must be in {interval_text(lo, hi, lo_open, hi_open)} " in line, line
                if outside < 0 and bound == 0 and not d.why_sides:  # "must be in (0, ..." is
                    assert d.why not in line, line  # its own reason, not the cap's
                else:  # the reason for the end it broke (each end its own, where given)
                    assert d.why_for(outside > 0) in line, (name, value, line)
                    other = d.why_sides and d.why_sides[int(outside < 0)]
                    assert not other or other not in line, (name, value, line)
                assert math.isfinite(value)


def test_control_characters_never_split_a_message() -> None:
    d = _tiny()
    d["sensors"][0]["id"] = "a\nb"
    d["uav"] = {"max\nsped": 1}
    with pytest.raises(MapError) as info:
        load_map(d)
    assert info.value.problems == [
        "sensors[0].id: must be printable text (no control characters, line or paragraph "
        "separators, or bidirectional controls: names are printed in one-line messages); "
        "character 2 is a newline (U+000A), a C0 control character",
        "uav.'max\\nsped': unknown field (did you mean 'max_speed'?)",
    ]


@pytest.mark.parametrize(("change", "line"), [
    (lambda d: d.update(fleet={"depots": [{"name": "a", "x": 5, "y": 5},
                                          {"name": "", "x": 6, "y": 6}]}),
     'fleet.depots[1].name: must be 1 to 100 characters long, got "" (an empty string)'),
    (lambda d: d.update(fleet={"depots": [{"name": "n" * 101, "x": 5, "y": 5}]}),
     'fleet.depots[0].name: must be 1 to 100 characters long, got "' + "n" * 35
     + '..." (a string of 101 characters)'),
    (lambda d: d.update(fleet={"depots": [{"name": f"d{k}", "x": 5, "y": 5}
                                          for k in range(101)]}),
     "fleet.depots: must hold 1 to 100 depots, got 101"),
    (lambda d: d.update(fleet={"depots": [{"name": "a", "x": 5, "y": 5,
                                           "pads": [[6, 6]] * 101}]}),
     "fleet.depots[0].pads: must hold at most 100 pads, got 101"),
    (lambda d: d.update(name=""), 'name: must be 1 to 200 characters long, got "" (an empty '
                                  "string)"),
    (lambda d: d.update(name="m" * 201), "name: must be 1 to 200 characters long, got "
     '"mmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmm..." (a string of 201 characters)'),
    (lambda d: d["sensors"][0].update(id=""),
     'sensors[0].id: must be 1 to 100 characters long, got "" (an empty string)'),
    (lambda d: d.update(witness={"hover_points": [[1, 1]] * 201, "hover_times": [1]}),
     "witness.hover_points: must hold at most 200 hover points, got 201"),
    (lambda d: d["obstacles"].update(no_fly_zones=[{"vertices": [[1, 1], [2, 1], [2, 2]],
                                                    "name": "z" * 201}]),
     "obstacles.no_fly_zones[0].name: must be at most 200 characters long, got "
     '"zzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzz..." (a string of 201 characters)'),
])  # fmt: skip
def test_length_errors_are_one_house_style_line(change, line) -> None:
    """A newcomer met pydantic's own words ("String should have at least 1 character", "List
    should have at most 100 items after validation, not 101") among the map's messages: every
    string or list of the wrong length now names the field, the whole allowed range and what
    was given."""
    d = _tiny()
    change(d)
    with pytest.raises(MapError) as info:
        load_map(d)
    assert info.value.problems == [line]
    assert "should have" not in line


@pytest.mark.parametrize(("char", "said"), [
    ("\u202e", "U+202E RIGHT-TO-LEFT OVERRIDE, a bidirectional embedding or override (it "
                "reorders what a terminal shows)"),
    ("\u2067", "U+2067 RIGHT-TO-LEFT ISOLATE, a bidirectional isolate (it reorders what a "
                "terminal shows)"),
    ("\u2028", "U+2028 LINE SEPARATOR, a line or paragraph separator"),
    ("\t", "a tab (U+0009), a C0 control character"),
    ("\x85", "U+0085, a C1 control character"),
    ("\x7f", "U+007F, the control character DEL"),
])  # fmt: skip
def test_an_unprintable_name_names_its_character_class(char, said) -> None:
    """A depot name holding a bidi override was refused as "no control characters such as
    newlines or tabs": the line now names the character, where it is, and its class."""
    d = _tiny()
    d["fleet"] = {"depots": [{"name": f"ab{char}c", "x": 5, "y": 5}]}
    with pytest.raises(MapError) as info:
        load_map(d)
    assert info.value.problems == [
        "fleet.depots[0].name: must be printable text (no control characters, line or "
        "paragraph separators, or bidirectional controls: names are printed in one-line "
        f"messages); character 3 is {said}"]


def test_generate_refuses_an_empty_map_name_as_the_map_format_does(tmp_path, capsys) -> None:
    """`generate g1.json --name ""` wrote a map named "" while a depot's name must not be
    empty: a map's name is not empty either (1 to 200 characters), and generate says so up
    front."""
    from lamde_mission.cli import main

    out = tmp_path / "g1.json"
    assert main(["generate", str(out), "--name", "", "--size", "5000", "--density", "1"]) == 2
    assert capsys.readouterr().err.strip() == (
        'lamde-mission generate: --name: must be 1 to 200 characters long, got "" (an empty '
        "string)")
    assert not out.exists()


def test_readme_lists_every_input_limit() -> None:
    readme = (Path(__file__).resolve().parent.parent / "README.md").read_text(encoding="utf-8")
    for name, lim in textio.LIMITS.items():
        shown = "64 MiB" if name == "bytes" else f"{lim.default:,}"
        row = [ln for ln in readme.splitlines() if ln.startswith("| ") and shown in ln
               and (lim.env is None or f"`{lim.env}`" in ln)]  # fmt: skip
        assert row, f"README's input-limits table lacks {name} ({shown}, {lim.env})"


def test_output_that_is_a_directory_is_refused_before_planning(tmp_path: Path) -> None:
    folder = tmp_path / "out.plan"
    folder.mkdir()
    _refused(["plan", str(TINY), "-o", str(folder), "--quiet"],
             "-o/--output: " + str(folder) + ": is a folder; a map without a battery or "
             "fleet is planned as a single flight into one file")  # fmt: skip
    _refused(["plan", str(TINY), "-o", str(tmp_path / "x.plan"), "--report",
              str(TINY / "r.json"), "--quiet"], "--report: ")  # fmt: skip
    (tmp_path / "img.svg").mkdir()
    _refused(["show", str(TINY), "-o", str(tmp_path / "img.svg")], "-o/--output: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["img.svg", "out.plan"]


def test_rally_points_and_breach_return_are_range_checked(tmp_path: Path) -> None:
    doc = json.loads((DATA / "hover-1e39.plan").read_text())
    doc["mission"]["items"][2]["params"][0] = 40.0
    doc["rallyPoints"] = {"points": [[1e308, 7.3, 50.0]], "version": 2}
    _refused(["upload", _write(tmp_path, "r.plan", json.dumps(doc)), "--connect",
              "udpin://127.0.0.1:1", "--timeout", "1"],
             "rallyPoints.points[0] (latitude): latitude 1e+308")  # fmt: skip
    doc["rallyPoints"] = {"points": [], "version": 2}
    doc.setdefault("geoFence", {"version": 2})["breachReturn"] = [46.2, 7.3, float("inf")]
    text = json.dumps(doc).replace("Infinity", "1e39")
    _refused(["verify", str(TINY), _write(tmp_path, "b.plan", text)],
             "geoFence.breachReturn (altitude): altitude 1e+39")  # fmt: skip


def test_waypoints_lines_are_counted_as_the_parser_splits_them(tmp_path: Path) -> None:
    """CR-only (and other) line ends count toward the line cap: a file of 20,000,000 '#a\\r'
    comment lines passed it (only LFs were counted) and split into 1.9 GB."""
    from lamde_mission.formats.waypoints import _line_breaks

    for text in ("a\r\nb\rc\nd\x0be\x0cf\x1cg\x85h\u2028i\u2029j\r\r\n\n", "", "x", "\r\n\r",
                 "a\n\x1d\x1e"):  # fmt: skip
        assert _line_breaks(text) == len((text + "x").splitlines()) - 1
    home = "0\t1\t0\t16\t0\t0\t0\t0\t46.2\t7.3\t500\t1\n"
    for end in ("\r", "\u2028", "\x0c"):
        wpl = "QGC WPL 110\n" + home + f"#a{end}" * 200_000
        _refused(["verify", str(TINY), _write(tmp_path, "cr.waypoints", wpl)],
                 "200,002 lines, far more than the 65,535 items")  # fmt: skip
