"""Bad input to `lamde-mission lam` and to the training-set loader: one line naming the field or
option, exit status 2, nothing written, no work started, memory bounded by the limits."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from lamde_mission.cli import main
from planner_core.learning.lam import Database, PairProblem, load_trainset
from planner_core.learning.lam.bbob import FULL, MAX_DIMENSION, MAX_INSTANCES, BBOBProblem
from planner_core.learning.lam.probe import MAX_N_PROBE
from planner_core.learning.lam.trainset import MAX_PROBLEMS, dumps_trainset

ROOT = Path(__file__).resolve().parents[1]
T01 = ROOT / "examples" / "maps" / "suite" / "T01.json"


def _doc(n: int = 1, **patch: object) -> dict:
    p = {"objective": {"function": 1, "dimension": 20, "instance": 1},
         "constraint": {"function": 2, "dimension": 20, "instance": 1},
         "threshold": 1.0, "scale": 1.0}  # fmt: skip
    for key, value in patch.items():
        part, field = key.split("__")
        p[part] = {**p[part], field: value}
    return {"format": "lamde-trainset/1", "options": {}, "problems": [p] * n}


def _write(tmp_path: Path, doc: dict) -> Path:
    path = tmp_path / "t.json"
    path.write_text(json.dumps(doc))
    return path


# ---------------------------------------------------------------- the training-set loader


def test_the_limits_are_the_papers_database() -> None:
    assert MAX_DIMENSION == max(FULL.dimensions) == 200
    assert MAX_INSTANCES == len(FULL.instances) == 100
    assert MAX_PROBLEMS == len(FULL) == 14_400


@pytest.mark.parametrize("part", ["objective", "constraint"])
@pytest.mark.parametrize(
    ("field", "value", "shown"),
    [
        ("dimension", 10**9, "1000000000"),
        ("dimension", 201, "201"),
        ("dimension", 1, "1"),
        ("dimension", "40", "'40'"),
        ("dimension", True, "True"),
        ("function", 25, "25"),
        ("instance", 101, "101"),
        ("instance", 10**18, str(10**18)),
    ],
)
def test_a_key_out_of_range_is_one_line_naming_the_field(tmp_path, part, field, value,
                                                         shown) -> None:  # fmt: skip
    doc = _doc(**{f"{part}__{field}": value})
    if field == "dimension" and part == "objective":  # keep the pair's dimensions equal
        doc["problems"][0]["constraint"]["dimension"] = value
    path = _write(tmp_path, doc)
    with pytest.raises(ValueError) as err:
        load_trainset(path)
    msg = str(err.value)
    assert "\n" not in msg
    low, high = {"dimension": (2, 200), "function": (1, 24), "instance": (1, 100)}[field]
    assert msg == (f"{path}: problems[0].{part}.{field}: must be an integer in [{low}, {high}], "
                   f"got {shown}")  # fmt: skip


@pytest.mark.parametrize(("fmt", "shown"), [("lamde-trainset/9", "'lamde-trainset/9'"),
                                             (9, "9"), (None, "missing")])
def test_another_format_version_names_it_and_the_one_read(tmp_path, fmt, shown) -> None:
    """A training set of another format version said `problems[0] must be an object with
    'kind'` through `train --problems` (its entries taken for specs); now both readers name
    the version found and the one read."""
    from planner_core.learning.policy.problems import read_trainset

    doc = _doc()
    if fmt is None:
        del doc["format"]
    else:
        doc["format"] = fmt
    path = _write(tmp_path, doc)
    want = (f"{path}: format: {shown}, not a version this program reads (it reads "
            "'lamde-trainset/1')")
    with pytest.raises(ValueError) as err:
        load_trainset(path)
    assert str(err.value) == want
    if fmt is not None:  # without a format, train reads a file of problem specs
        with pytest.raises(ValueError) as err:
            read_trainset(path)
        assert str(err.value) == f"--problems: {want}"


def test_more_problems_than_the_database_holds_are_refused(tmp_path) -> None:
    path = _write(tmp_path, _doc(MAX_PROBLEMS + 1))
    with pytest.raises(ValueError, match=r"problems: 14,401 entries, more than the limit of "
                       r"14,400"):  # fmt: skip
        load_trainset(path)
    assert len(load_trainset(_write(tmp_path, _doc(3)))) == 3


def test_the_file_is_read_under_the_input_size_limit(tmp_path, monkeypatch) -> None:
    path = _write(tmp_path, _doc(20))
    monkeypatch.setenv("LAMDE_MAX_INPUT_BYTES", "1000")
    with pytest.raises(ValueError, match=r"t\.json: file is [\d,]+ bytes, more than the limit of "
                       r"1,000 \(raise it with LAMDE_MAX_INPUT_BYTES\)"):  # fmt: skip
        load_trainset(path)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('{"format": "lamde-trainset/1", "problems": [1e400]}', r"problems\[0\]: .*double"),
        ('{"format": "lamde-trainset/1", "format": "x"}', "format: this key appears more"),
    ],
)
def test_json_rules_of_the_project_apply(tmp_path, text, message) -> None:
    path = tmp_path / "t.json"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        load_trainset(path)


def test_problems_refuse_dimensions_numpy_cannot_hold() -> None:
    with pytest.raises(ValueError, match=r"^objective\.dimension: must be an integer in \[2, "):
        PairProblem((1, 10**9, 1), (2, 10**9, 1), 0.0)
    with pytest.raises(ValueError, match=r"^key\.instance: must be an integer"):
        BBOBProblem((1, 20, 10**12))  # ioh takes a C int


@pytest.mark.slow  # measured 4.7 s on a loaded machine (default suite <= 5 min)
def test_cli_train_refuses_a_huge_dimension_in_one_line(tmp_path, capsys) -> None:
    pytest.importorskip("torch")
    path = _write(tmp_path, _doc(objective__dimension=10**9, constraint__dimension=10**9))
    assert main(["train", "-o", str(tmp_path / "ck"), "--problems", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert "problems[0].objective.dimension: must be an integer in [2, 200], got 1000000000" in err
    assert not (tmp_path / "ck").exists()


# ---------------------------------------------------------------- the CLI: no work on bad input


@pytest.fixture
def no_work(monkeypatch):
    """Any database build or selection fails the test: refusals come before work."""

    def boom(*a, **k):
        pytest.fail("work started before the input was checked")

    monkeypatch.setattr(Database, "build", boom)
    monkeypatch.setattr("planner_core.learning.lam.select", boom)


def _one_line(capsys, *needles: str) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for n in needles:
        assert n in err, err
    return err


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        (["--dims", "10000000"], ["--dims:", "[2, 200]", "10000000"]),
        (["--dims", "20,1-10000000"], ["--dims:", "[2, 200]"]),
        (["--dims", "201"], ["--dims:", "201"]),
        (["--instances", "100000000"], ["--instances", "[1, 100]"]),
        (["--n-probe", "100000000"], ["--n-probe", f"[4, {MAX_N_PROBE}]"]),
        (["--functions", "30"], ["--functions:", "30"]),
        (["--jobs", "257"], ["--jobs: must be at most 256", "257"]),
    ],
)
@pytest.mark.parametrize("command", ["build", "select"])
def test_sizes_are_bounded_and_named_by_their_option(tmp_path, capsys, no_work, command, args,
                                                     needles) -> None:  # fmt: skip
    cache = tmp_path / "cache"
    extra = ["--tasks", str(T01), "-o", str(tmp_path / "o.json")] if command == "select" else []
    assert main(["lam", command, *args, "--cache", str(cache), *extra]) == 2
    err = _one_line(capsys, *needles)
    assert "functions:" not in err.replace("--functions:", "")
    assert "dimensions:" not in err
    assert not cache.exists() and not (tmp_path / "o.json").exists()


def test_cache_that_is_a_file_or_cannot_be_made_is_refused(tmp_path, capsys, no_work) -> None:
    afile = tmp_path / "afile"
    afile.write_text("keep")
    for cache in (afile, afile / "sub"):
        assert main(["lam", "build", "--cache", str(cache), "--functions", "1", "--dims", "2",
                     "--instances", "1"]) == 2  # fmt: skip
        _one_line(capsys, "--cache:", str(cache))
    assert afile.read_text() == "keep"
    if Path("/proc/self").is_dir():
        assert main(["lam", "build", "--cache", "/proc/nonexist"]) == 2
        _one_line(capsys, "--cache: cannot create the folder /proc/nonexist")


@pytest.fixture
def outs(tmp_path, monkeypatch):
    """A folder with a file `my.json`, a folder `empty.png` and a file `b.txt`."""
    monkeypatch.chdir(tmp_path)
    Path("my.json").write_text("{}")
    Path("empty.png").mkdir()
    Path("b.txt").write_text("text")
    return tmp_path


@pytest.mark.parametrize(
    ("out", "plot", "needles"),
    [
        ("my.json/x.json", None, ["-o:", "my.json is a file, not a folder"]),
        ("okk.json", "my.json/p.png", ["--plot:", "my.json is a file, not a folder"]),
        ("okk.json", "empty.png", ["--plot:", "is a folder"]),
        ("okk.json", "empty", ["--plot:", "must end in .png or .svg"]),
        ("okk.json", "b.txt", ["--plot:", "must end in .png or .svg"]),
        ("nodir/a.json", None, ["-o:", "the folder nodir does not exist"]),
        ("okk.json", "nodir/p.svg", ["--plot:", "the folder nodir does not exist"]),
        (str(T01), None, ["-o:", "is the task map this command reads"]),
        ("okk.json", "okk.json", ["--plot:", "must end in"]),
    ],
)
def test_select_checks_every_output_before_any_work(outs, capsys, no_work, out, plot,
                                                    needles) -> None:  # fmt: skip
    before = {p: p.read_bytes() for p in outs.rglob("*") if p.is_file()}
    args = ["lam", "select", "--tasks", str(T01), "--k", "3", "-o", out,
            "--cache", str(outs / "cache")]  # fmt: skip
    assert main([*args, *(["--plot", plot] if plot else [])]) == 2
    _one_line(capsys, *needles)
    assert {p: p.read_bytes() for p in outs.rglob("*") if p.is_file()} == before
    assert not Path("okk.json").exists() and not Path("nodir").exists()
    assert not (outs / "cache").exists()


def test_select_refuses_a_training_set_given_as_tasks(tmp_path, capsys, no_work) -> None:
    tasks = tmp_path / "tasks"
    tasks.mkdir()
    (tasks / "a.json").write_bytes(T01.read_bytes())
    (tasks / "set.json").write_text(dumps_trainset(_doc(2)))
    for given in (tasks / "set.json", tasks):
        assert main(["lam", "select", "--tasks", str(given), "-o", str(tmp_path / "o.json"),
                     "--cache", str(tmp_path / "c")]) == 2  # fmt: skip
        _one_line(capsys, "--tasks:", "set.json", "is a training-set file", "not a map")
    assert not (tmp_path / "o.json").exists()


def _fake_select(db, tasks, names, **kw):  # noqa: ANN001, ANN003, ANN202
    rng = np.random.default_rng(0)
    doc = {"format": "lamde-trainset/1",
           "options": {"k": kw["k"], "seed": 0, "selection": "global", "features": "ela",
                       "n_probe": 100, "tasks": list(names), "rho": 0.5},
           "problems": [{"objective": {"function": 1, "dimension": 20, "instance": 1},
                         "constraint": {"function": 2, "dimension": 20, "instance": 1},
                         "threshold": 1.0, "scale": 1.0, "task": names[0]}] * kw["k"]}  # fmt: skip
    arrays = {"Z": rng.random((12, 4)), "z_f": rng.random((1, 4)), "z_phi": rng.random((1, 4)),
              "objective": np.arange(kw["k"]), "constraint": np.arange(kw["k"]) + 1}  # fmt: skip
    return doc, arrays


def test_select_writes_svg_and_makes_folders_only_with_mkdir(tmp_path, monkeypatch) -> None:
    monkeypatch.setattr(Database, "missing", lambda self, names=None: [])
    monkeypatch.setattr("planner_core.learning.lam.select", _fake_select)
    out, plot = tmp_path / "new" / "set.json", tmp_path / "figs" / "sel.SVG"
    args = ["lam", "select", "--tasks", str(T01), "--k", "3", "-o", str(out), "--plot",
            str(plot), "--features", "ela", "--cache", str(tmp_path / "cache")]  # fmt: skip
    assert main(args) == 2 and not out.parent.exists()
    assert main([*args, "--mkdir"]) == 0
    assert len(load_trainset(out)) == 3
    assert b"<svg" in plot.read_bytes()[:2000]
    assert not [p for p in tmp_path.rglob("*") if ".lamde-tmp-" in p.name]


def test_the_help_shows_the_modules_limits_without_importing_them() -> None:
    """`lam`'s help mirrors bbob's and probe's limits (importing them would load scipy to build
    `--help`, which test_help_is_fast_and_lists_commands forbids)."""
    import importlib

    from lamde_mission.commands import lam as cli

    # the modules themselves (the package exports a function named `probe`)
    bbob = importlib.import_module("planner_core.learning.lam.bbob")
    probe = importlib.import_module("planner_core.learning.lam.probe")

    assert (cli.MIN_DIMENSION, cli.MAX_DIMENSION, cli.MAX_INSTANCES) == (
        bbob.MIN_DIMENSION, bbob.MAX_DIMENSION, bbob.MAX_INSTANCES)
    assert (cli.N_PROBE, cli.MAX_N_PROBE) == (probe.N_PROBE, probe.MAX_N_PROBE)
