"""The manual (mkdocs.yml, docs/) builds with warnings as errors, and its generated reference is
complete: every subcommand of `lamde-mission` (nested ones too) with every option, every name of
`lamde_mission.__all__`, every row of the defaults table. Skipped without the `docs` extra."""

from __future__ import annotations

import argparse
import html
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import ROOT

pytest.importorskip("mkdocs")
pytest.importorskip("material")
pytest.importorskip("mkdocstrings")
pytest.importorskip("mkdocstrings_handlers.python")


def _sources_mtime() -> float:
    paths = [ROOT / "mkdocs.yml", *(ROOT / "docs").rglob("*.md"), ROOT / "docs" / "hooks.py"]
    return max(p.stat().st_mtime for p in paths)


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The site, built once by `mkdocs build --strict` into a scratch folder; or the one `make
    test` has just built strictly (LAMDE_DOCS_SITE), when it is newer than every source page."""
    prebuilt = os.environ.get("LAMDE_DOCS_SITE")
    if prebuilt and (Path(prebuilt) / "index.html").exists() and (
            (Path(prebuilt) / "index.html").stat().st_mtime >= _sources_mtime()):
        return Path(prebuilt)
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    r = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f",
                        str(ROOT / "mkdocs.yml"), "-d", str(out)], cwd=ROOT, env=env,
                       capture_output=True, text=True, timeout=600)  # fmt: skip
    assert r.returncode == 0, f"mkdocs build --strict failed:\n{r.stdout[-3000:]}{r.stderr[-5000:]}"
    assert "WARNING" not in r.stderr, r.stderr[-5000:]
    return out


def _text(page: Path) -> str:
    """The page's article as plain text (tags dropped, entities decoded, spaces collapsed)."""
    doc = page.read_text(encoding="utf-8")
    body = doc[doc.index("<article"):doc.index("</article>")]
    return re.sub(r"\s+", " ", html.unescape(re.sub(r"<[^>]+>", " ", body)))


def _commands(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()):
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _commands(sub, (*path, name))


def test_every_cli_subcommand_and_option_has_a_reference_entry(site: Path) -> None:
    from lamde_mission.cli import build_parser

    page = _text(site / "reference" / "cli" / "index.html")
    found = list(_commands(build_parser()))
    assert len(found) > 14, [p for p, _ in found]  # the top level, 13 commands, their subcommands
    for path, parser in found:
        name = " ".join(("lamde-mission", *path))
        assert f"usage: {name} " in page, f"the CLI reference lacks `{name}`"
        for action in parser._actions:
            for opt in action.option_strings:
                assert opt in page, f"the CLI reference lacks {name} {opt}"


def test_every_public_name_of_lamde_mission_has_an_api_entry(site: Path) -> None:
    import lamde_mission

    doc = (site / "reference" / "api" / "index.html").read_text(encoding="utf-8")
    text = _text(site / "reference" / "api" / "index.html")
    bare = re.sub(r"[\s`]", "", text)  # the docstring's `code` is markup on the page
    assert lamde_mission.__all__
    for name in lamde_mission.__all__:
        obj = getattr(lamde_mission, name)
        assert f'id="{obj.__module__}.{obj.__qualname__}"' in doc, name
        assert f"lamde_mission.{name}" in text, name
        summary = re.sub(r"[\s`]", "", (obj.__doc__ or "").strip().split("\n\n")[0])
        assert summary and summary in bare, f"lamde_mission.{name}: no docstring on the API page"


def test_defaults_page_has_every_row_of_the_table(site: Path) -> None:
    from planner_core import defaults

    text = _text(site / "reference" / "defaults" / "index.html")
    names = re.findall(r"^\| `([\w.]+)` \|", defaults.render_markdown(), re.M)
    assert len(names) > 30
    for name in names:
        assert f" {name} " in text, f"the defaults page lacks {name}"


def test_manual_pages_are_in_the_site(site: Path) -> None:
    """Every page of the nav was built, the README's links into docs/ included."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    for link in re.findall(r"\]\(docs/([^)#]+)\.md[^)]*\)", readme):
        built = site / link / "index.html" if not link.endswith("index") else site / "index.html"
        assert built.exists(), f"README links docs/{link}.md, which the site does not build"
