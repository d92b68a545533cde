"""Large CSV recordings are parsed block by block: the same samples whatever the block size, bad
cells still named, and memory a small multiple of the file rather than 14x."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from tactile_bullet.errors import UsageError
from tactile_bullet.hand import JOINT_NAMES
from tactile_bullet.realhand import tables

NAMES = ["rh_" + n for n in JOINT_NAMES]


def _csv(path, rows: int, bad: tuple[int, str] | None = None):
    rng = np.random.default_rng(0)
    lines = [",".join(["time", *NAMES, *[n + "_effort" for n in NAMES], "grasp", "shape"])]
    for i in range(rows):
        cells = [f"{i / 100:.2f}", *(f"{v:.6f}" for v in rng.uniform(0, 0.5, 48)),
                 str(1 + i // 100), "1"]  # fmt: skip  (a label that looks like a number)
        if bad and bad[0] == i:
            cells[3] = bad[1]
        lines.append(",".join(cells))
    path.write_text("\n".join(lines) + "\n")
    return path


def test_block_size_does_not_change_the_samples(tmp_path, monkeypatch):
    path = _csv(tmp_path / "r.csv", 250)
    whole = tables.read_table(path)
    monkeypatch.setattr(tables, "CSV_BLOCK_ROWS", 7)
    blocks = tables.read_table(path)
    assert np.array_equal(whole.angles, blocks.angles)
    assert np.array_equal(whole.efforts, blocks.efforts)
    assert np.array_equal(whole.time, blocks.time)
    assert list(whole.row_groups) == list(blocks.row_groups)
    assert blocks.labels == ["1"] * 250  # label text kept as written, not "1.0"


def test_a_bad_cell_in_a_late_block_is_named(tmp_path, monkeypatch):
    monkeypatch.setattr(tables, "CSV_BLOCK_ROWS", 16)
    path = _csv(tmp_path / "r.csv", 100, bad=(90, "abc"))
    with pytest.raises(UsageError, match="holds 'abc', not a number"):
        tables.read_table(path)


def test_a_short_line_is_named_by_its_line_number(tmp_path, monkeypatch):
    monkeypatch.setattr(tables, "CSV_BLOCK_ROWS", 16)
    path = _csv(tmp_path / "r.csv", 60)
    lines = path.read_text().splitlines()
    lines[41] = lines[41].rsplit(",", 3)[0]
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(UsageError, match="line 42 has 48 fields, the header 51"):
        tables.read_table(path)


def test_peak_memory_is_a_small_multiple_of_the_file(tmp_path):
    path = _csv(tmp_path / "big.csv", 40_000)  # ~18 MB
    size = path.stat().st_size
    tracemalloc.start()
    try:
        samples = tables.read_table(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert samples.angles.shape == (40_000, len(JOINT_NAMES))
    # twice the file plus one block of cells (4,096 rows x 51 columns as str: ~13 MB);
    # whole-file lists of strings peaked at ~14x the file
    assert peak < 2 * size + 16e6
