"""The default identifier: what ``grasp``, ``identify``, ``identify --recording`` and
``Identifier`` answer with when no model is named.

It is the robustness matrix's winner (docs/robustness.md: the method whose worst column over
every hand and condition the project can test is the highest), trained on the matrix's own
training sets, with its doubt and its novelty calibrated, and shipped as package data by
``tools/make_default_model.py``: nothing is simulated on first use. The file's sha256 is kept
beside it; a file that does not match is refused (reinstall), never used.
"""

from __future__ import annotations

import hashlib
import json
from functools import cache
from importlib import resources
from typing import Any

from ..errors import UsageError

MODEL_FILE = "default_model.npz"
META_FILE = "default_model.json"
TRAINING_FILE = "default_training.npz"
"""The default's training grasps as features and labels (what ``adapt`` shifts to a hand)."""
DEFAULT_NAME = "default"
"""What ``--model`` may also say to ask for the default explicitly."""


def _data():
    return resources.files("tactile_bullet.data")


def default_meta() -> dict[str, Any]:
    """The shipped default's description: method, training, its matrix figures, sha256."""
    try:
        meta = json.loads((_data() / META_FILE).read_text())
    except (OSError, ValueError):
        raise UsageError(
            "the default model's description is missing or damaged; reinstall tactile-bullet "
            "or name a model with --model"
        ) from None
    if not isinstance(meta, dict) or not isinstance(meta.get("sha256"), str):
        raise UsageError("the default model's description is damaged; reinstall tactile-bullet")
    return meta


@cache
def default_model():
    """The default :class:`~tactile_bullet.learn.models.Model`, checked against its sha256
    (loaded once a process)."""
    from .models import load_model

    meta = default_meta()
    resource = _data() / MODEL_FILE
    try:
        blob = resource.read_bytes()
    except OSError:
        raise UsageError(
            "the default model is missing from this install; reinstall tactile-bullet or name "
            "a model with --model"
        ) from None
    if hashlib.sha256(blob).hexdigest() != meta["sha256"]:
        raise UsageError(
            "the default model is damaged (its sha256 differs from the one shipped beside it); "
            "reinstall tactile-bullet or name a model with --model"
        )
    with resources.as_file(resource) as path:
        return load_model(path)


def default_training_set():
    """(features, labels) the default was fitted on, checked against the sha256 shipped beside
    them; a UsageError where they are missing or damaged (reinstall)."""
    import numpy as np

    meta = default_meta()
    resource = _data() / TRAINING_FILE
    try:
        blob = resource.read_bytes()
    except OSError:
        raise UsageError("the default's training grasps are missing from this install; "
                         "reinstall tactile-bullet") from None  # fmt: skip
    if hashlib.sha256(blob).hexdigest() != meta.get("training_sha256"):
        raise UsageError("the default's training grasps are damaged (their sha256 differs "
                         "from the one shipped); reinstall tactile-bullet")  # fmt: skip
    with resources.as_file(resource) as path, np.load(path, allow_pickle=False) as data:
        x, y = np.asarray(data["features"], dtype=float), np.asarray(data["labels"]).astype(str)
    if x.ndim != 2 or y.shape != (len(x),) or not np.all(np.isfinite(x)):
        raise UsageError("the default's training grasps are damaged; reinstall tactile-bullet")
    return x, y


def resolve_model(path):
    """A model file's Model, or the default where ``path`` is None or ``"default"``."""
    if path is None or str(path) == DEFAULT_NAME:
        return default_model()
    from .models import load_model

    return load_model(path)
