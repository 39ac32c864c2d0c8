"""Redraw every benchmark figure in docs/ from the runs stored in the repository:
`python docs/make_figures.py` (from the repository root; `--out DIR` writes the same tree
under DIR instead). No benchmark is re-run.

The stored runs are gzip-compressed (`results.jsonl.gz`, `docs/policy/*.jsonl.gz`) and read as
such (`planner_core.bench._io`); an uncompressed `results.jsonl` beside them is read first.

- REPORTS: `lamde-mission report` over a stored benchmark folder (`results.jsonl`); the report
  and its figures (scores per task, convergence per task, best paths, I_max study) are
  rewritten. A folder that is not in the repository is skipped, and the script says so: the
  figures it made stay as they were drawn (see NOT_STORED).
- STUDIES: a report whose own runs are not stored but whose studies are (`report --imax DIR
  --ablations DIR` over slim copies kept in the repository, `benchmarks/store_runs.py`): the
  studies' figures are redrawn, and the script checks that the page's study sections are what
  the stored runs give.
- POLICY: the score figures of `benchmarks/validate_policy.py`'s runs (docs/policy/*.jsonl),
  one per start mode, over the seeds every (map, mode, configurator) completed.
- SCANS: the figure of a configuration scan (`validate_policy.py --configurators grid`), one
  panel per pipeline.

The figures themselves are `planner_core.bench.figures`; each one written here is then stored
as a 256-colour palette PNG (`compact_png`: a quarter of the bytes, the same picture to the eye),
so the figures the pages show stay small in the repository. `make figures` runs this script.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import shlex
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent

#: (benchmark folder, report it makes, reference column, extra `report` options)
REPORTS: list[tuple[str, str, str, list[str]]] = [
    ("docs/reduced/runs", "docs/reduced/protocol.md", "de-adaptive", []),
    ("docs/reduced/imax-runs", "docs/reduced/imax.md", "de-lamde", ["--no-limits"]),
    ("docs/reduced/ablation-runs", "docs/reduced/ablations.md", "",  # reference: meta.json's
     ["--no-limits", "--title", "REDUCED ablation run (2 tasks x 2 runs, K = 4, 1-epoch "
      "trainings), not the paper protocol"]),
    ("results-with-metabox", "docs/results.md", "de-lamde",
     ["--policy-checkpoint", "planner_core/learning/policy/checkpoints/lamde-v2",
      "--ablations", "docs/studies/ablations", "--imax", "docs/studies/imax"]),
]

#: why a report's runs are not in the repository (its figures keep the style they were drawn in)
NOT_STORED: dict[str, str] = {
    "results-with-metabox": "the 8,800 runs behind docs/results.md were not committed (42 MB); "
    "the commands at the top of docs/results.md re-run them, seed for seed (~35 min with "
    "--jobs 1 on this machine), and merge them with the committed MetaBox records "
    "(docs/metabox/results.jsonl.gz) into results-with-metabox; then the report command there "
    "redraws the page (keeping its "
    "hand-written 'what this shows' section); its ablation and I_max studies are stored "
    "(docs/studies/), and their figures are redrawn from them",
}

#: (runs file, figure stem, what the runs compare, command that made them)
POLICY: list[tuple[str, str, str, str]] = [
    ("docs/policy/validation.jsonl.gz", "docs/policy/validation",
     "lamde-v1 against the hand-made configurators on 4 unseen maps",
     "python benchmarks/validate_policy.py --maps validation --count 4 --runs 25"),
    ("docs/policy/suite-uniform.jsonl.gz", "docs/policy/suite",
     "lamde-v1 against the hand-made configurators on the 16 suite maps",
     "python benchmarks/validate_policy.py --maps suite --modes uniform "
     "--configurators lamde random adaptive --runs 25"),
    ("docs/policy/suite-uniform-planner.jsonl.gz", "docs/policy/suite_planner",
     "lamde-v1 against the hand-made configurators in plan's pipeline, 16 suite maps",
     "python benchmarks/validate_policy.py --maps suite --modes uniform --pipeline planner "
     "--configurators lamde random adaptive --runs 25"),
]

#: (runs file of a configuration scan, figure, what it shows, command that made it; one figure
#: with a panel per pipeline the file holds, against `random`)
SCANS: list[tuple[str, str, str, str]] = [
    ("docs/policy/scan-suite-uniform.jsonl.gz", "docs/policy/scan_suite_uniform.png",
     "How far any DE configuration gets from the untrained random one, 16 suite maps",
     "python benchmarks/validate_policy.py --maps suite --modes uniform --pipeline PIPELINE "
     "--configurators random adaptive lamde grid --reference random --runs 8"),
]


def compact_png(path: Path) -> Path:
    """Rewrite a PNG as a 256-colour palette image (no dithering: plots have few colours, so
    lines and text keep their edges); one already in palette mode is left as it is."""
    from PIL import Image

    with Image.open(path) as im:
        if im.mode == "P":
            return path
        im.load()
    rgb = im if im.mode in ("RGB", "RGBA") else im.convert("RGBA")
    q = rgb.quantize(256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
    q.save(path, format="PNG", optimize=True)
    return path


def compact_folder(folder: Path) -> None:
    """`compact_png` on every PNG of a report's figure folder."""
    for png in sorted(folder.glob("*.png")) if folder.is_dir() else []:
        compact_png(png)


def report_command(results: str, md: str, reference: str, extra: list[str]) -> str:
    """The `lamde-mission report` command line a report records (and that re-makes it); no
    --reference when `reference` is empty (the report's default: meta.json's, else its own)."""
    return shlex.join(["lamde-mission", "report", results, "-o", md,
                       *(["--reference", reference] if reference else []), *extra])


def _option(extra: list[str], flag: str) -> str | None:
    return extra[extra.index(flag) + 1] if flag in extra else None


def study_figures(md: str, reference: str, extra: list[str], out: Path) -> list[str]:
    """Redraw the study figures of report `md` (under `out`) from the stored study folders its
    options name (--imax, --ablations); return the problems found: a stored folder missing, or
    the page's study sections not what the stored runs give."""
    from planner_core.bench.report import study_sections

    folders = {k: _option(extra, f"--{k}") for k in ("imax", "ablations")}
    missing = [f for f in folders.values() if f and not stored(f)]
    if missing:
        return [f"{md}: stored study folder(s) {', '.join(missing)} not found"]
    if not any(folders.values()):
        return []
    lines = study_sections(out / md, (out / md).with_suffix(""), reference=reference, **folders)
    page = (ROOT / md).read_text(encoding="utf-8") if (ROOT / md).is_file() else ""
    if "\n".join(lines) not in page:
        return [f"{md}: its study sections are not what the stored runs give: re-run its "
                "report command (at its top)"]
    return []


def stored(folder: str | Path) -> bool:
    """Whether a benchmark folder holds its runs (`results.jsonl`, or compressed `.gz`)."""
    from planner_core.bench._io import stored_path

    return stored_path(Path(folder) / "results.jsonl").exists()


def complete_seeds(records: list[dict[str, Any]]) -> list[int]:
    """Seeds for which every (map, mode, configurator) present has a run (a validation cut
    short leaves its last seed partial; the tables in docs/policy.md leave it out too)."""
    cells = {(r["map"], r["mode"], r["configurator"]) for r in records}
    have: dict[int, set[tuple[str, str, str]]] = defaultdict(set)
    for r in records:
        have[int(r["seed"])].add((r["map"], r["mode"], r["configurator"]))
    return sorted(s for s, c in have.items() if c == cells)


def _validate_policy() -> Any:
    spec = importlib.util.spec_from_file_location(
        "validate_policy", ROOT / "benchmarks" / "validate_policy.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def policy_figures(runs_file: Path, stem: Path, what: str) -> list[Path]:
    """One score figure per start mode of a validate_policy.py runs file: `stem`_<mode>.png."""
    from planner_core.bench import figures as F
    from planner_core.bench._io import read_jsonl

    vp = _validate_policy()
    records = read_jsonl(runs_file)  # a .gz name: gzip-compressed
    seeds = set(complete_seeds(records))
    records = [r for r in records if int(r["seed"]) in seeds]
    confs = list(dict.fromkeys(r["configurator"] for r in records))
    out = []
    for mode in ("seeded", "uniform"):
        recs = [r for r in records if r["mode"] == mode]
        if not recs:
            continue
        maps = sorted({r["map"] for r in recs})
        grouped: dict[str, dict[str, list[tuple[float, bool]]]] = defaultdict(
            lambda: defaultdict(list))
        for r in recs:
            grouped[r["map"]][r["configurator"]].append((float(r["score"]), r["phi"] == 0))
        planner = any(r.get("pipeline") == "planner" for r in recs)
        protocol = (F.protocol_text(mode, vp.BUDGET, len(seeds), per="configurator and map")
                    + f" · DE population {vp.POPULATION}, "
                    + ("plan's pipeline: memetic step + polish" if planner else "no polish"))
        fig = F.scores_figure(maps, grouped, confs, what=what + ": final score of every run",
                              protocol=protocol, legend_title="configurator")
        out.append(F.save(fig, stem.parent / f"{stem.name}_{mode}.png"))
    return out


def scan_figures(runs_file: Path, out: Path, what: str) -> Path:
    """The figure of a configuration scan's runs file (one panel per pipeline, `SCANS`)."""
    from planner_core.bench import figures as F
    from planner_core.bench._io import read_jsonl

    vp = _validate_policy()
    records = read_jsonl(runs_file)  # a .gz name: gzip-compressed
    panels, runs = {}, set()
    for pipeline in ("de", "repair", "memetic", "planner"):
        recs = [r for r in records if r.get("pipeline", "de") == pipeline]
        if not recs:
            continue
        labels = list(dict.fromkeys(r["configurator"] for r in recs))
        recs = vp.complete_seeds(recs, labels)
        runs.add(len({r["seed"] for r in recs}))
        panels[pipeline] = vp.scan_rows(recs, labels, "random", "uniform")
    protocol = (F.protocol_text("uniform", vp.BUDGET, sorted(runs), per="configurator and map")
                + f" · DE population {vp.POPULATION}")
    return F.save(F.scan_figure(panels, "random", what, protocol), out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT,
                    help="root of the tree to write (default: this repository)")
    args = ap.parse_args(argv)
    out = args.out.resolve()
    os.chdir(ROOT)  # the stored results name their suite relative to the repository root
    from planner_core.bench.report import DEFAULT_REFERENCE, build_report

    problems: list[str] = []
    for results, md, reference, extra in REPORTS:
        if not stored(results):
            print(f"skipped {md}: {results}/results.jsonl is not in the repository: "
                  f"{NOT_STORED.get(results, 'run its benchmark first')}", file=sys.stderr)
            problems += study_figures(md, reference, extra, out)
            compact_folder((out / md).with_suffix(""))
            if "--imax" in extra or "--ablations" in extra:
                print(f"redrew the study figures of {md} from its stored study runs",
                      file=sys.stderr)
            continue
        policy = _option(extra, "--policy-checkpoint")
        if out != ROOT and (ROOT / md).is_file():  # the hand-written part travels with the page
            (out / md).parent.mkdir(parents=True, exist_ok=True)
            if not (out / md).exists():
                (out / md).write_text((ROOT / md).read_text(encoding="utf-8"), encoding="utf-8")
        title = {"title": _option(extra, "--title")} if "--title" in extra else {}
        build_report(results, out / md, reference=reference or DEFAULT_REFERENCE,
                     limits="--no-limits" not in extra, **title,
                     command=report_command(results, md, reference, extra),
                     policy_checkpoint=policy, imax=_option(extra, "--imax"),
                     ablations=_option(extra, "--ablations"))
        compact_folder((out / md).with_suffix(""))
        print(f"wrote {md} and its figures", file=sys.stderr)
    for runs, stem, what, _ in POLICY:
        for p in map(compact_png, policy_figures(Path(runs), out / stem, what)):
            print(f"wrote {p.relative_to(out).as_posix()}", file=sys.stderr)
    for runs, fig, what, _ in SCANS:
        p = compact_png(scan_figures(Path(runs), out / fig, what))
        print(f"wrote {p.relative_to(out).as_posix()}", file=sys.stderr)
    for msg in problems:
        print(f"error: {msg}", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
