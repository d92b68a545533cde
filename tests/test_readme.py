"""The README's examples run, in order, on a fresh folder: every ```bash block of its
"A short tour" section and every ```python block, each failing the test on a non-zero exit.
The README stays short, its links resolve, and its set-up commands are what CI runs.

The tour's own dataset (the 39-grasp ``tour`` preset) and held-out set (20 grasps) run as
written; the README still quotes other long runs (a 280-grasp sequential set, ten orders of
forests, the randomized and temporal presets); :data:`SUBSTITUTIONS` swaps each for a small
stand-in, and nothing else is changed. Every substitution must still apply, so a README edit
that moves a heavy command out of the table's reach fails here rather than silently running
for an hour. Blocks added later (new commands) join the test without touching it.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
README = REPO / "README.md"
TOUR = "A short tour"
"""The README section whose bash blocks run in order."""
MAX_README_LINES = 200

SUBSTITUTIONS: tuple[tuple[str, str, str], ...] = (
    ("--preset sequential", "--config small-sequential.toml", "280 grasps -> 9 (3 classes)"),
    ("--preset temporal", "--preset smoke", "198 grasps with fingers off the object -> 4"),
    (
        "make-objects --out objects",
        "make-objects --only bottle,pear --out objects",
        "14 objects (252 + 84 grasps) -> 2 (36 + 12)",
    ),
    (
        "tactile-bullet benchmark --quick",
        "tactile-bullet benchmark --scale tiny --protocol in-distribution,sensor-noise "
        "--descriptor signature,robust-joints --classifier svm",
        "five protocols x every installed method on 200 grasps -> two, on the tiny sets",
    ),
    (
        "--classifier svm,som,neural-forest",
        "--classifier svm,som",
        "three neural-forest fits in compare; the sequential example still trains forests",
    ),
    ("--preset randomized", "--config small-randomized.toml", "1,143 grasps -> 6 (2 shapes)"),
    (
        "tactile-bullet sequential ",
        "tactile-bullet sequential --orders 1 --n-updates 20 --recalibration 5 ",
        "10 orders x 300 updates per forest -> 1 x 20",
    ),
)
"""(text in the README, what the test runs instead, why)."""

SMALL_SEQUENTIAL = """\
name = "small-sequential"
mode = "random"
samples = 3
[[shapes]]
name = "sphere"
[[shapes]]
name = "cylinder"
[[shapes]]
name = "cylinder"
rotation_deg = [90]
"""
"""The stand-in for ``--preset sequential``: three of chapter 4's classes (one turned 90 deg),
three grasps each, the fewest the experiment's train/test split accepts."""

SMALL_RANDOMIZED = """\
name = "small-randomized"
mode = "random"
samples = 3
[[shapes]]
name = "sphere"
[[shapes]]
name = "cylinder"
[randomize]
friction = { min = 0.5, max = 1.2 }
coupling = ["j2-first", "equal-torque", "distal-first"]
"""
"""The stand-in for ``--preset randomized``: two shapes, three grasps each, the hand's friction
and tendon rule drawn per grasp (what ``train --training randomized`` checks for)."""

BASH_PRELUDE = """\
set -euo pipefail
tactile-bullet() { "$TB_PYTHON" -m tactile_bullet.cli "$@"; }
"""
"""Each bash block runs under ``set -e`` (any failing line fails it) with ``tactile-bullet``
bound to this interpreter, installed console script or not."""


def readme_blocks(text: str) -> list[tuple[str, str]]:
    """(language, code) of the blocks to run, in README order: ``bash`` blocks inside the
    :data:`TOUR` section, ``python`` blocks anywhere."""
    blocks = []
    section = ""
    fence = re.compile(r"^```(\w+)\n(.*?)^```", re.S | re.M)
    heading = re.compile(r"^## (.+)$", re.M)
    marks = [(m.start(), "h", m.group(1)) for m in heading.finditer(text)]
    marks += [(m.start(), "b", m) for m in fence.finditer(text)]
    for _, kind, value in sorted(marks, key=lambda x: x[0]):
        if kind == "h":
            section = value.strip()
            continue
        language, code = value.group(1), value.group(2)
        if (language == "bash" and section == TOUR) or language == "python":
            blocks.append((language, code))
    return blocks


def substituted(blocks: list[tuple[str, str]]) -> list[tuple[str, str]]:
    used = {old: 0 for old, _, _ in SUBSTITUTIONS}
    out = []
    for language, code in blocks:
        for old, new, _ in SUBSTITUTIONS:
            used[old] += code.count(old)
            code = code.replace(old, new)
        out.append((language, code))
    stale = [old for old, n in used.items() if n == 0]
    assert not stale, f"README no longer has {stale}: update SUBSTITUTIONS"
    return out


def test_the_readme_is_parsed_into_blocks():
    blocks = readme_blocks(README.read_text())
    languages = [language for language, _ in blocks]
    assert "bash" in languages and "python" in languages
    assert all("pip install" not in code for _, code in blocks)  # "Try it" stays out


def test_the_readme_is_short_and_its_links_resolve():
    text = README.read_text()
    assert len(text.splitlines()) <= MAX_README_LINES
    broken = []
    for page in [README]:  # docs/: the site's strict build checks them (test_docs_site.py)
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", page.read_text()):
            if "://" in target:
                continue
            if not (page.parent / target).exists():
                broken.append(f"{page.relative_to(REPO)}: {target}")
    assert not broken, broken


def test_the_two_set_up_commands_are_what_ci_runs():
    """ "Try it" holds exactly two commands: one ends in the demo, the other is .ci/run's."""
    try_it = re.search(r"^## Try it\n(.*?)^## ", README.read_text(), re.S | re.M).group(1)
    commands = re.findall(r"^```bash\n(.*?)\n```", try_it, re.S | re.M)
    assert len(commands) == 2
    demo, tests = commands
    assert demo.rstrip().endswith("tactile-bullet demo --out demo-report")
    ci = (REPO / ".ci" / "run").read_text()
    cpu = "--extra-index-url https://download.pytorch.org/whl/cpu"
    for step in ('pip install --quiet -e ".[test]" ./plugins/tactile-bullet-example ' + cpu,
                 "python -m pytest -q"):  # fmt: skip
        assert step.replace(" --quiet", "") in tests and step in ci
    for extra in ("torch", "ros"):  # what the tour needs: the neural forest, bags
        assert extra in re.search(r'-e "\.\[([a-z,]+)\]"', demo).group(1).split(",")
    # the copy-paste line itself installs the CPU torch (no multi-GB CUDA build on Linux) and
    # the example plugin the README's random-forest recipes need
    assert cpu in demo and "./plugins/tactile-bullet-example" in demo


def test_licence_and_citation_agree_with_the_package():
    import tactile_bullet

    assert (REPO / "LICENSE").read_text().startswith("MIT License")
    assert "license = MIT" in (REPO / "setup.cfg").read_text()
    cff = (REPO / "CITATION.cff").read_text()
    assert f'version: "{tactile_bullet.__version__}"' in cff
    assert "In-hand robotic tactile object recognition" in cff


@pytest.mark.slow
def test_readme_examples_run_in_order(tmp_path):
    blocks = substituted(readme_blocks(README.read_text()))
    (tmp_path / "small-sequential.toml").write_text(SMALL_SEQUENTIAL)
    (tmp_path / "small-randomized.toml").write_text(SMALL_RANDOMIZED)
    env = {**os.environ, "TB_PYTHON": sys.executable, "MPLBACKEND": "Agg"}
    env.pop("TACTILE_BULLET_PLUGINS", None)
    for number, (language, code) in enumerate(blocks):
        if language == "bash":
            cmd = ["bash", "-c", BASH_PRELUDE + code]
        else:
            script = tmp_path / f"readme_block_{number}.py"
            script.write_text(code)
            cmd = [sys.executable, str(script)]
        proc = subprocess.run(
            cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600
        )
        assert proc.returncode == 0, (
            f"README block {number} ({language}) exited {proc.returncode}:\n{code}\n"
            f"--- stderr ---\n{proc.stderr[-3000:]}"
        )
