"""Trained models: a descriptor and a fitted classifier, saved without pickle.

A model file is a ``.npz`` archive read with ``allow_pickle=False``: ``meta`` holds JSON (format,
versions, descriptor and classifier names and parameters, classes) and the estimator is stored
one of two ways:

- **state** (``estimator_state`` JSON + ``state.<name>`` arrays): for estimators that implement
  the :class:`StatefulEstimator` protocol (``to_state`` / ``from_state``). Loading builds a fresh
  estimator of the *registered* classifier named in the file and calls its class's
  ``from_state``: the file can only pick among installed classifiers, never name code.
- **skops** (``estimator_skops`` bytes): any other scikit-learn estimator, loaded by skops with an
  explicit trusted-type list (the registered classifier's own class, the sklearn internals in
  ``SKLEARN_DATA_TYPES``, and the names in the class's ``trusted_types`` attribute). A file
  holding any other type is refused.

A classifier's factory may name a ``fitted_form`` (``factory.fitted_form``, a callable returning
a class with ``from_state``): a state-encoded file of it then loads as that predict-only class,
sparing the estimator's own imports (a saved knn or svm predicts in numpy without
scikit-learn).

For plugin authors: a classifier whose state skops cannot represent (a torch module, a C
handle) implements ``to_state() -> (dict of JSON values, dict of numeric numpy arrays)`` and a
classmethod ``from_state(state, arrays) -> fitted estimator`` (``to_state`` may raise
NotImplementedError to be written through skops instead); one that skops can store but that
holds extra non-default types lists their qualified names in a class attribute
``trusted_types``.
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

from .. import __version__
from ..errors import UsageError
from ..files import atomic_path, json_value

MODEL_FORMAT = "tactile-bullet-model"
MODEL_FORMAT_VERSION = 1

SKLEARN_DATA_TYPES: frozenset[str] = frozenset(
    {
        "sklearn.tree._tree.Tree",
        "sklearn.neighbors._kd_tree.KDTree",
        "sklearn.neighbors._ball_tree.BallTree",
        "sklearn.calibration._CalibratedClassifier",
        "sklearn.calibration._SigmoidCalibration",
    }
)
"""scikit-learn internals that hold only fitted arrays (trees, neighbour indexes, calibration
maps) and that skops does not trust by default."""

_DIST_METRIC = re.compile(r"^sklearn\.metrics\._dist_metrics\.[A-Za-z]+(32|64)$")
"""Neighbour-index distance metrics (data-only Cython classes)."""

if TYPE_CHECKING:
    from .doubt import KnownGrasps

_STATE_PREFIX = "state."
_SECOND_PREFIX = "second."
"""The members of a second opinion's classifier state (``learn/second_opinion.py``)."""
_KNOWN_FEATURES, _KNOWN_LABELS = "known.features", "known.labels"
_NOVELTY_ARRAYS = ("centre", "scale", "reference")
_NOVELTY_PREFIX = "novelty."


@runtime_checkable
class StatefulEstimator(Protocol):
    """An estimator that saves itself as JSON plus numeric arrays (see module docstring)."""

    def to_state(self) -> tuple[dict, dict[str, np.ndarray]]: ...

    @classmethod
    def from_state(cls, state: dict, arrays: dict[str, np.ndarray]) -> Any: ...


@dataclass(eq=False)
class Model:
    """A descriptor (name + parameters) and the classifier fitted on its features.

    ``info`` holds free JSON the trainer wants kept (data set, scores); ``software_version``
    and ``format_version`` say what wrote the file.
    """

    descriptor: str
    descriptor_params: dict
    classifier: str
    classifier_params: dict
    estimator: Any
    info: dict = field(default_factory=dict)
    known: KnownGrasps | None = None
    """:class:`tactile_bullet.learn.doubt.KnownGrasps` of a model fitted with the user's known
    grasps (``train --known``): they second its answers. Saved as ``known.*`` arrays."""
    novelty: Any = None
    """:class:`tactile_bullet.learn.novelty.Novelty`: how far a grasp lies from the training
    grasps, and where that answers ``unknown`` (None in a model file written before it
    existed: no answer is unknown). Saved as ``novelty.*`` arrays."""
    axis: Any = None
    """:class:`tactile_bullet.perception.contact_check.ContactCheck`: thresholds on how far a
    grasp's contact normals miss every axis and its points the named family's surface, per
    engine and family, where that answers ``unknown`` (None where the training grasps had no
    contacts, or in a file written before it existed). Saved as ``axis_check`` in the
    metadata."""
    second: Any = None
    """:class:`tactile_bullet.learn.second_opinion.SecondOpinion`: a second classifier that
    seconds the answers in place of the shape fit (the shipped default's; None otherwise).
    Saved as ``second_opinion`` in the metadata and ``second.*`` arrays."""
    software_version: str = __version__
    format_version: int = MODEL_FORMAT_VERSION

    @property
    def classes(self) -> list[str]:
        """Class names in the column order of ``predict_proba_records``."""
        return [str(c) for c in self.estimator.classes_]

    def describe_descriptor(self):
        """The descriptor object that turns records into this model's features."""
        from ..plugins import get_descriptor

        return get_descriptor(self.descriptor, **self.descriptor_params)

    def features(self, records: Sequence) -> np.ndarray:
        return np.asarray(self.describe_descriptor().transform(records), dtype=float)

    def predict_records(self, records: Sequence) -> np.ndarray:
        """Predicted shape names, one per record: the classifier's, renamed where the grasp's
        contacts name another family (:meth:`contact_names`)."""
        names = np.asarray(self.estimator.predict(self.features(records))).astype(str)
        return renamed(names, self.contact_names(records, names))

    def contact_names(self, records: Sequence, names: Sequence[str]) -> list[str | None]:
        """For each of the classifier's answers, the family the grasp's contacts name instead
        (a torus read as a sphere:
        :meth:`~tactile_bullet.perception.contact_check.ContactCheck.contact_names`), or None;
        all None without a contact check."""
        if self.axis is None or not len(records):
            return [None] * len(records)
        return self.axis.contact_names(records, names)

    def predict_proba_records(self, records: Sequence) -> np.ndarray:
        """(n, n_classes) probabilities; columns follow ``classes``."""
        return np.asarray(self.estimator.predict_proba(self.features(records)), dtype=float)

    def predict_with_proba(
        self, records: Sequence, x: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Predicted names and probabilities (None where the estimator gives none) from one
        pass of the descriptor: the estimator's own decision is kept, since it can differ
        from the probability argmax (SVC with Platt scaling). ``x``: the records' features
        where the caller computed them already (the answer's doubt reads them too)."""
        names, proba, _ = self.answers(records, x)
        return names, proba

    def answers(
        self, records: Sequence, x: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray | None, list[str | None]]:
        """:meth:`predict_with_proba`'s names and probabilities, and for each answer the
        classifier's own name where the grasp's contacts renamed it (else None). The
        probabilities stay the classifier's: a renamed answer's margin is negative, so its
        doubt shows both names."""
        x = self.features(records) if x is None else np.asarray(x, dtype=float)
        names = np.asarray(self.estimator.predict(x)).astype(str)
        try:
            proba = np.asarray(self.estimator.predict_proba(x), dtype=float)
        except (AttributeError, NotImplementedError):
            proba = None
        instead = self.contact_names(records, names)
        was = [str(n) if other else None for n, other in zip(names, instead, strict=True)]
        return renamed(names, instead), proba, was

    @property
    def doubt_margin(self) -> float | None:
        """The calibrated ambiguity threshold (``learn/doubt.py``); None in a model file
        written before it existed, which then flags no answer."""
        from .doubt import model_threshold

        return model_threshold(self.info)


def renamed(names: np.ndarray, instead: Sequence[str | None]) -> np.ndarray:
    """``names`` with each replaced where ``instead`` names another family."""
    out = [str(o) if o else str(n) for n, o in zip(names, instead, strict=True)]
    return np.asarray(out, dtype=str)


def _qualname(kind: type) -> str:
    return f"{kind.__module__}.{kind.__qualname__}"


def save_model(path: str | Path, model: Model) -> Path:
    """Write ``model`` to ``path`` (a .npz archive) atomically; returns the path."""
    path = Path(path)
    est = model.estimator
    if not hasattr(est, "classes_"):
        raise UsageError("cannot save a model whose classifier has not been fitted")
    from .. import plugins

    try:  # a file load_model would refuse is not written
        described = plugins.get_descriptor(model.descriptor, **dict(model.descriptor_params))
    except UsageError as exc:
        raise UsageError(f"cannot save a model of descriptor {model.descriptor!r}: {exc}") from None
    _check_width(path, model.descriptor, described, est)
    meta: dict[str, Any] = {
        "format": MODEL_FORMAT,
        "format_version": MODEL_FORMAT_VERSION,
        "software_version": __version__,
        "descriptor": {"name": model.descriptor, "params": dict(model.descriptor_params)},
        "classifier": {"name": model.classifier, "params": dict(model.classifier_params)},
        "classes": model.classes,
        "estimator_type": _qualname(type(est)),
        "info": dict(model.info),
    }
    arrays: dict[str, np.ndarray] = {}
    if model.known is not None:
        meta["known_descriptor"] = model.known.descriptor
        arrays[_KNOWN_FEATURES] = np.asarray(model.known.features, dtype=float)
        arrays[_KNOWN_LABELS] = np.asarray(model.known.labels).astype(str)
    if model.novelty is not None:
        state, novelty_arrays = model.novelty.to_state()
        meta["novelty"] = state
        arrays |= {_NOVELTY_PREFIX + k: np.asarray(v, dtype=float)
                   for k, v in novelty_arrays.items()}  # fmt: skip
    if model.axis is not None:
        meta["axis_check"] = model.axis.to_dict()
    if model.second is not None:
        meta["second_opinion"], second_arrays = model.second.to_state()
        arrays |= second_arrays
    saved_state = _state_of(est, model.classifier)
    if saved_state is not None:
        state, state_arrays = saved_state
        meta["estimator_encoding"] = "state"
        arrays["estimator_state"] = np.array(json.dumps(state, default=json_value))
        for name, value in state_arrays.items():
            arr = np.asarray(value)
            if arr.dtype.kind not in "biufcU":
                raise UsageError(
                    f"estimator state array {name!r} has non-numeric dtype {arr.dtype}"
                )
            arrays[_STATE_PREFIX + name] = arr
    else:
        import skops.io as sio

        meta["estimator_encoding"] = "skops"
        arrays["estimator_skops"] = np.frombuffer(sio.dumps(est), dtype=np.uint8)
    try:
        meta_text = json.dumps(meta, default=json_value)
    except TypeError as exc:
        raise UsageError(f"model parameters must be plain values: {exc}") from None
    with atomic_path(path, "model") as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, meta=np.array(meta_text), **arrays)
    return path


def _state_of(est: Any, classifier: str) -> tuple[dict, dict[str, np.ndarray]] | None:
    """``est.to_state()``, or None for skops: an estimator without the protocol, or one whose
    ``to_state`` raises NotImplementedError (a library layout it does not know, such as another
    scikit-learn's). Its ValueError (a value it does not store) is a one-line UsageError."""
    if not isinstance(est, StatefulEstimator):
        return None
    try:
        return est.to_state()
    except NotImplementedError:
        return None
    except ValueError as exc:
        raise UsageError(f"cannot save the {classifier!r} classifier: {exc}") from None


MODEL_MEMBER_LIMIT = 1 << 30
"""The most bytes one array of a model file may decompress to (models are a few MB; an SVM on
a million grasps holds ~200 MB of support vectors)."""


KNOWN_MEMBER_LIMIT = 64 << 20
"""The most bytes a model's ``known.features`` or ``known.labels`` may hold: above what
``train --known`` writes for :data:`doubt.MAX_KNOWN_GRASPS` grasps (35 features of 8 bytes, a
label of 20 characters), far below what a damaged or hostile file could declare."""


def _is_model_member(name: str) -> bool:
    return name in (
        "meta", "estimator_state", "estimator_skops", _KNOWN_FEATURES, _KNOWN_LABELS,
        *(_NOVELTY_PREFIX + k for k in _NOVELTY_ARRAYS),
    ) or name.startswith((_STATE_PREFIX, _SECOND_PREFIX))  # fmt: skip


def _read(path: Path) -> tuple[dict, dict[str, np.ndarray]]:
    from ..files import check_npz_members, input_path

    input_path(path, "model file")
    try:
        check_npz_members(path, str(path), _is_model_member, MODEL_MEMBER_LIMIT,
                          limits={_KNOWN_FEATURES: KNOWN_MEMBER_LIMIT,
                                  _KNOWN_LABELS: KNOWN_MEMBER_LIMIT})  # fmt: skip
    except UsageError as exc:
        why = str(exc).removeprefix(f"{path} ")
        raise UsageError(f"{path} is not a tactile-bullet model ({why})") from None
    try:
        with np.load(path, allow_pickle=False) as data:
            contents = {k: data[k] for k in data.files}
    except Exception as exc:  # noqa: BLE001 - any unreadable file is the user's input
        raise UsageError(f"{path} is not a tactile-bullet model ({_reason(exc)})") from None
    if "meta" not in contents:
        raise UsageError(f"{path} is not a tactile-bullet model (no metadata)")
    try:
        meta = json.loads(str(contents.pop("meta")))
    except ValueError:
        raise UsageError(f"{path} is not a tactile-bullet model (unreadable metadata)") from None
    if not isinstance(meta, dict) or meta.get("format") != MODEL_FORMAT:
        raise UsageError(f"{path} is not a tactile-bullet model (wrong format marker)")
    return meta, contents


def _reason(exc: BaseException) -> str:
    from ..files import load_failure

    return load_failure(exc)


def _field(meta: dict, key: str, path: Path) -> tuple[str, dict]:
    part = meta.get(key)
    if (
        not isinstance(part, dict)
        or not isinstance(part.get("name"), str)
        or not isinstance(part.get("params", {}), dict)
    ):
        raise UsageError(f"{path} is not a valid model: bad {key} entry")
    return part["name"], dict(part.get("params", {}))


def _trusted(untrusted: list[str], template: Any) -> tuple[list[str], list[str]]:
    own = {_qualname(type(template))} | set(getattr(template, "trusted_types", ()))
    allowed, refused = [], []
    for name in untrusted:
        ok = name in own or name in SKLEARN_DATA_TYPES or _DIST_METRIC.match(name)
        (allowed if ok else refused).append(name)
    return allowed, refused


def load_model(path: str | Path) -> Model:
    """Read a model written by :func:`save_model`; never runs code from the file.

    Refuses (UsageError) a file that is not such a model, a newer format, a descriptor or
    classifier that is not installed here, and an estimator holding untrusted types.
    """
    from .. import plugins

    path = Path(path)
    meta, contents = _read(path)
    version = meta.get("format_version")
    if version != MODEL_FORMAT_VERSION:
        raise UsageError(
            f"{path} has model format version {version!r}; this tactile-bullet "
            f"({__version__}) reads version {MODEL_FORMAT_VERSION}"
        )
    descriptor, descriptor_params = _field(meta, "descriptor", path)
    classifier, classifier_params = _field(meta, "classifier", path)
    try:
        described = plugins.get_descriptor(descriptor, **descriptor_params)
    except UsageError as exc:
        raise UsageError(f"{path} needs descriptor {descriptor!r}: {exc}") from None
    encoding = meta.get("estimator_encoding")
    try:
        light = plugins.fitted_form(classifier) if encoding == "state" else None
        template = None if light else plugins.get_classifier(classifier, **classifier_params)
    except UsageError as exc:
        raise UsageError(f"{path} needs classifier {classifier!r}: {exc}") from None
    if light is not None:
        estimator = _load_state(path, contents, light)
        _check_params(path, classifier, classifier_params, estimator)
    elif encoding == "state":
        estimator = _load_state(path, contents, type(template))
    elif encoding == "skops":
        estimator = _load_skops(path, contents, template)
    else:
        raise UsageError(f"{path} is not a valid model: unknown estimator encoding {encoding!r}")
    if type(estimator) is not (light or type(template)):
        raise UsageError(
            f"{path} holds a {_qualname(type(estimator))}, not the {classifier!r} classifier "
            f"({_qualname(light or type(template))}) it names"
        )
    classes = [str(c) for c in getattr(estimator, "classes_", [])]
    if classes != [str(c) for c in meta.get("classes", [])]:
        raise UsageError(f"{path} is not a valid model: its classes do not match its metadata")
    _check_width(path, descriptor, described, estimator)
    info = meta.get("info", {})
    known = _load_known(path, meta, contents, classes)
    novelty = _load_novelty(path, meta, contents)
    axis = _load_axis(path, meta)
    second = None
    if "second_opinion" in meta:
        from .second_opinion import SecondOpinion

        second = SecondOpinion.from_state(meta["second_opinion"], contents, classes, str(path))
    return Model(
        descriptor=descriptor,
        descriptor_params=descriptor_params,
        classifier=classifier,
        classifier_params=classifier_params,
        estimator=estimator,
        info=info if isinstance(info, dict) else {},
        known=known,
        novelty=novelty,
        axis=axis,
        second=second,
        software_version=str(meta.get("software_version", "unknown")),
        format_version=MODEL_FORMAT_VERSION,
    )


def _check_width(path: Path, descriptor: str, described: Any, estimator: Any) -> None:
    """Refuse a model whose descriptor, with its parameters, gives rows of another width than
    its estimator was fitted on (metadata edited, or mixed from two files): every answer would
    fail. Descriptors or estimators that do not say their width pass."""
    names = getattr(described, "feature_names", None)
    fitted = getattr(estimator, "n_features_in_", None)
    if names is None or fitted is None:
        return
    try:
        width = len(names())
    except Exception:  # noqa: BLE001 - a plugin's own: the width is then unknown, not wrong
        return
    if width != int(fitted):
        raise UsageError(
            f"{path} is not a valid model: its descriptor {descriptor!r} gives {width} "
            f"features, its classifier was fitted on {int(fitted)}"
        )


def _load_known(path: Path, meta: dict, contents: dict[str, np.ndarray], classes: list[str]):
    """The model's known grasps (None where it was fitted without), checked: damaged ones
    are refused, not used to second answers."""
    from .doubt import KnownGrasps

    parts = (contents.get(_KNOWN_FEATURES), contents.get(_KNOWN_LABELS))
    descriptor = meta.get("known_descriptor")
    if all(p is None for p in parts) and descriptor is None:
        return None
    if any(p is None for p in parts) or not isinstance(descriptor, str):
        raise UsageError(f"{path} is not a valid model: its known grasps are incomplete")
    features, labels = parts
    if features.dtype.kind not in "fiu" or labels.dtype.kind != "U":
        raise UsageError(f"{path} is not a valid model: its known grasps are not numbers/names")
    known = KnownGrasps(features.astype(float), labels, descriptor)
    try:
        known.check(classes)
        from .. import plugins

        columns = len(plugins.get_descriptor(descriptor).feature_names())
        if features.shape[1] != columns:
            raise UsageError(f"its known grasps have {features.shape[1]} features, and "
                             f"{descriptor} gives {columns}")  # fmt: skip
    except (ValueError, UsageError) as exc:
        raise UsageError(f"{path} is not a valid model: {exc}") from None
    return known


def _load_novelty(path: Path, meta: dict, contents: dict[str, np.ndarray]):
    """The model's novelty (None where it was written without), checked: a damaged one is
    refused, never used to answer unknown."""
    from .novelty import Novelty

    arrays = {k: contents.get(_NOVELTY_PREFIX + k) for k in _NOVELTY_ARRAYS}
    state = meta.get("novelty")
    if state is None and all(v is None for v in arrays.values()):
        return None
    if not isinstance(state, dict) or any(v is None for v in arrays.values()):
        raise UsageError(f"{path} is not a valid model: its novelty fields are incomplete")
    try:
        return Novelty.from_state(state, arrays)
    except ValueError as exc:
        raise UsageError(f"{path} is not a valid model: {exc}") from None


def _load_axis(path: Path, meta: dict):
    """The model's axis check (None where it was written without), checked: a damaged one is
    refused, never used to answer unknown."""
    if "axis_check" not in meta:
        return None
    from ..perception.contact_check import ContactCheck

    try:
        return ContactCheck.from_dict(meta["axis_check"])
    except ValueError as exc:
        raise UsageError(f"{path} is not a valid model: {exc}") from None


def _check_params(path: Path, classifier: str, params: dict, estimator: Any) -> None:
    """The metadata's classifier parameters against those of the state (a light form is
    loaded without the estimator that would have checked them)."""
    own = estimator.get_params()
    for key, value in params.items():
        if key not in own or own[key] != value:
            raise UsageError(
                f"{path} is not a valid model: classifier {classifier!r} parameter {key}="
                f"{value!r} does not match its saved state"
            )


def _load_state(path: Path, contents: dict[str, np.ndarray], kind: type) -> Any:
    if not callable(getattr(kind, "from_state", None)):
        raise UsageError(f"{path}: classifier {_qualname(kind)} cannot restore a saved state")
    try:
        state = json.loads(str(contents["estimator_state"]))
    except (KeyError, ValueError):
        raise UsageError(f"{path} is not a valid model: missing estimator state") from None
    arrays = {
        k[len(_STATE_PREFIX) :]: v for k, v in contents.items() if k.startswith(_STATE_PREFIX)
    }
    try:
        return kind.from_state(state, arrays)
    except UsageError:
        raise
    except Exception as exc:  # noqa: BLE001 - a bad state is a bad file
        raise UsageError(f"{path}: cannot restore the estimator ({_reason(exc)})") from None


def _load_skops(path: Path, contents: dict[str, np.ndarray], template: Any) -> Any:
    import skops.io as sio

    blob = contents.get("estimator_skops")
    if blob is None or blob.dtype != np.uint8 or blob.ndim != 1:
        raise UsageError(f"{path} is not a valid model: missing estimator")
    data = blob.tobytes()
    try:
        untrusted = sio.get_untrusted_types(data=data)
    except Exception as exc:  # noqa: BLE001 - a corrupt payload is a bad file
        raise UsageError(f"{path}: unreadable estimator ({_reason(exc)})") from None
    allowed, refused = _trusted(untrusted, template)
    if refused:
        raise UsageError(
            f"{path} holds types this model may not load: {', '.join(sorted(refused))}"
        )
    try:
        return sio.loads(data, trusted=allowed)
    except Exception as exc:  # noqa: BLE001
        raise UsageError(f"{path}: cannot restore the estimator ({_reason(exc)})") from None
