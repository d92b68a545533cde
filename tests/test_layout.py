"""The package's layout keeps the promises docs/api.md makes to a reader: folders by concept,
no import circle, a short root, modules small enough to read (or saying why they are not)."""

from __future__ import annotations

import ast
from pathlib import Path

import tactile_bullet

PACKAGE = Path(tactile_bullet.__file__).parent
MAX_ROOT_MODULES = 10
MAX_LINES = 600
REASON = "Longer than"  # a module over MAX_LINES starts its docstring's reason with this


def _modules() -> dict[str, Path]:
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """Package modules ``name`` imports, at its top or inside functions (both can close a loop
    at run time). Importing the package itself (``__version__``, ``hookimpl``) is left out: its
    ``__init__`` only re-exports names lazily."""
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            candidates = [target] + [f"{target}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            candidates = [a.name for a in node.names]
        else:
            continue
        found |= {c for c in candidates if c in modules and c not in (name, "tactile_bullet")}
    return found


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def test_no_module_imports_itself_round_a_loop():
    modules = _modules()
    graph = {name: _imports(name, path, modules) for name, path in modules.items()}
    assert _cycles(graph) == []


def test_the_root_holds_only_what_everything_shares():
    root = sorted(p.stem for p in PACKAGE.glob("*.py"))
    assert len(root) <= MAX_ROOT_MODULES, root
    folders = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").exists()}
    assert {"objects", "sim", "perception", "learn", "datasets", "realhand", "experiments",
            "cli"} <= folders  # fmt: skip


def test_long_modules_say_why_at_their_top():
    for path in PACKAGE.rglob("*.py"):
        text = path.read_text()
        if text.count("\n") > MAX_LINES:
            doc = ast.get_docstring(ast.parse(text)) or ""
            assert REASON in doc, f"{path.relative_to(PACKAGE)}: over {MAX_LINES} lines, no reason"


def test_the_public_names_import_from_the_package_root():
    from tactile_bullet import (  # noqa: F401
        Identifier,
        hookimpl,
        load_record,
        read_records,
        simulate_grasp,
        workflow,
    )

    assert callable(simulate_grasp) and hasattr(workflow, "train")
    assert set(tactile_bullet.__all__) <= set(dir(tactile_bullet))
