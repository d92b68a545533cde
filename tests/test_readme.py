"""The README's examples run, in order, on a fresh folder: every ```bash block of its
"A short tour" section and every ```python block, each failing the test on a non-zero exit.
The README stays short, its links resolve, and its set-up commands are what CI runs.

The tour runs exactly as written: its runs are small in the README itself (the 39-grasp
``tour`` preset, ``--scale small`` presets, two objects, tiny benchmark sets, two orders of
forests; docs/performance.md has its measured time), so nothing is substituted. Every grasp
example of the README names its shape: each ``grasp --shape S`` and ``identify --shape S``
line answers S (an AMBIGUOUS answer whose first name is S counts; UNKNOWN does not).
"""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
README = REPO / "README.md"
TOUR = "A short tour"
"""The README section whose bash blocks run in order."""
MAX_README_LINES = 200

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


SHAPE_LINE = re.compile(
    r"^tactile-bullet (grasp|identify|explore) (.*--shape (\S+).*?)\s*(#.*)?$", re.M
)


def shape_examples(text: str) -> list[tuple[str, str, str]]:
    """(command, its arguments, the shape it names) of every README line that grasps a named
    shape: ``grasp --shape S``, ``identify --shape S`` and ``explore --shape S``, in any bash
    block."""
    code = "\n".join(c for lang, c in re.findall(r"^```(\w+)\n(.*?)^```", text, re.S | re.M)
                     if lang == "bash")  # fmt: skip
    return [(m.group(1), m.group(2), m.group(3)) for m in SHAPE_LINE.finditer(code)]


def names_its_shape(doc: dict, shape: str) -> bool:
    """Whether a ``grasp``/``identify`` JSON answer names ``shape``: its answer is ``shape``,
    or AMBIGUOUS with ``shape`` first, and never UNKNOWN."""
    answer = doc.get("answer", doc)
    if answer.get("unknown"):
        return False
    ambiguous = answer.get("ambiguous")
    return answer.get("shape") == shape or bool(ambiguous and ambiguous[0] == shape)


def run_json(command: str, arguments: str, cwd: Path) -> dict:
    argv = [sys.executable, "-m", "tactile_bullet.cli", command, *shlex.split(arguments)]
    if "--json" not in argv:
        argv.append("--json")
    env = {**os.environ, "MPLBACKEND": "Agg"}
    proc = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"{command} {arguments}: {proc.stderr[-2000:]}"
    return json.loads(proc.stdout)


def test_the_readme_names_shapes_in_its_grasp_examples():
    examples = shape_examples(README.read_text())
    assert {c for c, _, _ in examples} == {"grasp", "identify", "explore"}
    assert len([1 for c, _, _ in examples if c == "grasp"]) >= 4


@pytest.mark.slow
def test_every_grasp_example_of_the_readme_names_its_shape(tmp_path):
    """The default identifier's answers to the README's ``grasp --shape`` lines, and the fused
    answer of its ``explore --shape`` line (the ``identify --model`` lines need the tour's
    model: test_readme_examples_run_in_order)."""
    wrong = []
    text = README.read_text()
    for command, arguments, shape in shape_examples(text):
        if command == "identify":
            continue
        doc = run_json(command, arguments, tmp_path)
        if declares_unknown(text, arguments):  # the README says so beside the line
            answer = doc.get("answer", {})
            ok = answer.get("unknown") is True and answer.get("shape") == shape
        else:
            ok = names_its_shape(doc, shape)
        if not ok:
            wrong.append(f"{command} {arguments}: {doc.get('answer')}")
    assert not wrong, wrong


def declares_unknown(text: str, arguments: str) -> bool:
    """Whether the README line of ``arguments`` says, in its comment, that the answer is
    UNKNOWN (a grasp unlike the default's training: then its best guess must be the shape)."""
    line = next(x for x in text.splitlines() if x.startswith("tactile-bullet") and arguments in x)
    return "UNKNOWN" in line.partition("#")[2]


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
    # CI's machines hold the CPU torch and reach no other index: the test command names none
    for step in ('pip install --quiet -e ".[test]" ./plugins/tactile-bullet-example',
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
    blocks = readme_blocks(README.read_text())
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
        if language == "python":  # its streaming loop prints "<answer> grasped: <shape>"
            streamed = [line.split(" grasped: ") for line in proc.stdout.splitlines()
                        if " grasped: " in line]  # fmt: skip
            assert len(streamed) == 5 and all(a == b for a, b in streamed), proc.stdout
    for command, arguments, shape in shape_examples(README.read_text()):
        if command == "identify":  # its model is the tour's: it exists now
            doc = run_json(command, arguments, tmp_path)
            assert names_its_shape(doc, shape), f"{command} {arguments}: {doc}"


@pytest.mark.slow
def test_the_readme_box_is_answered_unknown_for_its_contacts(tmp_path):
    """The README's mesh example grasps a box, an object of no family: its answer is UNKNOWN,
    because its contacts fit no solid of revolution, as the line's comment says."""
    from tactile_bullet.learn.doubt import NOT_REVOLUTION

    text = README.read_text()
    make = next(x for x in text.splitlines() if x.startswith("tactile-bullet make-objects"))
    grasp = next(x for x in text.splitlines() if x.startswith("tactile-bullet grasp --mesh"))
    assert "box" in make and "UNKNOWN" in grasp.partition("#")[2]
    argv = shlex.split(make.partition("#")[0])[1:]
    subprocess.run([sys.executable, "-m", "tactile_bullet.cli", *argv], cwd=tmp_path,
                   check=True, capture_output=True)  # fmt: skip
    doc = run_json("grasp", grasp.partition("#")[0].split("grasp", 1)[1], tmp_path)
    assert doc["answer"]["unknown"] is True and doc["answer"]["unknown_why"] == NOT_REVOLUTION
