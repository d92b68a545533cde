"""The documentation site (mkdocs.yml, docs/): it builds with no warning, its generated
command-line reference covers the parser, its tutorial's commands parse, and every measured
figure lives on one page.

A broken link, a missing anchor, a page left out of the nav or a docstring reference that does
not resolve is a warning, and ``mkdocs build --strict`` turns any warning into a failure: the
build test is what keeps the site whole, run with the rest of the suite (``.ci/run``).
"""

from __future__ import annotations

import importlib.util
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
DOCS = REPO / "docs"

FIGURES_PAGE = "performance.md"
"""The measured-figures page: each figure with its command, date and commit."""
GENERATED = {"signature_invariance.md": "written by tools/invariance.py from its own run"}
"""Pages a tool writes from its own output: figures there are that tool's, never copied."""
BESIDE_COMMAND = {
    "robustness.md": "the matrix's table is its command's own output (table.md), with the "
    "targets and root causes measured from it",
}
"""Pages that still keep figures of their own beside the command that gives them, and why.
The list only shrinks: a page whose figures have moved must leave it."""

FIGURE = re.compile(r"(?<![\w.])\d+\.\d+ ?%|(?<![\w.])\d+\.\d+x\b")
"""A measured figure in prose: a percentage or a ratio with a decimal (98.3%, 4.8x). Round
numbers (targets such as 95%, limits) are not figures; decimals are what a measurement gives."""
QUOTED = re.compile(
    r"(?<![\w.])\d+\.\d+ ?%|(?<![\w.])\d+\.\d+x\b|(?<=\| )\d+\.\d(?= \|)|\b\d+\.\d / \d+\.\d\b"
)
"""A figure as pages quote one: :data:`FIGURE`, a table cell such as ``| 88.3 |``, or a pair
such as ``98.3 / 95.0`` (bullet->mujoco / mujoco->bullet)."""


def _hook():
    spec = importlib.util.spec_from_file_location("docs_hook_pages", DOCS / "_hooks" / "pages.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_site_builds_with_no_warning(tmp_path):
    """`mkdocs build --strict`: links, anchors, the nav and the API references all resolve."""
    path = os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])
    env = {**os.environ, "PYTHONPATH": path, "NO_MKDOCS_2_WARNING": "1"}
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=REPO, env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, output[-4000:]
    assert "WARNING" not in output, output[-4000:]
    for page in ("reference/cli", "reference/python", "howto/plugin", "changelog"):
        assert (tmp_path / "site" / page / "index.html").is_file(), page


def test_the_cli_reference_covers_every_command_and_option():
    """The page is walked from the parser the CLI builds, so a new command or option appears
    in it without anyone writing it down."""
    from tactile_bullet.cli import build_parser

    hook = _hook()
    page = hook.cli_reference()
    for name, (_, parser) in hook.subcommands(build_parser()).items():
        section = page.split(f"## `{name}`\n", 1)[1].split("\n## ", 1)[0]
        for action in parser._actions:
            for option in action.option_strings:
                if option not in ("-h", "--help"):
                    assert f"`{option}" in section or f", {option}" in section, (name, option)


def _commands(page: Path) -> list[str]:
    blocks = re.findall(r"^```bash\n(.*?)^```", page.read_text(encoding="utf-8"), re.S | re.M)
    return [line for block in blocks for line in block.splitlines()
            if line.startswith("tactile-bullet ")]  # fmt: skip


@pytest.mark.parametrize("page", ["tutorial.md", "howto/engine.md"])
def test_the_guides_commands_parse(page):
    """Every ``tactile-bullet`` line of the hand-written guides names real options."""
    from tactile_bullet.cli import build_parser, join_negative_values

    commands = _commands(DOCS / page)
    assert commands
    for command in commands:
        argv = shlex.split(command, comments=True)[1:]
        parser = build_parser()
        try:
            parser.parse_args(join_negative_values(argv))
        except SystemExit as exc:
            raise AssertionError(f"{page}: {command}") from exc


def _pages() -> dict[str, str]:
    pages = {p.relative_to(DOCS).as_posix(): p.read_text(encoding="utf-8")
             for p in DOCS.rglob("*.md")}  # fmt: skip
    pages["../README.md"] = (REPO / "README.md").read_text(encoding="utf-8")
    return pages


def test_measured_figures_live_on_one_page():
    """Outside the figures page, the generated pages and :data:`BESIDE_COMMAND`, no page
    holds a measured figure: it links to the page that does."""
    stray = {}
    for name, text in _pages().items():
        if name == FIGURES_PAGE or name in GENERATED or name in BESIDE_COMMAND:
            continue
        found = FIGURE.findall(text)
        if found:
            stray[name] = found[:5]
    assert not stray, f"figures outside {FIGURES_PAGE}: link to it instead: {stray}"
    for name in BESIDE_COMMAND:
        assert FIGURE.search((DOCS / name).read_text(encoding="utf-8")), f"{name}: unlist it"


def _quoted(text: str) -> set[tuple[str, str]]:
    """(what names it, the figure) for every figure quoted in ``text``: in a table row, the
    row's label, the training cell where there is one, and the column; in prose, the three
    words before it."""
    out = set()
    prose = []
    for line in text.splitlines():
        if not line.startswith("|"):
            prose.append(line)
            continue
        cells = [re.sub(r"[^a-z0-9+ -]", "", c.lower()).strip() for c in line.split("|")[1:]]
        for column, cell in enumerate(line.split("|")[1:]):
            for match in QUOTED.finditer(f"| {cell.strip()} |"):
                label = f"{cells[0]} / {cells[1] if len(cells) > 1 else ''} / {column}"
                out.add((label, match.group()))
    flowing = " ".join(prose)
    for match in QUOTED.finditer(flowing):
        before = re.sub(r"[^a-z0-9+ -]", "", flowing[max(0, match.start() - 40) : match.start()])
        out.add((" ".join(before.lower().split()[-3:]), match.group()))
    return out


def test_no_figure_is_in_two_pages():
    """The same figure after the same words on two pages (any page of the site, and the
    README) is a copy: one of them should link to the other. (A heuristic: it catches a
    sentence or a table row copied from one page to another, not a figure reworded around.)"""
    seen: dict[tuple[str, str], str] = {}
    copies = []
    for name, text in _pages().items():
        for key in _quoted(text):
            if key in seen and seen[key] != name:
                copies.append(f"{key[1]} after '{key[0]}' in {seen[key]} and {name}")
            seen.setdefault(key, name)
    assert not copies, copies


def test_every_figure_section_says_when_and_where_it_was_measured():
    """Each section of the figures page with figures carries its date and commit."""
    text = (DOCS / FIGURES_PAGE).read_text(encoding="utf-8")
    for section in re.split(r"^#{2,3} ", text, flags=re.M)[1:]:
        own = re.split(r"^#{2,4} ", section, flags=re.M)[0]
        if FIGURE.search(own) or "\n|" in own:
            title = own.splitlines()[0]
            assert re.search(r"\b20\d\d-\d\d-\d\d\b", own), f"{title}: no date"
            assert re.search(r"\bcommit [0-9a-f]{7,}\b", own), f"{title}: no commit"
