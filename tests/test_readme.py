"""The README and the manual hold for a reader who has only the repository: the README's tutorial
runs as written (its shell blocks in order, in a scratch folder), every Python block of the
README and of the manual's pages runs when pasted, every other command example is exercised by a
named test, no page cites a path outside the repository, and `.gitignore` ignores no tracked
file."""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import ROOT
from tests.vehicle_helpers import free_udp_port

README = (ROOT / "README.md").read_text(encoding="utf-8")
#: the manual's hand-written pages that took over the README's reference sections: their
#: examples are held as the README's were (the reference pages are generated, see
#: tests/test_docs_site.py; the study pages are reports with tests of their own)
MANUAL = ("getting-started.md", "maps.md", "planning.md", "missions.md", "flying.md",
          "benchmarks.md", "learning.md", "ray.md", "layout.md", "fleet.md", "reference/api.md")


def _page(name: str) -> str:
    return (ROOT / "docs" / name).read_text(encoding="utf-8")


def _fenced(text: str, lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", text, re.S)


def _blocks(lang: str) -> list[str]:
    return _fenced(README, lang)


def _tutorial() -> str:
    """The README after its quick start (whose `make` lines install; `make` wraps the rest)."""
    return README[README.index("\n## ", README.index("## Quick start") + 1):]


def _examples() -> list[tuple[str, str]]:
    """(where, text) of every part whose command examples must be exercised by a named test:
    the README's prose after the quick start (its shell blocks run in
    test_readme_tutorial_runs), and each manual page (getting-started.md from its first
    mission on: before it, the same install commands as the quick start)."""
    parts = [("README.md", re.sub(r"```bash\n.*?```", "", _tutorial(), flags=re.S))]
    for name in MANUAL:
        text = _page(name)
        if name == "getting-started.md":
            text = text[text.index("## The first mission"):]
        parts.append((f"docs/{name}", text))
    return parts


def _commands() -> list[str]:
    """The command lines of the README and the manual pages (see `_examples`): every line of
    their bash blocks (continuation lines joined, comments and a trailing `&` dropped, the body
    of a here-document skipped) and every inline `lamde-mission ...` / `python ...` example in
    their text (the `make` targets wrap these)."""
    cmds = []
    for _, text in _examples():
        for block in _fenced(text, "bash"):
            block = re.sub(r"<<'?(\w+)'?\n.*?\n\1\n", "\n", block, flags=re.S)
            for line in block.replace("\\\n", " ").splitlines():
                cmd = re.sub(r"\s+", " ", line.split("#")[0]).strip().rstrip("&").strip()
                if cmd:
                    cmds.append(cmd)
        prose = re.sub(r"```.*?```", "", text, flags=re.S)
        cmds += re.findall(r"`((?:lamde-mission|python) [^`\n]+)`", prose)
    return cmds


def _python_blocks() -> list[tuple[str, int, str]]:
    out = [("README.md", i, code) for i, code in enumerate(_blocks("python"))]
    for name in MANUAL:
        out += [(f"docs/{name}", i, code) for i, code in enumerate(_fenced(_page(name), "python"))]
    return out


def _scratch(tmp_path: Path) -> Path:
    """A folder to run examples in: the repository's `examples/` linked in, nothing else, so
    what they write lands there and not in the checkout."""
    (tmp_path / "examples").symlink_to(ROOT / "examples", target_is_directory=True)
    return tmp_path


@pytest.mark.parametrize("where,i,code", _python_blocks(),
                         ids=[f"{w}-{i}" for w, i, _ in _python_blocks()])
@pytest.mark.slow  # measured 17 s over 4 cases (issue 35: default suite <= 5 min)
def test_python_block_runs_when_pasted(where: str, i: int, code: str, tmp_path: Path) -> None:
    r = subprocess.run([sys.executable, "-c", code], cwd=_scratch(tmp_path), capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, f"{where} python block {i} failed:\n{code}\n{r.stderr[-3000:]}"


@pytest.mark.slow  # measured 32 s (issue 35: default suite <= 5 min)
def test_readme_tutorial_runs(tmp_path: Path) -> None:
    """The README's shell blocks after the quick start, in order, as one bash script in a
    scratch folder: the first mission planned, verified and drawn, the GeoJSON map imported,
    checked and planned, the mission uploaded to the mock vehicle, plainly and signed. The only
    change: the mock and the uploader meet on a free port instead of 14540 (another test may
    hold it)."""
    blocks = _fenced(_tutorial(), "bash")
    assert len(blocks) >= 4, "the tutorial lost its shell blocks"
    port = free_udp_port()
    mock = f"lamde-mission mock-vehicle --connect udpout:127.0.0.1:{port}"
    script = "\n".join(blocks).replace("lamde-mission mock-vehicle", mock)
    script = script.replace("14540", str(port))
    bindir = Path(sys.executable).parent
    env = {**os.environ, "PATH": f"{bindir}{os.pathsep}{os.environ.get('PATH', '')}"}
    env.pop("LAMDE_MAVLINK_SIGNING_KEY", None)
    if not (bindir / "lamde-mission").exists():
        pytest.skip(f"no lamde-mission console script beside {sys.executable}")
    where = _scratch(tmp_path)
    r = subprocess.run(
        ["bash", "-c", "set -euo pipefail\ntrap 'kill $(jobs -p) 2>/dev/null || true' EXIT\n"
         + script], cwd=where, env=env, capture_output=True, text=True, timeout=600)  # fmt: skip
    assert r.returncode == 0, f"README tutorial failed:\n{script}\n{r.stdout[-3000:]}\n" \
        f"{r.stderr[-3000:]}"  # fmt: skip
    for name in ("mission.plan", "mission.png", "mission.svg", "my-area.json", "my-area.plan",
                 "my-area.png"):
        assert (where / name).stat().st_size > 0, name
    assert "result: all constraints hold" in r.stdout  # verify's last line
    assert r.stdout.count("read back and compared") == 2 and "identical" in r.stdout


def test_readme_reaches_a_verified_mission_in_60_lines() -> None:
    head = "\n".join(README.splitlines()[:60])
    assert "lamde-mission plan examples/maps/small-demo.json" in head
    assert "lamde-mission verify examples/maps/small-demo.json mission.plan" in head
    assert len(README.splitlines()) <= 300


#: README command (its leading words, enough to tell it apart) -> the test that runs it, and the
#: strings that test's source must contain (the subcommand and the options the README shows)
COVERED_BY: dict[str, tuple[str, tuple[str, ...]]] = {
    "lamde-mission map from-geojson examples/gis/campus.geojson":
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
    "lamde-mission train -o my-policy --bbob":
        ("test_ablations.py::test_cli_train_bbob_and_fixed_length", ('"--bbob"', '"--bbob-dims"')),
    "lamde-mission train -o my-policy --problems trainset.json --fixed-length":
        ("test_ablations.py::test_cli_train_bbob_and_fixed_length", ('"--fixed-length"',)),
    "python -m planner_core.pipeline.warmup":
        ("test_api.py::test_the_install_step_leaves_every_kernel_of_a_plan_cached",
         ('"planner_core.pipeline.warmup"',)),
    "python -m planner_core.learning.policy.credit":
        ("test_credit.py::test_the_credit_diagnostic_cli_prints_both_signals", ("credit.main",)),
    "python benchmarks/ablations.py":
        ("test_ablations.py::test_ablation_driver_end_to_end_is_resumable_and_reproducible",
         ('"--report"', '"--jobs"')),
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
    "lamde-mission generate farm.json --layout":
        ("test_generate_large.py::test_the_documented_large_map_command_runs",
         ("maps.md", '"--cluster-size"')),
    "lamde-mission generate my.json":
        ("test_suite.py::test_cli_one_map", ('"--density"', '"--seed"')),
    "lamde-mission mock-vehicle":
        ("test_vehicle.py::test_cli_mock_vehicle_runs_until_ctrl_c", ("mock-vehicle",)),
    "lamde-mission upload":
        ("test_vehicle.py::test_cli_upload_plan", ('"upload"', "--connect")),
    "lamde-mission plan examples/maps/fleet-demo.json -o demo/":
        ("test_sorties.py::test_plan_dir_writes_sorties_the_sim_passes_and_verify_catches_energy",
         ('"-o"', "_verify_cli")),
    "lamde-mission upload DIR/ --fleet":
        ("test_vehicle_fleet.py::test_cli_upload_fleet_dir", ('"upload"', '"--fleet"')),
    "lamde-mission mock-vehicle --vehicles":
        ("test_vehicle_fleet.py::test_cli_mock_vehicle_fleet_runs_until_ctrl_c",
         ('"mock-vehicle"', '"--vehicles"', '"--ports"')),
    "lamde-mission mock-vehicle --vehicles 3 --param MPC_XY_VEL_MAX=20":
        ("test_speed_limit.py::test_the_documented_fleet_recipe_runs_as_written",
         ("MPC_XY_VEL_MAX=20", '"upload"', '"--fleet"')),
    "lamde-mission mock-vehicle --sysids":
        ("test_vehicle_fleet.py::test_cli_mock_vehicle_fleet_runs_until_ctrl_c",
         ('"mock-vehicle"', '"--sysids"')),
    "lamde-mission upload mission.plan --sysid":
        ("test_vehicle_fleet.py::test_single_upload_picks_a_vehicle_by_system_id",
         ('"upload"', '"--sysid"')),
    "lamde-mission plan MAP -o DIR/ --plot":
        ("test_vehicle_fleet.py::test_cli_plan_plot_draws_the_sortie_directory",
         ('"plan"', '"--plot"')),
    "lamde-mission show MAP DIR/":
        ("test_vehicle_fleet.py::test_cli_show_fleet_dir", ('"show"',)),
    "python examples/fleet_to_mock.py":
        ("test_vehicle_fleet.py::test_fleet_to_mock_example_runs", ("fleet_to_mock.py",)),
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
    "python benchmarks/bench_plan.py --compare":
        ("test_benchmarks.py::test_bench_plan_compares_with_another_checkout", ('"--compare"',)),
    "python benchmarks/bench_plan.py": ("test_benchmarks.py", ("bench_plan",)),
    "python benchmarks/compare_runs.py":
        ("test_benchmarks.py::test_compare_runs_marks_maps_by_rank_sum_and_by_seed",
         ("compare_runs",)),
    "python benchmarks/bench_anytime.py":
        ("test_benchmarks.py::test_bench_anytime_tables_the_gap_per_budget_multiple",
         ("bench_anytime", '"--jobs"')),
    "python benchmarks/bench_order.py":
        ("test_benchmarks.py::test_bench_order_compares_our_order_with_ortools", ("bench_order",)),
    "python benchmarks/bench_descent.py":
        ("test_benchmarks.py::test_bench_descent_compares_the_step_rules_start_by_start",
         ("bench_descent",)),
    "lamde-mission bench": ("test_bench.py::test_cli_bench_then_report", ('"bench"',)),
    "lamde-mission bench --runs 25 --jobs 2 --out results --no-best-known-update":
        ("test_bench.py::test_cli_bench_updates_the_best_known_file_beside_the_suite_unless_told_"
         "not_to", ('"bench"', '"--no-best-known-update"')),
    "lamde-mission report": ("test_bench.py::test_cli_bench_then_report", ('"report"',)),
    "lamde-mission report results -o docs/results.md --reference de-lamde --imax":
        ("test_studies.py::test_report_sections_from_study_folders_and_their_slim_copies",
         ('"report"', '"--imax"', '"--ablations"', '"--reference"')),
    "python benchmarks/store_runs.py":
        ("test_studies.py::test_store_runs_script", ("store_runs.py",)),
    "lamde-mission schema": ("test_mapio.py::test_cli_check_and_schema", ('"schema"',)),
    "lamde-mission check MAP": ("test_mapio.py::test_cli_check_and_schema", ('"check"',)),
    "lamde-mission map campus": ("test_gis.py::test_cli_map_campus_writes_the_benchmark_map",
                                 ('"campus"', '"-o"')),
    "lamde-mission plan MAP -o x.plan --population 5":
        ("test_defaults.py::test_cli_population_5_is_one_line_and_exit_2", ('"5"',)),
    "python -m planner_core.defaults README.md":
        ("test_defaults.py::test_update_readme_rewrites_only_the_table", ("update_readme",)),
    "python -m planner_core.learning.lam.train_encoder":
        ("test_lam_features.py::test_train_encoder_command_writes_weights",
         ("train_encoder", "main(")),
    "python benchmarks/bench_plan.py campus-500":
        ("test_benchmarks.py::test_bench_plan_on_the_campus", ("campus-500",)),
    "python benchmarks/bench_policy.py":
        ("test_policy_cli.py::test_bench_policy_runs_on_a_small_map", ("bench_policy",)),
    "python benchmarks/bench_lam.py":
        ("test_lam_query.py::test_bench_lam_runs_and_prints_the_estimates", ("bench_lam",)),
    "python benchmarks/fuzz_inputs.py":
        ("test_benchmarks.py::test_fuzz_inputs_runs", ("fuzz_inputs", '"--seed"')),
    "python benchmarks/bench_upload.py":
        ("test_benchmarks.py::test_bench_upload_end_to_end", ("bench_upload", '"--mission"',
                                                              '"--loss"', '"--runs"')),
    "python benchmarks/search_table.py":
        ("test_benchmarks.py::test_search_table_prints_the_comparison", ("search_table",)),
    "python benchmarks/cmaes_sigma_sweep.py":
        ("test_benchmarks.py::test_cmaes_sigma_sweep_runs_and_ranks", ("cmaes_sigma_sweep",)),
    "python benchmarks/refresh_best_known.py":
        ("test_benchmarks.py::test_refresh_best_known_stores_only_plans_the_sim_passes",
         ("refresh_best_known",)),
    "python benchmarks/bench_executor.py":
        ("test_benchmarks.py::test_bench_executor_runs", ("bench_executor",)),
    "python docs/make_gallery.py":
        ("test_readme.py::test_make_gallery_regenerates_the_gallery", ("make_gallery.py",)),
    "python docs/make_figures.py":
        ("test_bench_figures.py::test_make_figures_redraws_the_stored_runs", ("make_figures",)),
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


@pytest.mark.slow  # measured 5 s (issue 35: default suite <= 5 min)
def test_upload_to_mock_example_runs() -> None:
    r = subprocess.run([sys.executable, "examples/upload_to_mock.py", "--via", "pymavlink"],
                       cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr


def test_readme_names_no_path_outside_the_repository() -> None:
    assert "../" not in README
    assert "Learning to Optimize UAV Path Planning" in README  # the paper, cited by title


#: the paper's authors in its order (its title page); its copy carries no year or venue
PAPER_AUTHORS = ("Sijie Ma", "Zeyuan Ma", "Weijia Cao", "Yue-Jiao Gong", "Lingling Ma",
                 "Zhiyang Huang", "Jun Zhang")


def test_readme_cites_the_paper_in_full() -> None:
    """Title, every author in the paper's order, "preprint" and no invented year, and what we
    follow from it by section."""
    at = README.index("The method (LAMDE) is from the paper")
    cite = README[at:README.index("\n## ", at)]
    text = re.sub(r"\s*\n>?\s*", " ", cite)
    assert ("Learning to Optimize UAV Path Planning for Data Sensing in Wireless Sensor "
            "Networks") in text
    at = [text.index(a) for a in PAPER_AUTHORS]
    assert at == sorted(at), "authors out of the paper's order"
    assert "Preprint" in text and not re.search(r"\b(19|20)\d\d\b", text)
    for part in ("What we follow from it", "Sec. 3", "Sec. 4", "Sec. 5"):
        assert part in text


def test_gitignore_ignores_no_tracked_file() -> None:
    r = subprocess.run(["git", "ls-files", "-ci", "--exclude-standard"], cwd=ROOT,
                       capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip("not a git checkout")
    assert r.stdout == "", f".gitignore ignores tracked files:\n{r.stdout}"


@pytest.mark.slow  # measured 1.2 s on a loaded machine (default suite <= 5 min)
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


def _requirement_name(req: str) -> str:
    return re.split(r"[<>=!~\[; ]", req, maxsplit=1)[0].lower()


def test_getting_started_lists_what_the_install_and_each_extra_bring() -> None:
    """docs/getting-started.md's "What the install brings" names every core dependency, and its
    extras table every extra of pyproject.toml with exactly the packages that extra installs."""
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    page = _page("getting-started.md")
    at = page.index("What the install brings")
    brings = page[at:page.index("| extra |", at)].lower()
    aliases = {"cma": "pycma"}  # the package's import/registry name vs the name people use
    for req in project["dependencies"]:
        name = _requirement_name(req)
        assert aliases.get(name, name) in brings, f"the page does not list core dependency {name}"
    rows = {}
    for line in page[page.index("| extra |", at):].splitlines()[2:]:
        if not line.startswith("| `"):
            break
        cells = [c.strip() for c in line.strip("|").split("|")]
        listed = re.sub(r"\([^)]*\)", "", cells[1])  # version notes in brackets
        rows[cells[0].strip("`")] = {p.strip().lower() for p in listed.split(",")}
    extras = project["optional-dependencies"]
    assert set(rows) == set(extras), (sorted(rows), sorted(extras))
    for extra, reqs in extras.items():
        assert rows[extra] == {_requirement_name(r) for r in reqs}, extra


@pytest.mark.slow
def test_make_gallery_regenerates_the_gallery(tmp_path) -> None:
    """`python docs/make_gallery.py` (into a scratch tree): every picture written, the page the
    same as the committed one, and every picture the same pixels as the committed one (what
    the code draws today; the README's first picture is the gallery's demo.png)."""
    from PIL import Image

    r = subprocess.run([sys.executable, "docs/make_gallery.py", "--out", str(tmp_path)],
                       cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    pictures = re.findall(r"!\[[^]]*\]\(([^)]+)\)",
                          (tmp_path / "docs" / "gallery.md").read_text(encoding="utf-8"))
    assert len(pictures) >= 4
    for rel in pictures:
        png = tmp_path / "docs" / rel
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
        with Image.open(png) as new, Image.open(ROOT / "docs" / rel) as old:
            assert new.size == old.size and new.convert("RGB").tobytes() == old.convert(
                "RGB").tobytes(), f"docs/{rel} is not what the code draws: run `make figures`"
    assert (tmp_path / "docs" / "gallery.md").read_text(encoding="utf-8") == (
        ROOT / "docs" / "gallery.md").read_text(encoding="utf-8")


def test_every_link_and_repository_path_resolves() -> None:
    """Relative links of README.md and docs/**/*.md point at files of the repository, and every
    repository path the README and the manual pages name (docs/..., examples/...,
    benchmarks/..., ...) exists."""
    import glob
    import os

    pages = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    for page in pages:
        text = page.read_text(encoding="utf-8")
        for link in re.findall(r"\]\(([^)#\s]+)[^)]*\)", text):
            if re.match(r"[a-z]+:", link):  # http(s), mailto: not ours to check
                continue
            assert (page.parent / link).exists(), f"{page.relative_to(ROOT)}: broken link {link}"
    text = "\n".join([README, *(_page(name) for name in MANUAL)])
    named = re.findall(r"(?<![\w/.-])((?:docs|examples|benchmarks|planner_core|lamde_mission|sim"
                       r"|tests)/[\w./*-]*[\w*])", text)
    assert len(named) > 20
    for rel in named:
        assert glob.glob(os.path.join(ROOT, rel)), f"the docs name {rel}, which does not exist"
