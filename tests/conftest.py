"""Shared fixtures: a plugin registered for one test, and synthetic grasp records.

Setting ``sys._tactile_bullet_testing`` keeps installed plugins (entry points) out of the
registry while the suite runs, unless ``TACTILE_BULLET_PLUGINS`` names them; child processes
started by tests load them as a user's would.
"""

from __future__ import annotations

import sys

import pytest
from synthetic import make_records


def pytest_configure(config):
    sys._tactile_bullet_testing = True


@pytest.fixture
def register_test_plugin():
    """``register(plugin, name=None) -> name``: a plugin that lives for the current test."""
    from tactile_bullet import plugins

    names: list[str] = []

    def register(plugin, name: str | None = None) -> str:
        registered = plugins.register_plugin(plugin, name)
        names.append(registered)
        return registered

    yield register
    for name in reversed(names):
        plugins.unregister_plugin(name)


@pytest.fixture(scope="session")
def synthetic_split():
    """(train, test) synthetic records of the five thesis shapes: 12 and 6 per shape."""
    return make_records(per_shape=12, seed=1), make_records(per_shape=6, seed=2)


@pytest.fixture
def private_mesh_cache(tmp_path_factory, monkeypatch):
    """An empty mesh cache of the test's own and no in-memory copies, before and after (the
    mesh tests use it for every test: ``pytestmark = usefixtures(...)``)."""
    from tactile_bullet.objects import meshes

    monkeypatch.setenv(meshes.CACHE_ENV, str(tmp_path_factory.mktemp("cache")))
    meshes.forget_loaded()
    yield
    meshes.forget_loaded()
