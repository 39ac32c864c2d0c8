"""The learned meta-level through the public surfaces: `plan(..., init=, configurator=)`, the
CLI's `plan --init/--configurator` and `train`."""

from __future__ import annotations

import json

import numpy as np
import pytest

from lamde_mission import plan
from lamde_mission.cli import main
from planner_core.learning.policy import PolicyConfigurator
from planner_core.model.problem import Problem
from planner_core.search.de import make_configurator, run
from tests.conftest import MAPS


def test_shipped_checkpoint_is_the_lamde_configurator() -> None:
    conf = make_configurator("lamde")
    assert isinstance(conf, PolicyConfigurator)
    problem = Problem(MAPS / "tiny.json")
    a = run(problem, configurator="lamde", seed=1, population=10, budget=100)
    b = run(problem, configurator=conf, seed=1, population=10, budget=100)
    assert np.array_equal(a.x, b.x)


def test_plan_init_modes_differ_and_are_checked() -> None:
    # the DE's own start population (no constructive starts, which both modes share)
    kw = {"seed": 0, "budget": 200, "population": 10, "polish": False, "starts": 0}
    seeded = plan(MAPS / "tiny.json", **kw)
    again = plan(MAPS / "tiny.json", init="seeded", **kw)
    uniform = plan(MAPS / "tiny.json", init="uniform", **kw)
    assert np.array_equal(seeded.history["best_f"], again.history["best_f"])
    assert not np.array_equal(seeded.history["best_f"], uniform.history["best_f"])
    with pytest.raises(ValueError, match="init: must be one of seeded, uniform, got 'random'"):
        plan(MAPS / "tiny.json", init="random")


def test_plan_with_lamde_is_deterministic() -> None:
    a = plan(MAPS / "tiny.json", seed=3, budget=200, population=10, configurator="lamde",
             init="uniform", polish=False)
    b = plan(MAPS / "tiny.json", seed=3, budget=200, population=10, configurator="lamde",
             init="uniform", polish=False)
    assert a.configurator == "lamde"
    assert np.array_equal(a.hover_points, b.hover_points) and a.f == b.f and a.phi == b.phi


def test_cli_plan_accepts_lamde_and_init(tmp_path, capsys) -> None:  # noqa: ANN001
    out = tmp_path / "m.plan"
    rc = main(["plan", str(MAPS / "tiny.json"), "-o", str(out), "--configurator", "lamde",
               "--init", "uniform", "--budget", "300", "--population", "10", "--quiet",
               "--allow-infeasible", "--report", str(tmp_path / "r.json")])
    assert rc in (0, 1) and out.exists()
    assert json.loads((tmp_path / "r.json").read_text())["plan"]["configurator"] == "lamde"
    with pytest.raises(SystemExit):
        main(["plan", str(MAPS / "tiny.json"), "-o", str(out), "--init", "sideways"])


def test_cli_train_bad_input_is_one_line_exit_2(tmp_path, capsys) -> None:  # noqa: ANN001
    pytest.importorskip("torch")
    assert main(["train", "-o", str(tmp_path / "ck"), "--set", "bogus=1"]) == 2
    assert "--set: unknown field 'bogus'" in capsys.readouterr().err
    assert main(["train", "-o", str(tmp_path / "ck"), "--problems",
                 str(tmp_path / "none.json")]) == 2
    assert "--problems:" in capsys.readouterr().err
    assert main(["train", "-o", str(tmp_path / "ck"), "--budget", "3", "--population",
                 "10"]) == 2
    assert main(["train", "-o", str(tmp_path / "ck"), "--imitate", "lamde"]) == 2
    assert "--imitate: unknown configurator 'lamde'" in capsys.readouterr().err
    capsys.readouterr()
    # a value of the wrong type (a traceback at the first comparison); the DE's least
    # population (it said 5, then refused 5 further on); -o a file (a traceback)
    a_file = tmp_path / "a.plan"
    a_file.write_text("mine")
    for args, needle in (
        (["--set", "lr=abc"], "--set lr: must be a number (its default is 0.0003), got 'abc'"),
        (["--set", "n_steps=2.5"], "--set n_steps: must be an integer"),
        (["--set", "net.hidden=true"], "--set net.hidden: must be an integer"),
        (["--population", "5"], "--population: must be >= 6, got 5"),
        (["--jobs", "257"], "--jobs: must be at most 256"),
        (["--maps", "1001"], "--maps: must be an integer in [1, 1,000] (the training maps' seeds"),
        (["--maps", "0"], "--maps: must be an integer in [1, 1,000]"),
        (["--bbob", "14401"], "--bbob: count must be an integer in [1, 14,400], got 14401"),
        (["-o", str(a_file)], f"-o/--output: {a_file}: is a file, not a folder"),
        # under a file: it ran the warm start, then crashed (NotADirectoryError, exit 1)
        (["-o", str(a_file / "sub"), "--maps", "1", "--envs", "2", "--epochs", "1", "--budget",
          "500", "--population", "20", "--imitate-epochs", "1"],
         f"-o/--output: {a_file / 'sub'}: {a_file} is a file, not a folder"),
    ):
        out = [] if "-o" in args else ["-o", str(tmp_path / "ck")]
        assert main(["train", *out, *args]) == 2, args
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and needle in err[0], (args, err)
    assert not (tmp_path / "ck").exists() and a_file.read_text() == "mine"


def test_cli_train_resume_from_a_damaged_state_is_one_line(tmp_path, capsys) -> None:  # noqa: ANN001
    """`train --resume` on a state.pt cut short ended in torch's "PytorchStreamReader failed
    reading zip archive" traceback, exit 1 (a state of another kind: a KeyError); now one line
    naming the file, exit 2, the folder's files unchanged."""
    import io

    torch = pytest.importorskip("torch")
    buf = io.BytesIO()
    torch.save({"model": {"w": torch.zeros(64, 64)}, "epoch": 1}, buf)
    whole = buf.getvalue()
    ck = tmp_path / "ck"
    ck.mkdir()
    (ck / "weights.npz").write_bytes(b"kept")
    state = ck / "state.pt"
    problems = tmp_path / "p.json"
    problems.write_text(json.dumps({"problems": [{"kind": "map",
                                                  "path": str(MAPS / "tiny.json")}]}))
    args = ["train", "-o", str(ck), "--resume", "--problems", str(problems), "--envs", "2",
            "--epochs", "1", "--budget", "60", "--population", "6", "--quiet"]
    for content, needle in ((whole[: len(whole) // 2], "not a readable training state"),
                            (b"", "not a readable training state"),
                            (whole, "not a training state (no optimizer, curve, config, "
                             "specs)")):  # fmt: skip
        state.write_bytes(content)
        assert main(args) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith(f"lamde-mission train: --resume: {state}: "
                                                   f"{needle}"), err
        assert sorted(p.name for p in ck.iterdir()) == ["state.pt", "weights.npz"]
        assert state.read_bytes() == content and (ck / "weights.npz").read_bytes() == b"kept"


class _RunsCode:
    """A pickled object that runs code when unpickled: what a state.pt from elsewhere could
    hold."""

    def __init__(self, marker: str) -> None:
        self.marker = marker

    def __reduce__(self):  # noqa: ANN204
        return (open, (self.marker, "w"))


def test_cli_train_resume_runs_no_code_from_a_state_file(tmp_path, capsys) -> None:  # noqa: ANN001
    """`train --resume` read state.pt with torch.load(weights_only=False), i.e. full pickle: a
    state.pt from someone else could run any code on resume. It is read with weights_only=True
    (tensors, dicts, lists, numbers, strings: all a training state holds); anything else is
    refused in one line, exit 2, and nothing in it is run."""
    import io

    torch = pytest.importorskip("torch")
    marker = tmp_path / "ran"
    buf = io.BytesIO()
    torch.save({"model": {}, "optimizer": {}, "epoch": 1, "curve": [], "config": {},
                "specs": [], "evil": _RunsCode(str(marker))}, buf)
    ck = tmp_path / "ck"
    ck.mkdir()
    (ck / "weights.npz").write_bytes(b"kept")
    (ck / "state.pt").write_bytes(buf.getvalue())
    problems = tmp_path / "p.json"
    problems.write_text(json.dumps({"problems": [{"kind": "map",
                                                  "path": str(MAPS / "tiny.json")}]}))
    assert main(["train", "-o", str(ck), "--resume", "--problems", str(problems), "--envs", "2",
                 "--epochs", "1", "--budget", "60", "--population", "6", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a readable training state" in err[0], err
    assert not marker.exists()


def test_cli_train_help_shows_every_default() -> None:
    """`train --help` gave no default for --maps, --epochs, --envs, --population or --budget,
    where every other command's options show theirs; the values shown are PPOConfig's."""
    import argparse

    from lamde_mission.cli import build_parser
    from planner_core.defaults import TRAIN_DEFAULTS

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    train = sub.choices["train"]
    bare = [a.option_strings[-1] for a in train._actions
            if a.option_strings and a.nargs != 0 and not a.required  # an option taking a value
            and "default" not in (a.help or "")]  # fmt: skip
    assert bare == [], bare
    text = train.format_help()
    for shown in ("(default 8)", "(default 10; 0: the warm start alone)", "(default 4)",
                  "(default 50; planning uses 100)", "(default 3,000)"):
        assert shown in " ".join(text.split()), shown
    # the trainer reads them from the same table (a literal retyped in PPOConfig fails here)
    ppo = pytest.importorskip("planner_core.learning.policy.ppo")  # imports torch
    base = ppo.PPOConfig()
    assert dict(TRAIN_DEFAULTS) == {k: getattr(base, k) for k in TRAIN_DEFAULTS}


def test_a_uav_spec_with_a_non_integer_field_is_one_value_error_naming_it() -> None:
    """`problems.build` of a uav spec: size, density and seed must be JSON integers (int()
    raised TypeError for null, an unnamed ValueError for "abc", and cut 5000.5 to 5000);
    out-of-range values keep the generator's message, with the spec."""
    from planner_core.learning.policy.problems import build

    ok = {"kind": "uav", "size": 5000, "density": 1, "seed": 1}
    for key, value, needle in (
        ("size", None, "size must be an integer, got None"),
        ("density", "abc", "density must be an integer, got 'abc'"),
        ("size", 5000.5, "size must be an integer, got 5000.5"),
        ("seed", True, "seed must be an integer, got True"),
        ("seed", [1], "seed must be an integer, got [1]"),
        ("size", 7, "size must be one of [5000, 10000] (got 7)"),
        ("seed", -1, "seed must be a non-negative integer (got -1)"),
    ):
        with pytest.raises(ValueError, match=r"^problems: uav spec ") as e:
            build({**ok, key: value})
        assert needle in str(e.value) and "\n" not in str(e.value), (key, value)


def test_cli_train_refuses_a_uav_spec_with_a_null_field(tmp_path, capsys) -> None:  # noqa: ANN001
    """`lamde-mission train --problems` with {"size": null}: one line naming the field, exit 2
    (was a TypeError traceback), nothing written."""
    pytest.importorskip("torch")
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"problems": [{"kind": "uav", "size": None, "density": 1,
                                              "seed": 1}]}))
    assert main(["train", "-o", str(tmp_path / "ck"), "--problems", str(path), "--epochs",
                 "1", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "size must be an integer, got None" in err[0], err
    assert not (tmp_path / "ck" / "weights.npz").exists()


def test_cli_train_runs_on_a_trainset_file(tmp_path, capsys) -> None:  # noqa: ANN001
    pytest.importorskip("torch")
    trainset = tmp_path / "trainset.json"
    trainset.write_text(json.dumps({"problems": [
        {"kind": "map", "path": str(MAPS / "tiny.json")}]}))
    rc = main(["train", "-o", str(tmp_path / "ck"), "--problems", str(trainset), "--epochs",
               "1", "--envs", "1", "--population", "6", "--budget", "30", "--quiet",
               "--set", "n_steps=2", "--set", "net.embed=8", "--imitate", "fixed",
               "--imitate-epochs", "1"])
    assert rc == 0
    assert (tmp_path / "ck" / "weights.npz").exists()
    # a second training into the same folder would overwrite the checkpoint: refused
    before = (tmp_path / "ck" / "weights.npz").read_bytes()
    assert main(["train", "-o", str(tmp_path / "ck"), "--problems", str(trainset)]) == 2
    assert "holds a checkpoint already: --resume continues" in capsys.readouterr().err
    assert (tmp_path / "ck" / "weights.npz").read_bytes() == before
    config = json.loads((tmp_path / "ck" / "config.json").read_text())
    assert config["net"]["embed"] == 8 and config["training"]["ppo"]["imitate"] == "fixed"
    assert len(config["training"]["imitation"]) == 1
    # a new training reads the observation's context and uses per-individual credit
    from planner_core.learning.env import N_CONTEXT

    assert config["net"]["context"] == N_CONTEXT
    assert config["training"]["ppo"]["credit"] == "individual"


def test_cli_plan_with_a_trained_checkpoint_folder(tmp_path, capsys) -> None:  # noqa: ANN001
    from planner_core.learning.policy import NetConfig, init_params, save

    save(tmp_path / "ck", init_params(NetConfig(embed=8, heads=1, ff=8, hidden=8), 1),
         NetConfig(embed=8, heads=1, ff=8, hidden=8))
    out = tmp_path / "m.plan"
    args = ["plan", str(MAPS / "tiny.json"), "-o", str(out), "--budget", "200",
            "--population", "10", "--quiet", "--allow-infeasible"]
    assert main([*args, "--configurator", "lamde", "--policy", str(tmp_path / "ck")]) in (0, 1)
    assert out.exists()
    assert main([*args, "--policy", str(tmp_path / "ck")]) == 2
    assert "--policy: only with --configurator lamde" in capsys.readouterr().err
    assert main([*args, "--configurator", "lamde", "--policy", str(tmp_path / "none")]) == 2
    assert "--policy: checkpoint:" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["lamde-v1", "lamde-v2"])
def test_shipped_checkpoint_is_small_and_documented(name: str) -> None:
    from planner_core.learning.policy.checkpoint import DEFAULT_CHECKPOINT, SHIPPED

    assert DEFAULT_CHECKPOINT == "lamde-v2"
    folder = SHIPPED / name
    assert sum(p.stat().st_size for p in folder.iterdir()) < 5 * 2**20
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["problems"] and all(s["kind"] == "uav" for s in manifest["problems"])
    curve = (folder / "curve.csv").read_text().splitlines()
    config = json.loads((folder / "config.json").read_text())
    assert len(curve) == 1 + config["training"]["epochs_done"]


@pytest.mark.slow  # measured 1.7 s on a loaded machine (default suite <= 5 min)
def test_bench_policy_runs_on_a_small_map() -> None:
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    r = subprocess.run([sys.executable, str(root / "benchmarks" / "bench_policy.py"),
                        str(MAPS / "tiny.json"), "--generations", "4", "--population", "10"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "policy / evaluation = " in r.stdout


@pytest.mark.slow  # measured 1.6 s on a loaded machine (default suite <= 5 min)
def test_compare_checkpoints_marks_each_map(tmp_path) -> None:  # noqa: ANN001
    """benchmarks/compare_checkpoints.py: per map, on the seeds both files share, '+' where the
    candidate's lamde runs rank significantly lower, '~' where they do not differ."""
    import subprocess
    import sys
    from pathlib import Path

    def rec(m: str, seed: int, score: float, conf: str = "lamde") -> str:
        return json.dumps({"map": m, "mode": "uniform", "configurator": conf, "seed": seed,
                           "pipeline": "de", "f": score, "phi": 0.0, "score": score})

    cand = [rec("A", s, 10.0 + s * 0.01) for s in range(12)] + [
        rec("B", s, 50.0 + s) for s in range(12)] + [rec("A", 0, 1e9, "random")]
    base = [rec("A", s, 20.0 + s * 0.01) for s in range(12)] + [
        rec("B", s, 50.5 + s) for s in range(14)]
    (tmp_path / "c.jsonl").write_text("\n".join(cand) + "\n")
    (tmp_path / "b.jsonl").write_text("\n".join(base) + "\n")
    root = Path(__file__).resolve().parent.parent
    r = subprocess.run([sys.executable, str(root / "benchmarks" / "compare_checkpoints.py"),
                        str(tmp_path / "c.jsonl"), str(tmp_path / "b.jsonl")],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    rows = {line.split()[0]: line.split() for line in r.stdout.splitlines()[1:3]}
    assert rows["A"][3] == "+" and rows["A"][4] == "12"
    assert rows["B"][3] == "~" and rows["B"][4] == "12"
    assert "significantly better on 1, worse on 0, no difference on 1" in r.stdout


def test_cli_train_reads_the_lam_trainset_format(tmp_path) -> None:  # noqa: ANN001
    """A `lamde-mission lam select` file (format lamde-trainset/1) trains as it is."""
    pytest.importorskip("torch")
    pytest.importorskip("ioh")
    from planner_core.learning.policy.problems import build, read_trainset

    pair = {"objective": {"function": 1, "dimension": 4, "instance": 1},
            "constraint": {"function": 2, "dimension": 4, "instance": 1},
            "threshold": 0.0, "scale": 10.0, "task": "T01", "distance_f": 0.1,
            "distance_phi": 0.2}
    trainset = tmp_path / "trainset.json"
    trainset.write_text(json.dumps({"format": "lamde-trainset/1", "options": {},
                                    "problems": [pair, {**pair, "threshold": 5.0}]}))
    specs = read_trainset(trainset)
    assert [s["kind"] for s in specs] == ["lam-pair", "lam-pair"]
    problem = build(specs[0])
    f, phi = problem.evaluate(np.full((3, 4), 0.5))
    assert f.shape == phi.shape == (3,)
    rc = main(["train", "-o", str(tmp_path / "ck"), "--problems", str(trainset), "--epochs",
               "1", "--envs", "2", "--population", "6", "--budget", "30", "--quiet",
               "--set", "n_steps=2", "--set", "net.embed=8"])
    assert rc == 0
    manifest = json.loads((tmp_path / "ck" / "manifest.json").read_text())
    assert manifest["problems"] == specs


def test_a_trainset_file_is_read_within_the_input_limits(tmp_path) -> None:  # noqa: ANN001
    """`train --problems` read its file with plain json (no size limit) and any number of
    problems: now the project's reader, and at most the full database's count."""
    from planner_core.learning.lam.trainset import MAX_PROBLEMS
    from planner_core.learning.policy.problems import read_trainset

    many = tmp_path / "many.json"
    spec = {"kind": "map", "path": str(MAPS / "tiny.json")}
    many.write_text(json.dumps({"problems": [spec] * (MAX_PROBLEMS + 1)}))
    with pytest.raises(ValueError, match=f"{MAX_PROBLEMS + 1} problems, more than {MAX_PROBLEMS}"):
        read_trainset(many)
    bad = tmp_path / "bad.json"
    bad.write_bytes(b'{"problems": [\xff]}')
    with pytest.raises(ValueError, match=r"^--problems: .*bad\.json: "):
        read_trainset(bad)


def test_train_ends_with_a_plan_command_that_plans_with_the_checkpoint(
        tmp_path, capsys) -> None:  # noqa: ANN001
    # the line `train` ends with is a command a user can paste (docs/learning.md): MAP and OUT
    # filled in, it plans with the new policy
    pytest.importorskip("torch")
    import shlex

    trainset = tmp_path / "set.json"
    trainset.write_text(json.dumps({"problems": [{"kind": "map",
                                                  "path": str(MAPS / "tiny.json")}]}))
    ck = tmp_path / "my policy"
    assert main(["train", "-o", str(ck), "--problems", str(trainset), "--epochs", "1",
                 "--envs", "1", "--population", "6", "--budget", "30", "--set", "n_steps=2",
                 "--set", "net.embed=8"]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last.startswith(f"wrote {ck} (plan with it: lamde-mission plan MAP -o OUT ")
    command = last.split("plan with it: ", 1)[1].split("; in Python", 1)[0]
    argv = shlex.split(command)[1:]  # without the console script's name
    out = tmp_path / "m.plan"
    argv = [str(MAPS / "tiny.json") if a == "MAP" else str(out) if a == "OUT" else a
            for a in argv]
    assert argv[argv.index("--policy") + 1] == str(ck)  # the space survives the quoting
    rc = main([*argv, "--budget", "200", "--population", "6", "--quiet", "--allow-infeasible",
               "--report", str(tmp_path / "r.json")])
    assert rc in (0, 1) and out.exists()
    got = json.loads((tmp_path / "r.json").read_text())["plan"]["configurator"]
    assert got == f"lamde:{ck}"


def test_a_plan_records_which_policy_configured_it() -> None:
    # the record keeps the options it ran with: the shipped policy is "lamde", another
    # checkpoint names itself (not the class name every checkpoint shares)
    kw = {"seed": 0, "budget": 120, "population": 10, "polish": False, "starts": 0}
    shipped = plan(MAPS / "tiny.json", configurator=PolicyConfigurator(), **kw)
    assert shipped.configurator == "lamde" and shipped.config["configurator"] == "lamde"
    moded = plan(MAPS / "tiny.json", configurator=PolicyConfigurator(mode=True), **kw)
    assert moded.configurator == "lamde:mode"
    assert PolicyConfigurator(checkpoint="/x/y", params={}, net=object()).name == "lamde:/x/y"
