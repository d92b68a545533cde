"""A command-line grasp answers without scikit-learn (a saved knn or svm, the default among
them, predicts in numpy) and, for a built-in shape or a mesh processed before, without
trimesh: those imports were most of its time beyond the simulation (issue 30). The promise
is checked as what a fresh process imports, never as a time."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from tactile_bullet import plugins
from tactile_bullet.errors import UsageError
from tactile_bullet.learn.descriptors import raw_joint_names
from tactile_bullet.learn.models import load_model, save_model
from tactile_bullet.learn.neighbours import NeighbourVote
from tactile_bullet.objects.shapes import BUILTIN_SHAPES


def _fresh(code: str, env: dict | None = None) -> str:
    import os

    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**os.environ, **(env or {})}, timeout=300)  # fmt: skip
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_the_default_model_loads_and_answers_without_scikit_learn():
    out = _fresh(
        "import sys, numpy as np\n"
        "from tactile_bullet.learn.default import default_model\n"
        "m = default_model()\n"
        "p = m.estimator.predict_proba(np.zeros((1, m.estimator.n_features_in_)))\n"
        "print('sklearn' in sys.modules, round(p.sum(), 9))\n"
    )
    assert out.split() == ["False", "1.0"]


def test_a_saved_knn_loads_and_answers_without_scikit_learn(tmp_path):
    from tactile_bullet.learn.models import Model

    rng = np.random.default_rng(1)
    n = len(raw_joint_names(False))  # the raw-joints descriptor's width
    est = plugins.get_classifier("knn").fit(rng.normal(size=(30, n)), np.repeat(["a", "b"], 15))
    path = save_model(tmp_path / "m.npz", Model("raw-joints", {}, "knn", {}, est))
    out = _fresh(
        "import sys, numpy as np\n"
        "from tactile_bullet.learn.models import load_model\n"
        f"m = load_model({str(path)!r})\n"
        f"p = m.estimator.predict_proba(np.zeros((1, {n})))\n"
        "print(type(m.estimator).__name__, 'sklearn' in sys.modules, round(p.sum(), 9))\n"
    )
    assert out.split() == ["NeighbourVote", "False", "1.0"]


def test_a_loaded_knn_answers_exactly_as_the_fitted_one(tmp_path):
    rng = np.random.default_rng(3)
    x = rng.normal(size=(60, 7))
    y = np.repeat(["cone", "sphere", "torus"], 20)
    x[y == "sphere"] += 1.5
    for params in ({}, {"n_neighbors": 3, "weights": "uniform"}, {"n_neighbors": 100}):
        est = plugins.get_classifier("knn", **params).fit(x, y)
        vote = NeighbourVote.from_state(*est.to_state())
        queries = np.vstack([rng.normal(size=(25, 7)), x[:5]])  # x[:5]: exact matches
        assert np.array_equal(vote.predict_proba(queries), est.predict_proba(queries))
        assert np.array_equal(vote.predict(queries), est.predict(queries))


def test_a_knn_file_whose_parameters_disagree_with_its_state_is_refused(tmp_path):
    from tactile_bullet.learn.models import Model

    rng = np.random.default_rng(0)
    x, y = rng.normal(size=(20, len(raw_joint_names(False)))), np.repeat(["cone", "torus"], 10)
    est = plugins.get_classifier("knn", n_neighbors=3).fit(x, y)
    path = save_model(tmp_path / "m.npz", Model("raw-joints", {}, "knn", {"n_neighbors": 7}, est))
    with pytest.raises(UsageError, match="n_neighbors=7 does not match its saved state"):
        load_model(path)


def test_a_damaged_knn_state_is_one_line_error(tmp_path):
    rng = np.random.default_rng(0)
    est = plugins.get_classifier("knn").fit(rng.normal(size=(20, 4)), np.repeat(["a", "b"], 10))
    state, arrays = est.to_state()
    with pytest.raises(ValueError, match="non-numbers"):
        NeighbourVote.from_state(state, {**arrays, "mean": np.full(4, np.nan)})
    with pytest.raises(ValueError, match="labels do not match"):
        NeighbourVote.from_state(state, {**arrays, "y_index": arrays["y_index"] + 5})
    with pytest.raises(ValueError, match="n_neighbors"):
        NeighbourVote.from_state({**state, "params": {"n_neighbors": 0, "weights": "uniform"}},
                                 arrays)  # fmt: skip


@pytest.fixture
def cache_home(tmp_path, monkeypatch):
    monkeypatch.setenv("TACTILE_BULLET_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


BUILT = tuple(s.name for s in BUILTIN_SHAPES)


def _sizes(shape, draws: int = 4) -> list[dict[str, float]]:
    """Both ends of every range and draws inside them (valid sizes only: a hyperboloid's ends
    are wider than its waist)."""
    rng = np.random.default_rng(7)
    out = [{k: p.min for k, p in shape.params.items()}, {k: p.max for k, p in shape.params.items()}]
    while len(out) < 2 + draws:
        params = {k: float(rng.uniform(p.min, p.max)) for k, p in shape.params.items()}
        if shape.name != "hyperboloid" or params["end_radius"] > params["waist_radius"]:
            out.append(params)
    return out


@pytest.mark.parametrize("name", BUILT)
def test_a_built_in_piece_is_its_meshs_points_and_faces_to_the_bit(name):
    """The built-in pieces are built without trimesh; Bullet must get the very points,
    triangles and order the mesh-based build gave it, at both ends of every range and
    inside them."""
    from tactile_bullet.objects.shapes import COLLISION_SECTIONS

    shape = next(s for s in BUILTIN_SHAPES if s.name == name)
    for params in _sizes(shape):
        (piece,) = shape.pieces(**params)
        mesh = shape.mesh(**params, sections=COLLISION_SECTIONS)
        vertices = np.asarray(getattr(piece, "vertices", piece))
        assert vertices.dtype == np.float64
        assert np.array_equal(vertices, np.asarray(mesh.vertices)), params
        if name in ("torus", "hyperboloid"):
            assert np.array_equal(piece.faces, np.asarray(mesh.faces)), params
        else:
            assert not hasattr(piece, "faces")  # a convex hull: its points only


@pytest.mark.parametrize("shape, param", [("sphere", "radius"), ("torus", "minor_radius")])
def test_a_grasp_of_any_size_imports_neither_trimesh_nor_scikit_learn(shape, param, cache_home):
    """Those imports were most of a command-line grasp's time beyond its simulation: the
    pieces of a built-in shape are built from its profile, the default answers in numpy."""
    import os

    code = (
        "import atexit, runpy, sys\n"
        "atexit.register(lambda: sys.stderr.write('\\nIMPORTED %d %d\\n' % (\n"
        "    'trimesh' in sys.modules, 'sklearn' in sys.modules)))\n"
        f"sys.argv = ['tactile-bullet', 'grasp', '--shape', {shape!r}, '--param',\n"
        f"            '{param}=0.0461', '--json']\n"
        "runpy.run_module('tactile_bullet.cli', run_name='__main__')\n"
    )
    env = {**os.environ, "TACTILE_BULLET_CACHE": str(cache_home)}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, timeout=300)  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["answer"]["shape"] == shape
    assert done.stderr.rsplit("IMPORTED", 1)[1].split() == ["0", "0"]
    assert not (cache_home / "pieces").exists()  # no file per size


def test_a_grasp_of_a_mesh_processed_before_imports_no_trimesh(cache_home, tmp_path):
    """Processing a mesh file needs trimesh; grasping it again (its processed arrays read
    from the mesh cache) does not, and answers the same."""
    import os

    from tactile_bullet.objects.examples import write_object

    path = write_object("box", tmp_path)
    code = (
        "import atexit, runpy, sys\n"
        "atexit.register(lambda: sys.stderr.write('\\nIMPORTED %d\\n' % (\n"
        "    'trimesh' in sys.modules)))\n"
        f"sys.argv = ['tactile-bullet', 'grasp', '--mesh', {str(path)!r}, '--unit', 'mm',\n"
        "            '--json']\n"
        "runpy.run_module('tactile_bullet.cli', run_name='__main__')\n"
    )
    env = {**os.environ, "TACTILE_BULLET_CACHE": str(cache_home)}
    runs = []
    for _ in range(2):
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              env=env, timeout=300)  # fmt: skip
        assert done.returncode == 0, done.stderr
        answer = json.loads(done.stdout)
        runs.append((answer["joint_angles"], done.stderr.rsplit("IMPORTED", 1)[1].split()))
    assert runs[0][1] == ["1"]  # processed the file with trimesh
    assert runs[1][1] == ["0"]  # read the processed arrays back
    assert runs[0][0] == runs[1][0]


def test_a_shape_fit_model_saves_without_skops_and_refuses_a_damaged_state(tmp_path):
    from tactile_bullet.learn.classifiers.shape_fit import ShapeFitClassifier
    from tactile_bullet.learn.descriptors import raw_joint_names
    from tactile_bullet.learn.models import Model
    from tactile_bullet.learn.shape_fit_vote import ShapeFitVote

    n = len(raw_joint_names(False))
    est = plugins.get_classifier("shape-fit").fit(np.zeros((4, n)), ["cone", "torus"] * 2)
    path = save_model(tmp_path / "m.npz", Model("raw-joints", {}, "shape-fit", {}, est))
    with np.load(path) as data:
        assert "estimator_skops" not in data.files
    loaded = load_model(path).estimator
    assert type(loaded) is ShapeFitVote and list(loaded.classes_) == ["cone", "torus"]
    assert loaded.to_state()[0] == est.to_state()[0]  # it saves itself as it was loaded
    state, arrays = est.to_state()
    for bad_state, bad_arrays, message in [
        ({**state, "params": {"temperature": -1.0, "calibration": None}}, arrays, "temperature"),
        ({**state, "n_features_in": 5}, arrays, "columns"),
        (state, {"classes": np.array(["cone", "teapot"])}, "teapot"),
        (
            {**state, "params": {"temperature": 1.0, "calibration": {"gain": 2}}},
            arrays,
            "calibration",
        ),
    ]:
        for kind in (ShapeFitClassifier, ShapeFitVote):  # the estimator and its loaded form
            with pytest.raises(ValueError, match=message):
                kind.from_state(bad_state, bad_arrays)


def test_a_saved_shape_fit_model_answers_as_fitted_and_without_scikit_learn(tmp_path):
    from tactile_bullet.learn.descriptors import raw_joint_names
    from tactile_bullet.learn.models import Model
    from tactile_bullet.perception.shape_fit import predicted_angles

    names = raw_joint_names(False)
    rows = []
    for shape, params in [("sphere", {"radius": 0.05}), ("cylinder", {"radius": 0.03})]:
        j3, j0 = predicted_angles(shape, params)
        row = np.zeros(len(names))
        for k, f in enumerate(("FF", "MF", "RF", "LF")):
            row[names.index(f"{f}J3")], row[names.index(f"{f}J2")] = j3[k], j0[k] / 2
            row[names.index(f"{f}J1")] = j0[k] / 2
        rows.append(row)
    x = np.array(rows)
    est = plugins.get_classifier("shape-fit").fit(x, ["sphere", "cylinder"])
    path = save_model(tmp_path / "m.npz", Model("raw-joints", {}, "shape-fit", {}, est))
    np.testing.assert_array_equal(load_model(path).estimator.predict_proba(x),
                                  est.predict_proba(x))  # fmt: skip
    out = _fresh(
        "import sys, numpy as np\n"
        "from tactile_bullet.learn.models import load_model\n"
        f"m = load_model({str(path)!r})\n"
        f"print(*m.estimator.predict(np.array({x.tolist()!r})), type(m.estimator).__name__, "
        "'sklearn' in sys.modules)\n"
    )
    assert out.split() == ["sphere", "cylinder", "ShapeFitVote", "False"]
