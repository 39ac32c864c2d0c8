"""Every public function and method of the three packages has its docstring's `Args:` section
(when it takes arguments besides self/cls) and `Returns:` or `Yields:` (when it returns a
value): the guide's rule for public docstrings, checked on the source (ast), so a new function
without them fails here."""

from __future__ import annotations

import ast
from pathlib import Path

from tests.conftest import ROOT

PACKAGES = ("planner_core", "sim", "lamde_mission")


def _missing(path: Path, root: Path = ROOT) -> list[str]:
    """`path`'s public functions (and methods of its public classes) lacking a section."""
    out: list[str] = []

    def visit(node: ast.AST, owner: str) -> None:
        for n in ast.iter_child_nodes(node):
            if isinstance(n, ast.ClassDef) and not n.name.startswith("_"):
                visit(n, f"{owner}{n.name}.")
            elif isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) \
                    and not n.name.startswith("_"):
                doc = ast.get_docstring(n) or ""
                args = [a.arg for a in (*n.args.posonlyargs, *n.args.args, *n.args.kwonlyargs)
                        if a.arg not in ("self", "cls")]
                returns = any(isinstance(x, ast.Return) and x.value is not None
                              for x in ast.walk(n))
                lack = [s for s, need in (("Args", bool(args)), ("Returns", returns))
                        if need and f"{s}:" not in doc
                        and not (s == "Returns" and "Yields:" in doc)]
                if lack:
                    out.append(f"{path.relative_to(root)}:{n.lineno} {owner}{n.name}: "
                               f"no {' / '.join(lack)}")

    visit(ast.parse(path.read_text(encoding="utf-8")), "")
    return out


def test_public_functions_have_args_and_returns_sections() -> None:
    files = [p for pkg in PACKAGES for p in sorted((ROOT / pkg).rglob("*.py"))
             if "checkpoints" not in p.parts]
    assert len(files) > 100
    missing = [m for p in files for m in _missing(p)]
    assert not missing, "\n".join(missing)


def test_the_check_finds_a_function_without_sections(tmp_path) -> None:
    probe = tmp_path / "probe.py"
    probe.write_text('def f(x):\n    """Prose only."""\n    return x\n\n\n'
                     'def g(x):\n    """Summary.\n\n    Args:\n        x: a.\n\n'
                     '    Returns:\n        x.\n    """\n    return x\n\n\n'
                     'class C:\n    def h(self):\n        return 1\n', encoding="utf-8")
    assert _missing(probe, tmp_path) == ["probe.py:1 f: no Args / Returns",
                                         "probe.py:19 C.h: no Returns"]
