"""Where things live, as tools/README.md and benchmarks/ promise: tools/ holds only the
maintainer scripts its README lists, every benchmark says how to run it and prints the command
and commit behind its figures, and a user's job is a command."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
TOOLS = REPO / "tools"
BENCHMARKS = REPO / "benchmarks"
SCRIPTS = sorted(p for p in BENCHMARKS.glob("*.py") if not p.name.startswith("_"))


def _catalogue():
    """``benchmarks``' FAST and NEEDS tables, read without importing the package."""
    tree = ast.parse((BENCHMARKS / "__init__.py").read_text())
    tables = {}
    for node in tree.body:
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            if node.target.id in ("FAST", "NEEDS"):
                tables[node.target.id] = set(ast.literal_eval(node.value))
    return tables["FAST"], tables["NEEDS"]


def test_tools_holds_only_the_maintainer_scripts_its_readme_lists():
    listed = set(re.findall(r"^\| `(\w+\.py)` \|", (TOOLS / "README.md").read_text(), re.M))
    assert {p.name for p in TOOLS.glob("*.py")} == listed
    for name in listed:  # each writes what the package ships: a model or package data
        text = (TOOLS / name).read_text()
        assert "urdf/shadow_hand" in text or "tactile_bullet/data/" in text, name


@pytest.mark.parametrize("path", SCRIPTS, ids=lambda p: p.stem)
def test_every_benchmark_says_how_to_run_it_and_prints_its_provenance(path):
    tree = ast.parse(path.read_text())
    doc = ast.get_docstring(tree) or ""
    assert f"python benchmarks/{path.name}" in doc, f"{path.name}: no usage line"
    imports = [n for n in tree.body if isinstance(n, ast.ImportFrom) and n.module == "_report"]
    assert imports and "provenance" in {a.name for a in imports[0].names}, path.name
    first_package_import = min(
        (n.lineno for n in tree.body
         if isinstance(n, ast.ImportFrom) and (n.module or "").startswith("tactile_bullet")),
        default=float("inf"),
    )  # fmt: skip
    assert imports[0].lineno < first_package_import, "import _report before the package"
    calls = [
        n for n in ast.walk(tree)
        if isinstance(n, ast.Call) and getattr(n.func, "id", None) == "provenance"
    ]  # fmt: skip
    assert calls, f"{path.name} never calls provenance()"


def test_every_benchmark_is_fast_or_says_what_it_needs():
    fast, needs = _catalogue()
    names = {p.stem for p in SCRIPTS}
    assert fast | needs == names and not fast & needs


def test_the_catalogue_lists_every_benchmark_with_its_usage():
    done = subprocess.run([sys.executable, "-m", "benchmarks", "--list"], cwd=REPO,
                          capture_output=True, text=True, check=True)  # fmt: skip
    for path in SCRIPTS:
        assert f"\n{path.stem} (" in f"\n{done.stdout}", path.stem
        assert f"usage: python benchmarks/{path.name}" in done.stdout, path.stem


def test_provenance_prints_the_command_and_the_commit():
    code = ("import sys; sys.argv = ['benchmarks/x.py', '--repeat', '2']; "
            "sys.path.insert(0, 'benchmarks'); import _report; _report.provenance()")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True,
                         check=True).stdout.splitlines()  # fmt: skip
    assert out[0] == "command: python benchmarks/x.py --repeat 2"
    assert out[1].startswith("commit: ") and out[2].startswith("date: ")
    # the engines' versions: a new MuJoCo or PyBullet release moves physics and speed
    assert out[3].startswith("versions: pybullet ") and ", mujoco " in out[3]


def test_converting_another_hand_is_a_command():
    from tactile_bullet.cli import build_parser

    assert "convert-hand" in build_parser().format_help()
