"""`tactile-bullet sequential`: the chapter-4 experiment from the CLI."""

from __future__ import annotations

import pytest

from tactile_bullet.cli import main

pytest.importorskip("torch")


def test_timing_runs_on_synthetic_classes(capsys):
    args = ["--classes", "3", "--per-class", "40", "--n-updates", "40", "--recalibration", "10"]
    code = main(["sequential", "--synthetic", "--timing", "--latency-samples", "5", *args])
    assert code == 0
    out = capsys.readouterr().out
    assert "offline" in out and "sequential" in out


def test_experiment_writes_its_three_figures(tmp_path):
    code = main(["sequential", "--synthetic", "--classes", "3", "--per-class", "40",
                 "--orders", "2", "--n-updates", "40", "--recalibration", "10",
                 "--out", str(tmp_path)])  # fmt: skip
    assert code == 0
    names = {p.name for p in tmp_path.iterdir()}
    assert {"accuracy_vs_objects.png", "updates_per_tree.png", "disturbance_matrix.png"} <= names


def test_without_data_it_says_what_to_give(capsys):
    assert main(["sequential"]) == 2
    assert "--data DIR" in capsys.readouterr().err


def test_a_malformed_descriptor_parameter_is_refused_before_any_work(tmp_path, capsys):
    code = main(["sequential", "--data", str(tmp_path), "--descriptor-param", "points"])
    assert code == 2
    assert "--descriptor-param" in capsys.readouterr().err


@pytest.mark.parametrize("argv, why", [
    (["--synthetic", "--descriptor", "signature"], "--descriptor and --descriptor-param read"),
    (["--synthetic", "--descriptor-param", "points=20"], "not with --synthetic"),
    (["--data", "DATA", "--classes", "3"], "--classes sizes --synthetic data: not with --data"),
    (["--synthetic", "--timing", "--out", "FIGS"], "--out is the figures' folder: --timing"),
])  # fmt: skip
def test_a_flag_that_means_nothing_with_the_others_is_refused(argv, why, tmp_path, capsys):
    places = {"DATA": str(tmp_path), "FIGS": str(tmp_path / "figs")}
    argv = [places.get(a, a) for a in argv]
    assert main(["sequential", *argv]) == 2
    err = capsys.readouterr().err
    assert why in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "figs").exists()


def test_accuracy_error_bars_stay_within_0_and_1():
    import numpy as np

    from tactile_bullet.experiments.sequential import clipped_spread

    acc = np.array([[1.0, 0.9, 0.0], [1.0, 0.5, 0.2], [0.7, 0.7, 0.1]])
    mean, below, above = clipped_spread(acc)
    assert np.all(mean - below >= 0) and np.all(mean + above <= 1 + 1e-12)
    assert np.allclose(below[1], acc[:, 1].std())  # inside the scale: the plain std
    assert above[0] == 1.0 - mean[0] < acc[:, 0].std()  # near 1: cut at 1
