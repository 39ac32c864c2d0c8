"""The reference pages read in the repository as on the site: docs/reference/cli.md and
docs/reference/defaults.md hold, between their markers, what docs/hooks.py generates from the
code (`python docs/hooks.py --update` rewrites them; the build fills them again, to the same
text). They used to hold only the markers, empty in the repository although the README links
them. Needs no `docs` extra (the site itself: tests/test_docs_site.py)."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

from tests.conftest import ROOT


def _load_hooks():
    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "docs" / "hooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


hooks = _load_hooks()
STALE = "stale: regenerate it with `python docs/hooks.py --update`"


def _part(text: str, name: str) -> str:
    m = re.search(rf"<!-- {name}:begin -->\n(.*?)<!-- {name}:end -->", text, re.S)
    assert m, f"lost its <!-- {name}:begin --> ... <!-- {name}:end --> markers"
    return m.group(1)


def test_the_committed_pages_are_the_ones_the_hook_fills() -> None:
    assert set(hooks.COMMITTED) == {"cli", "defaults"}
    for rel, name in zip(hooks.PAGES, hooks.COMMITTED, strict=True):
        assert f"<!-- {name}:begin -->" in (ROOT / rel).read_text(encoding="utf-8"), rel


def test_committed_defaults_table_is_the_generated_one() -> None:
    from planner_core import defaults

    text = (ROOT / "docs" / "reference" / "defaults.md").read_text(encoding="utf-8")
    assert _part(text, "defaults").strip() == defaults.render_markdown().strip(), \
        f"docs/reference/defaults.md's table is {STALE}"  # fmt: skip
    assert hooks.fill(text) == text  # the site's build leaves it as committed


def _sections(part: str) -> dict[str, str]:
    """The cli part's sections by command (`lamde-mission map from-geojson`), each its text."""
    pieces = re.split(r"^#{2,4} `(lamde-mission[^`]*)`$", part, flags=re.M)
    return dict(zip(pieces[1::2], pieces[2::2], strict=True))


def test_committed_cli_help_has_every_command_and_option() -> None:
    """Whatever the Python: a section per command, no other, each with its usage line and
    every option of its parser (the layout of `--help` differs slightly between Pythons)."""
    from lamde_mission.cli import build_parser

    part = _part((ROOT / "docs" / "reference" / "cli.md").read_text(encoding="utf-8"), "cli")
    sections = _sections(part)
    names = []
    for path, parser in hooks.iter_commands(build_parser()):
        name = " ".join(("lamde-mission", *path))
        names.append(name)
        assert name in sections, f"docs/reference/cli.md lacks `{name}`: {STALE}"
        assert f"usage: {name} " in sections[name], name
        for action in parser._actions:
            for opt in action.option_strings:
                assert re.search(rf"(?<![\w-]){re.escape(opt)}(?![\w-])", sections[name]), \
                    f"docs/reference/cli.md: `{name}` lacks {opt}: {STALE}"  # fmt: skip
    assert len(names) > 14
    assert list(sections) == names, f"docs/reference/cli.md's commands are {STALE}"


def test_committed_cli_help_is_the_generated_one() -> None:
    """Byte for byte on the Python the page names (its first generated line); the build
    leaves it as committed."""
    text = (ROOT / "docs" / "reference" / "cli.md").read_text(encoding="utf-8")
    m = re.search(r"as Python (\d+\.\d+)'s argparse", _part(text, "cli"))
    assert m, "docs/reference/cli.md does not say which Python's argparse wrote its --help"
    if m.group(1) != hooks.python_version():
        pytest.skip(f"docs/reference/cli.md holds Python {m.group(1)}'s --help layout")
    assert hooks.fill(text, ["cli"]) == text, f"docs/reference/cli.md is {STALE}"
    assert hooks.on_page_markdown(text) == text


def test_the_defaults_table_has_one_writer(tmp_path: Path) -> None:
    """`python docs/hooks.py --update README.md` wrote the README's defaults table with a blank
    line each side (2 lines over the README's budget) where `python -m planner_core.defaults
    README.md` writes none, so each undid the other. Both now go through
    `planner_core.defaults.with_table`, which keeps the page's own blank lines: either leaves
    the other's output as it is, on the README, the reference page and stale copies of both."""
    from planner_core import defaults

    for rel in ("README.md", "docs/reference/defaults.md"):
        text = (ROOT / rel).read_text(encoding="utf-8")
        assert defaults.with_table(text) == text and hooks.fill(text, ["defaults"]) == text, rel
    begin, end = defaults.README_MARKERS
    table = defaults.render_markdown()
    for stale, fresh in ((f"{begin}| old |\n{end}\n", f"{begin}{table}{end}\n"),
                         (f"{begin}\n| old |\n\n{end}\n", f"{begin}\n{table}\n{end}\n"),
                         (f"{begin}\n{end}\n", f"{begin}\n{table}\n{end}\n"),
                         (f"{begin}{end}\n", f"{begin}{table}{end}\n")):
        for first, second in ((defaults.update_readme, hooks.update),
                              (hooks.update, defaults.update_readme)):
            page = tmp_path / "page.md"
            page.write_text("intro\n" + stale, encoding="utf-8")
            assert first(str(page)) is True
            assert page.read_text(encoding="utf-8") == "intro\n" + fresh
            assert second(str(page)) is False, (first, stale)


def test_update_rewrites_only_the_committed_parts(tmp_path: Path, capsys) -> None:
    page = tmp_path / "ref.md"
    page.write_text("intro\n<!-- defaults:begin -->\nold\n<!-- defaults:end -->\n"
                    "<!-- api:begin -->\nmine\n<!-- api:end -->\n"
                    "<!-- other:begin -->\nmine too\n<!-- other:end -->\nrest\n",
                    encoding="utf-8")  # fmt: skip
    assert hooks.update(page) is True
    text = page.read_text(encoding="utf-8")
    assert text == ("intro\n<!-- defaults:begin -->\n" + hooks.defaults_markdown()
                    + "<!-- defaults:end -->\n<!-- api:begin -->\nmine\n<!-- api:end -->\n"
                    "<!-- other:begin -->\nmine too\n<!-- other:end -->\nrest\n")  # fmt: skip
    assert hooks.update(page) is False
    assert [p.name for p in tmp_path.iterdir()] == ["ref.md"]  # no temporary file left
    assert hooks.main(["--update", str(page)]) == 0
    assert capsys.readouterr().out == f"{page}: up to date\n"
    bare = tmp_path / "bare.md"
    bare.write_text("<!-- api:begin -->\n<!-- api:end -->\n", encoding="utf-8")
    with pytest.raises(ValueError, match="no <!-- NAME:begin -->"):
        hooks.update(bare)
    assert hooks.main(["--update", str(bare)]) == 2
    assert "bare.md: no <!-- NAME:begin -->" in capsys.readouterr().err
    with pytest.raises(SystemExit) as info:
        hooks.main([])
    assert info.value.code == 2
