"""The plugin registry: every hook, duplicates, broken plugins, allow/block lists, the CLI."""

from __future__ import annotations

import dataclasses
import importlib.metadata
import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from tactile_bullet import hookspecs, plugins
from tactile_bullet.cli import main
from tactile_bullet.errors import UsageError
from tactile_bullet.hookspecs import hookimpl

HOOKS = [name for name in dir(hookspecs) if name.startswith("register_")]


def test_every_hook_has_a_test_of_its_own():
    assert HOOKS == sorted(plugins.KINDS.values())
    for hook in HOOKS:
        assert f"test_hook_{hook}" in globals(), f"hook {hook} has no test"


class ClosureDescriptor:
    """Total flexion of each long finger: a descriptor as small as a plugin's can be."""

    name = "test-closure"

    def __init__(self, scale: float = 1.0):
        self.scale = scale

    @property
    def params(self):
        return {"scale": self.scale}

    def feature_names(self):
        return ["ff", "mf", "rf", "lf"]

    def transform(self, records):
        return np.array([self.scale * r.fci_angles().sum(axis=0) for r in records])


def test_hook_register_descriptors(register_test_plugin, synthetic_split):
    class Plugin:
        @hookimpl
        def register_descriptors(self, register):
            register("test-closure", ClosureDescriptor)

    name = register_test_plugin(Plugin(), "test-descriptor-plugin")
    assert "test-closure" in plugins.descriptor_names()
    desc = plugins.get_descriptor("test-closure", scale=2.0)
    records = synthetic_split[1][:3]
    expected = 2.0 * np.array([r.fci_angles().sum(axis=0) for r in records])
    np.testing.assert_allclose(desc.transform(records), expected)
    combined = plugins.get_descriptor("raw-joints+test-closure")
    assert combined.transform(records).shape == (3, 17 + 4)
    entry = next(p for p in plugins.plugin_report() if p["name"] == name)
    assert entry["descriptors"] == ["test-closure"]
    assert plugins.plugin_of("descriptors", "test-closure") == name


@pytest.mark.filterwarnings("ignore:self.within_class_std_dev_")
def test_hook_register_classifiers(register_test_plugin, synthetic_split):
    from sklearn.neighbors import NearestCentroid

    class Plugin:
        @hookimpl
        def register_classifiers(self, register):
            register("test-centroid", NearestCentroid)

    name = register_test_plugin(Plugin(), "test-classifier-plugin")
    entry = next(p for p in plugins.plugin_report() if p["name"] == name)
    assert entry["classifiers"] == ["test-centroid"] and "error" not in entry
    est = plugins.get_classifier("test-centroid", metric="manhattan")
    assert isinstance(est, NearestCentroid) and est.metric == "manhattan"
    train, test = synthetic_split
    desc = plugins.get_descriptor("contact-normals")
    est.fit(desc.transform(train), [r.shape for r in train])
    accuracy = np.mean(est.predict(desc.transform(test)) == [r.shape for r in test])
    assert accuracy > 0.5


def test_hook_register_shapes(register_test_plugin, capsys):
    base = plugins.get_shape("cylinder")
    short = dataclasses.replace(base, name="test-short-cylinder", thesis=False)

    class Plugin:
        @hookimpl
        def register_shapes(self, register):
            register("test-short-cylinder", short)

    register_test_plugin(Plugin(), "test-shape-plugin")
    assert plugins.get_shape("test-short-cylinder") is short
    assert "test-short-cylinder" in plugins.shape_names()
    assert main(["shapes", "--json"]) == 0
    listed = [s["name"] for s in json.loads(capsys.readouterr().out)]
    assert "test-short-cylinder" in listed


def test_hook_register_engines(register_test_plugin, capsys, tmp_path):
    """A third-party engine drives Algorithm 1 through the Engine interface: here one that
    wraps the bullet engine and counts the controller's ticks."""
    from tactile_bullet.records import (
        ControllerSettings,
        controller_dict,
        load_record,
        save_record,
    )
    from tactile_bullet.sim.engines.bullet import BulletEngine
    from tactile_bullet.sim.grasp import simulate_grasp

    ticks = []

    class Counting(BulletEngine):
        name = "test-counting"

        def step(self):
            ticks.append(1)
            super().step()

    class Plugin:
        @hookimpl
        def register_engines(self, register):
            register("test-counting", lambda *a, **k: Counting(*a, **k))

    register_test_plugin(Plugin(), "test-engine-plugin")
    assert "test-counting" in plugins.engine_names()
    ctl = ControllerSettings(mode="contact", engine="test-counting")
    record = simulate_grasp("cylinder", controller=ctl)
    assert record.steps == len(ticks) > 0 and "lf" in record.fingers_in_contact
    assert record.metadata()["controller"]["engine"] == "test-counting"
    assert "engine" not in controller_dict(ControllerSettings())  # bullet: as before engines
    assert load_record(save_record(record, tmp_path / "r.npz")).controller.engine == "test-counting"
    assert main(["plugins", "--json"]) == 0
    listed = {p["name"]: p for p in json.loads(capsys.readouterr().out)}
    assert listed["test-engine-plugin"]["engines"] == ["test-counting"]
    assert listed["tactile_bullet.sim.engines.builtin"]["engines"] == ["bullet", "mujoco"]


def test_unknown_engine_is_a_usage_error_listing_the_registered_ones():
    from tactile_bullet.records import ControllerSettings
    from tactile_bullet.sim.grasp import simulate_grasp

    with pytest.raises(UsageError, match=r"unknown engine 'ode'.*bullet, mujoco"):
        simulate_grasp("cylinder", controller=ControllerSettings(engine="ode"))


def test_a_plugin_is_gone_once_unregistered(register_test_plugin):
    class Plugin:
        @hookimpl
        def register_descriptors(self, register):
            register("test-closure", ClosureDescriptor)

    name = register_test_plugin(Plugin(), "test-temporary")
    plugins.unregister_plugin(name)
    assert "test-closure" not in plugins.descriptor_names()
    assert name not in [p["name"] for p in plugins.plugin_report()]


def test_duplicate_name_is_refused_naming_both_plugins(register_test_plugin):
    class Plugin:
        @hookimpl
        def register_classifiers(self, register):
            register("test-first", lambda **p: None)
            register("svm", lambda **p: None)

    with pytest.raises(plugins.PluginError) as info:
        register_test_plugin(Plugin(), "test-clash")
    message = str(info.value)
    assert "'svm'" in message and "test-clash" in message
    assert "tactile_bullet.learn.classifiers.builtin" in message
    # all or nothing: the name registered before the clash is not kept
    assert "test-first" not in plugins.classifier_names()
    assert "test-clash" not in [p["name"] for p in plugins.plugin_report()]
    assert type(plugins.get_classifier("svm")).__name__ == "SVMClassifier"


def test_a_hook_that_raises_is_refused_and_the_rest_keeps_working(register_test_plugin):
    class Plugin:
        @hookimpl
        def register_shapes(self, register):
            raise RuntimeError("no trimesh today")

    with pytest.raises(plugins.PluginError, match="no trimesh today"):
        register_test_plugin(Plugin(), "test-raises")
    assert "cone" in plugins.shape_names()


def test_a_descriptor_must_carry_its_registered_name(register_test_plugin):
    class Plugin:
        @hookimpl
        def register_descriptors(self, register):
            register("test-alias", ClosureDescriptor)  # whose name is "test-closure"

    register_test_plugin(Plugin(), "test-alias-plugin")
    with pytest.raises(plugins.PluginError, match="calls itself 'test-closure'"):
        plugins.get_descriptor("test-alias")


def test_a_misspelt_hook_is_reported_not_ignored(register_test_plugin):
    class Plugin:
        @hookimpl
        def register_classifier(self, register):  # missing "s"
            register("never", lambda **p: None)

    with pytest.raises(plugins.PluginError, match="register_classifier"):
        register_test_plugin(Plugin(), "test-typo")


def test_a_taken_plugin_name_leaves_the_first_plugin_alone():
    with pytest.raises(plugins.PluginError, match="already registered"):
        plugins.register_plugin(object(), "tactile_bullet.learn.builtin")
    entry = next(p for p in plugins.plugin_report() if p["name"] == "tactile_bullet.learn.builtin")
    assert "signature" in entry["descriptors"] and "error" not in entry
    assert "signature" in plugins.descriptor_names()


def test_unknown_names_list_what_is_available():
    with pytest.raises(UsageError, match="svm") as info:
        plugins.get_classifier("no-such-classifier")
    assert "no-such-classifier" in str(info.value)
    with pytest.raises(UsageError, match="raw-joints"):
        plugins.get_descriptor("no-such-descriptor")
    with pytest.raises(UsageError, match="hyperboloid"):
        plugins.get_shape("no-such-shape")
    with pytest.raises(UsageError, match="no-such"):
        plugins.get_descriptor("signature+no-such")


def test_unknown_parameters_list_the_valid_ones():
    with pytest.raises(UsageError) as info:
        plugins.get_classifier("svm", gama=0.1)
    assert "'gama'" in str(info.value) and "gamma" in str(info.value)
    with pytest.raises(UsageError) as info:
        plugins.get_descriptor("signature", point=10)
    assert "'point'" in str(info.value) and "points" in str(info.value)
    assert plugins.get_classifier("svm", C=2.5).C == 2.5


@pytest.mark.parametrize(("name", "params", "why"), [
    ("svm", {"C": "abc"}, "The 'C' parameter of SVC must be a float"),
    ("svm", {"kernel": "rfb"}, "The 'kernel' parameter of SVC must be"),
    ("extra-trees", {"n_estimators": 0}, "n_estimators"),
])  # fmt: skip
def test_a_parameter_value_out_of_range_is_refused_when_the_classifier_is_made(name, params, why):
    # not inside the first fit, after the descriptors, under another function's name
    with pytest.raises(UsageError, match=f"classifier '{name}': .*{why}"):
        plugins.get_classifier(name, **params)


def test_combination_parameters_reach_the_right_part():
    desc = plugins.get_descriptor("signature+raw-joints", points=10, include_thumb=True)
    assert desc.params == {
        "signature.points": 10,
        "signature.alpha": False,
        "signature.level": False,
        "signature.floor": 0.05,
        "signature.correction": "none",
        "raw-joints.include_thumb": True,
    }
    again = plugins.get_descriptor(desc.name, **desc.params)
    assert again.feature_names() == desc.feature_names()
    with pytest.raises(UsageError, match="signature\\+signature"):
        plugins.get_descriptor("signature+signature")
    with pytest.raises(UsageError, match="bogus"):
        plugins.get_descriptor("signature+raw-joints", bogus=1)


def test_dtw_template_declares_the_descriptor_it_reads():
    assert plugins.required_descriptor("dtw-template") == "signature"
    assert plugins.compatible("signature", "dtw-template")
    assert not plugins.compatible("raw-joints", "dtw-template")
    assert plugins.compatible("raw-joints", "svm")


# --- installed plugins (entry points) --------------------------------------------------------

GOOD = """
from tactile_bullet.hookspecs import hookimpl
from sklearn.dummy import DummyClassifier

@hookimpl
def register_classifiers(register):
    register("ep-dummy", DummyClassifier)
"""

RAISES_IN_HOOK = """
from tactile_bullet.hookspecs import hookimpl

@hookimpl
def register_descriptors(register):
    raise RuntimeError("descriptor table missing")
"""


@pytest.fixture
def installed(monkeypatch, tmp_path):
    """Fake installed plugins: 'good', 'hook-fails' and 'import-fails' entry points."""
    (tmp_path / "tb_ep_good.py").write_text(GOOD)
    (tmp_path / "tb_ep_hook_fails.py").write_text(RAISES_IN_HOOK)
    monkeypatch.syspath_prepend(str(tmp_path))
    group = plugins.ENTRY_POINT_GROUP
    points = [
        importlib.metadata.EntryPoint("good", "tb_ep_good", group),
        importlib.metadata.EntryPoint("hook-fails", "tb_ep_hook_fails", group),
        importlib.metadata.EntryPoint("import-fails", "tb_ep_not_a_module_anywhere", group),
    ]
    monkeypatch.setattr(plugins, "_entry_points", lambda: points)
    monkeypatch.setattr(plugins, "_in_test_suite", lambda: False)
    monkeypatch.delenv(plugins.ALLOW_ENV, raising=False)
    monkeypatch.delenv(plugins.BLOCK_ENV, raising=False)
    yield
    monkeypatch.undo()
    plugins.reload_plugins()


def _report():
    return {p["name"]: p for p in plugins.plugin_report()}


def test_broken_installed_plugins_are_reported_and_skipped(installed, capsys):
    plugins.reload_plugins()
    report = _report()
    assert "ModuleNotFoundError" in report["import-fails"]["error"]
    assert "descriptor table missing" in report["hook-fails"]["error"]
    assert report["hook-fails"]["descriptors"] == []
    assert report["good"]["classifiers"] == ["ep-dummy"] and "error" not in report["good"]
    err = capsys.readouterr().err
    assert "'import-fails' skipped" in err and "'hook-fails' skipped" in err
    assert type(plugins.get_classifier("ep-dummy")).__name__ == "DummyClassifier"
    assert "signature" in plugins.descriptor_names() and "svm" in plugins.classifier_names()
    assert main(["plugins", "--json"]) == 0
    listed = {p["name"]: p for p in json.loads(capsys.readouterr().out)}
    assert "error" in listed["import-fails"] and listed["good"]["classifiers"] == ["ep-dummy"]


def test_allow_list_loads_only_the_named_plugins(installed, monkeypatch):
    monkeypatch.setenv(plugins.ALLOW_ENV, "good")
    plugins.reload_plugins()
    assert "good" in _report() and "import-fails" not in _report()
    monkeypatch.setenv(plugins.ALLOW_ENV, "")
    plugins.reload_plugins()
    assert all(p["builtin"] for p in plugins.plugin_report())
    assert "svm" in plugins.classifier_names()


def test_block_list_skips_the_named_plugins(installed, monkeypatch):
    monkeypatch.setenv(plugins.BLOCK_ENV, "good, import_fails")
    plugins.reload_plugins()
    assert set(_report()) & {"good", "import-fails"} == set()
    assert "hook-fails" in _report()
    with pytest.raises(UsageError):
        plugins.get_classifier("ep-dummy")


def test_the_test_suite_sees_only_built_in_plugins(installed, monkeypatch):
    monkeypatch.setattr(plugins, "_in_test_suite", lambda: True)
    plugins.reload_plugins()
    assert all(p["builtin"] for p in plugins.plugin_report())
    monkeypatch.setenv(plugins.ALLOW_ENV, "good")
    plugins.reload_plugins()
    assert "good" in _report()


def test_plugins_command_lists_the_built_in_plugins(capsys):
    assert main(["plugins", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    for entry in report:
        assert {"name", "version", "descriptors", "classifiers", "shapes"} <= set(entry)
    registered = {kind: sum((e[kind] for e in report), []) for kind in plugins.KINDS}
    assert {"signature", "raw-joints", "contact-normals"} <= set(registered["descriptors"])
    assert {"svm", "knn", "som", "dtw-template"} <= set(registered["classifiers"])
    assert {"cone", "torus", "sphere", "hyperboloid", "cylinder"} <= set(registered["shapes"])
    assert main(["plugins"]) == 0
    assert "dtw-template" in capsys.readouterr().out


def _example_installed() -> bool:
    try:
        importlib.metadata.distribution("tactile-bullet-example")
    except importlib.metadata.PackageNotFoundError:
        return False
    return True


@pytest.mark.skipif(
    not _example_installed(),
    reason="pip install ./plugins/tactile-bullet-example to run (CI does)",
)
def test_example_distribution_is_listed_and_selectable(tmp_path):
    cli = "import sys; from tactile_bullet.cli import main; sys.exit(main())"
    proc = subprocess.run(
        [sys.executable, "-c", cli, "plugins", "--json"], capture_output=True, text=True
    )
    assert proc.returncode == 0, proc.stderr
    report = {p["name"]: p for p in json.loads(proc.stdout)}
    example = report["tactile-bullet-example"]
    assert "error" not in example and not example["builtin"]
    assert "random-forest" in example["classifiers"]
    use = textwrap.dedent(
        """
        from tactile_bullet import plugins
        est = plugins.get_classifier("random-forest", n_estimators=7)
        print(type(est).__name__, est.n_estimators)
        """
    )
    proc = subprocess.run([sys.executable, "-c", use], capture_output=True, text=True)
    assert proc.stdout.split() == ["ExampleForest", "7"], proc.stderr


def test_a_fitted_form_that_cannot_be_imported_or_is_no_class_is_one_line(register_test_plugin):
    from tactile_bullet.errors import UsageError

    def missing():
        raise ImportError("No module named 'fancy_vote'")

    def factory(**params):
        from sklearn.neighbors import NearestCentroid

        return NearestCentroid(**params)

    def not_a_class():
        return 42

    class Plugin:
        @hookimpl
        def register_classifiers(self, register):
            register("test-missing-form", type("F", (), {"__call__": staticmethod(factory),
                                                          "fitted_form": staticmethod(missing)})())
            register("test-odd-form", type("G", (), {"__call__": staticmethod(factory),
                                                      "fitted_form": staticmethod(not_a_class)})())

    register_test_plugin(Plugin(), "test-fitted-form-plugin")
    with pytest.raises(UsageError, match="needs a package that is not installed: No module"):
        plugins.fitted_form("test-missing-form")
    with pytest.raises(UsageError, match="not a class with from_state"):
        plugins.fitted_form("test-odd-form")
    assert plugins.fitted_form("knn").__name__ == "NeighbourVote"
    assert plugins.fitted_form("svm").__name__ == "SVMVote"
    assert plugins.fitted_form("som") is None
