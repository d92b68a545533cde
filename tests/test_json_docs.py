"""docs/json.md against real output (issue 20 item 28): every field a command's table documents
is in a real run's ``--json`` document (unless the row says when it is absent), and every
field the document holds is documented, so scripts written from the page keep working."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from tactile_bullet.cli import main

DOC = Path(__file__).resolve().parent.parent / "docs" / "json.md"
CONDITIONAL = ("present only", "present when", "with `--", "datasets only", "absent where")
"""Words of a row whose field is not always there."""


def documented(command: str) -> tuple[set[str], set[str]]:
    """(always-present fields, conditional fields) of ``command``'s first table in json.md."""
    text = DOC.read_text(encoding="utf-8")
    parts = re.split(r"^## ", text, flags=re.M)
    section = next(p for p in parts if p.startswith(f"`{command} --json`"))
    table = section.split("| field | meaning |", 1)[1].split("\n\n", 1)[0]
    always, conditional = set(), set()
    for row in table.strip().splitlines()[1:]:
        cells = row.strip("|").split("|")
        names = {n for n in re.findall(r"`([^`]+)`", cells[0]) if "." not in n}
        (conditional if any(w in cells[1] for w in CONDITIONAL) else always).update(names)
    return always, conditional


def check(command: str, doc) -> None:
    entries = doc if isinstance(doc, list) else [doc]
    assert entries, f"{command}: an empty document proves nothing"
    always, conditional = documented(command)
    for entry in entries:
        missing = always - set(entry)
        assert not missing, f"{command} --json lacks documented {sorted(missing)}"
        extra = set(entry) - always - conditional
        assert not extra, f"{command} --json holds undocumented {sorted(extra)}"


def run_json(capsys, argv):
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.fixture(scope="module")
def runs(tmp_path_factory, synthetic_split):
    """Datasets for the commands that read one (synthetic grasps: no simulation needed)."""
    from tactile_bullet.realhand.recordings import write_dataset

    root = tmp_path_factory.mktemp("jsondocs")
    write_dataset(synthetic_split[0][:40], root / "train", {"test": True})
    write_dataset(synthetic_split[1][:15], root / "test", {"test": True})
    return root


COMMANDS = {
    "shapes": lambda r: ["shapes"],
    "plugins": lambda r: ["plugins"],
    "grasp": lambda r: ["grasp", "--shape", "cylinder"],
    "train": lambda r: ["train", "--data", str(r / "train"), "--out", str(r / "m.npz"),
                        "--force"],
    "evaluate": lambda r: ["evaluate", "--model", str(r / "m.npz"), "--data", str(r / "test")],
    "compare": lambda r: ["compare", "--data", str(r / "train"), "--test", str(r / "test"),
                          "--classifier", "svm", "--classifier", "dtw-template",
                          "--descriptor", "signature", "--descriptor", "raw-joints"],
    "identify": lambda r: ["identify", "--model", str(r / "m.npz"), "--shape", "sphere"],
    "generate": lambda r: ["generate", "--preset", "smoke", "--out", str(r / "ds"),
                           "--workers", "2"],
    "verify": lambda r: ["verify", "--data", str(r / "ds")],
}  # fmt: skip


@pytest.mark.parametrize("command", list(COMMANDS))
def test_documented_fields_match_a_real_run(runs, capsys, command):
    if command in ("evaluate", "identify") and not (runs / "m.npz").exists():
        run_json(capsys, COMMANDS["train"](runs))
    if command == "verify" and not (runs / "ds").exists():
        run_json(capsys, COMMANDS["generate"](runs))
    check(command, run_json(capsys, COMMANDS[command](runs)))


def test_demo_fields_match_a_real_run(tmp_path):
    """The smallest real demo (15 simulated grasps): the document the CLI prints."""
    from tactile_bullet.experiments.workflow import demo

    doc = demo(tmp_path / "demo", train_per_shape=2, test_per_shape=1, workers=2)
    check("demo", json.loads(json.dumps(doc, default=str)))
    assert set(doc["bins"]) == {"size", "position", "rotation"}
