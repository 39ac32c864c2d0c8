"""The README holds for a reader who has only the repository: its Python blocks run when pasted,
every command example outside the quick start is exercised by a named test, it cites no path
outside the repository, and `.gitignore` ignores no tracked file."""

from __future__ import annotations

import ast
import re
import subprocess
import sys

import pytest

from tests.conftest import ROOT

README = (ROOT / "README.md").read_text(encoding="utf-8")


def _blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", README, re.S)


def _commands() -> list[str]:
    """The command lines of the README's bash blocks after the quick start section (continuation
    lines joined, comments and a trailing `&` dropped)."""
    body = README[README.index("\n## ", README.index("## Quick start") + 1):]
    cmds = []
    for block in re.findall(r"```bash\n(.*?)```", body, re.S):
        for line in block.replace("\\\n", " ").splitlines():
            cmd = re.sub(r"\s+", " ", line.split("#")[0]).strip().rstrip("&").strip()
            if cmd:
                cmds.append(cmd)
    return cmds


@pytest.mark.parametrize("i", range(len(_blocks("python"))))
def test_python_block_runs_when_pasted(i: int) -> None:
    code = _blocks("python")[i]
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, f"README python block {i} failed:\n{code}\n{r.stderr[-3000:]}"


#: README command (its leading words, enough to tell it apart) -> the test that runs it, and the
#: strings that test's source must contain (the subcommand and the options the README shows)
COVERED_BY: dict[str, tuple[str, tuple[str, ...]]] = {
    "lamde-mission map from-geojson campus.geojson":
        ("test_gis.py::campus", ("from-geojson",)),  # the fixture every campus test uses
    "lamde-mission map from-geojson ends.geojson":
        ("test_readme.py::test_from_geojson_whole_file_layers_cli", ("--obstacles", "--sensors")),
    "lamde-mission map from-geojson fence.plan":
        ("test_gis.py::test_qgroundcontrol_geofence", ("from-geojson", ".plan")),
    "lamde-mission plan campus.json":
        ("test_gis.py::test_campus_plan_cli_verifies", ('"plan"',)),
    "lamde-mission map to-geojson":
        ("test_gis.py::test_round_trip_keeps_every_vertex_within_a_centimetre", ("to-geojson",)),
    "lamde-mission plan examples/maps/small-demo.json":
        ("test_cli_plan.py::test_plan_writes_plan_plot_report_and_verifies", ("--plot",)),
    "lamde-mission plan examples/maps/small-demo.json -o mission.plan --configurator lamde":
        ("test_policy_cli.py::test_cli_plan_accepts_lamde_and_init", ("lamde", "--init")),
    # `train --maps ...` runs the same CLI path on suite maps (minutes): the CLI test uses a
    # trainset file; --resume is tested through the API
    "lamde-mission train":
        ("test_policy_cli.py::test_cli_train_runs_on_a_trainset_file", ('"train"',)),
    "lamde-mission train -o my-policy --problems":
        ("test_policy_cli.py::test_cli_train_runs_on_a_trainset_file", ('"--problems"',)),
    "lamde-mission train -o my-policy --epochs 20 --resume":
        ("test_policy.py::test_two_epoch_training_smoke_run_and_resume", ("resume=True",)),
    "lamde-mission train -o my-policy --maps 16 --envs 4 --jobs":
        ("test_rollout.py::test_same_seed_same_checkpoint_in_this_process_and_on_two_workers",
         ('"--jobs"', "train_cli")),
    "lamde-mission train -o my-policy --maps 16 --envs 16 --backend ray":
        ("test_execution_ray.py::test_train_on_ray_gives_the_checkpoint_of_this_process",
         ('"--backend", "ray"', "train_cli")),
    "lamde-mission verify":
        ("test_plot_cli.py::test_verify_good_mission_exits_0", ('"verify"',)),
    "lamde-mission show":
        ("test_plot_cli.py::test_show_writes_png", ('"show"',)),
    "lamde-mission generate --suite":
        ("test_suite.py::test_cli_suite_reproduces_committed_files", ('"--suite"',)),
    "lamde-mission generate my.json":
        ("test_suite.py::test_cli_one_map", ('"--density"', '"--seed"')),
    "lamde-mission mock-vehicle":
        ("test_vehicle.py::test_cli_mock_vehicle_runs_until_ctrl_c", ("mock-vehicle",)),
    "lamde-mission upload":
        ("test_vehicle.py::test_cli_upload_plan", ('"upload"', "--connect")),
    "python examples/upload_to_mock.py":
        ("test_readme.py::test_upload_to_mock_example_runs", ("upload_to_mock.py",)),
    "lamde-mission lam build":
        ("test_lam_query.py::test_cli_build_reports_progress_and_resumes", ('"build"',)),
    "lamde-mission lam select":
        ("test_lam_query.py::test_cli_select_on_maps_writes_the_same_file_twice",
         ('"select"', '"--plot"')),
    "python benchmarks/bench_evaluate.py":
        ("test_gis.py::test_bench_evaluate_prints_suite_and_campus_in_one_run",
         ("bench_evaluate",)),
    "python benchmarks/bench_plan.py": ("test_benchmarks.py", ("bench_plan",)),
    "lamde-mission bench": ("test_bench.py::test_cli_bench_then_report", ('"bench"',)),
    "lamde-mission report": ("test_bench.py::test_cli_bench_then_report", ('"report"',)),
}


def _source_of(node_id: str) -> str:
    """The source of the test function named by `file.py::name` (the whole file without a
    name); AssertionError if it does not exist."""
    file, _, name = node_id.partition("::")
    text = (ROOT / "tests" / file).read_text(encoding="utf-8")
    if not name:
        return text
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.FunctionDef) and node.name == name:
            return ast.get_source_segment(text, node) or ""
    raise AssertionError(f"{node_id}: no such test")


def _check_extras(cmd: str) -> None:
    """The extras a README `pip install -e '.[a,b]'` line names are declared in pyproject."""
    import tomllib

    extras = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"][
        "optional-dependencies"]  # fmt: skip
    named = re.search(r"\.\[([\w,]+)\]", cmd)
    assert named, cmd
    for extra in named.group(1).split(","):
        assert extra in extras, f"README `{cmd}`: no extra {extra!r} in pyproject.toml"


def test_every_readme_command_is_exercised_by_a_test() -> None:
    cmds = _commands()
    assert len(cmds) >= 15, cmds  # the extraction still finds the examples
    for cmd in cmds:
        if cmd.startswith("pip install -e "):  # an install: its extras must exist (below)
            _check_extras(cmd)
            continue
        keys = [k for k in COVERED_BY if cmd.startswith(k)]
        assert keys, f"README command `{cmd}` is exercised by no test listed in COVERED_BY"
        node_id, needles = COVERED_BY[max(keys, key=len)]
        src = _source_of(node_id)
        for needle in needles:
            assert needle in src, f"{node_id} does not exercise `{cmd}` ({needle!r} missing)"


def test_upload_to_mock_example_runs() -> None:
    r = subprocess.run([sys.executable, "examples/upload_to_mock.py", "--via", "pymavlink"],
                       cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr


def test_readme_names_no_path_outside_the_repository() -> None:
    assert "../" not in README
    assert "Learning to Optimize UAV Path Planning" in README  # the paper, cited by title


def test_gitignore_ignores_no_tracked_file() -> None:
    r = subprocess.run(["git", "ls-files", "-ci", "--exclude-standard"], cwd=ROOT,
                       capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip("not a git checkout")
    assert r.stdout == "", f".gitignore ignores tracked files:\n{r.stdout}"


def test_from_geojson_whole_file_layers_cli(tmp_path) -> None:
    """The README's `map from-geojson ends.geojson --obstacles ... --sensors ...` line."""
    import json

    def fc(*features: dict) -> dict:
        return {"type": "FeatureCollection", "features": list(features)}

    def feat(geom_type: str, coords: object, **props: object) -> dict:
        return {"type": "Feature", "properties": props,
                "geometry": {"type": geom_type, "coordinates": coords}}  # fmt: skip

    def pt(i: float, j: float) -> list[float]:
        return [7.32 + i * 0.001, 46.21 + j * 0.001]

    files = {
        "ends.geojson": fc(feat("Point", pt(0, 0), kind="start"), feat("Point", pt(5, 5),
                                                                        kind="end")),
        "osm-buildings.geojson": fc(feat("Polygon", [[pt(2, 2), pt(3, 2), pt(3, 3), pt(2, 3)]])),
        "gateways.geojson": fc(feat("Point", pt(1, 1), id="g1"), feat("Point", pt(4, 4))),
    }
    for name, doc in files.items():
        (tmp_path / name).write_text(json.dumps(doc))
    r = subprocess.run([sys.executable, "-m", "lamde_mission.cli", "map", "from-geojson",
                        "ends.geojson", "--obstacles", "osm-buildings.geojson", "--sensors",
                        "gateways.geojson", "-o", "campus.json"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=300)  # fmt: skip
    assert r.returncode == 0, r.stderr
    m = json.loads((tmp_path / "campus.json").read_text())
    assert len(m["sensors"]) == 2 and m["sensors"][0]["id"] == "g1"
    assert len(m["obstacles"]["polygons"]) == 1


def test_gallery_is_what_its_script_writes() -> None:
    """docs/gallery.md is the script's rendering, and every picture it shows is committed."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_gallery", ROOT / "docs" / "make_gallery.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert (ROOT / "docs" / "gallery.md").read_text(encoding="utf-8") == mod.render_markdown(), \
        "docs/gallery.md is stale: run `python docs/make_gallery.py`"  # fmt: skip
    assert len(mod.ENTRIES) >= 4
    for _, _, cmds in mod.ENTRIES:
        png = ROOT / mod.picture(cmds)
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", png
        for cmd in cmds:  # repository paths only: a clone has everything the gallery needs
            assert "../" not in cmd and "shared" not in cmd
