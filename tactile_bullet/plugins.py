"""The plugin registry: descriptors, classifiers and shapes, built-in or from other packages.

Built-in parts are plugins too (``DEFAULT_PLUGINS``), registered through the same hooks as a
third-party package, so the CLI's choices come from one registry. Outside plugins are found
through the entry-point group ``tactile_bullet`` and loaded once, lazily, on the first query.

Environment:

- ``TACTILE_BULLET_PLUGINS="a,b"``: load only these installed plugins (entry-point or
  distribution names); set but empty, load none. Built-in plugins always load.
- ``TACTILE_BULLET_BLOCK_PLUGINS="a,b"``: never load these installed plugins.

While the project's own test suite runs (``tests/conftest.py`` sets
``sys._tactile_bullet_testing``), installed plugins are not loaded unless
``TACTILE_BULLET_PLUGINS`` names them, so the tests see the built-in registry only.

A plugin that fails to import or whose hook raises (a duplicate name included) is reported on
stderr and in :func:`plugin_report`, and nothing it registered is kept; the rest works.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import inspect
import os
import re
import sys
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import pluggy

from . import __version__, hookspecs
from .errors import TactileBulletError, UsageError

DEFAULT_PLUGINS: tuple[str, ...] = (
    "tactile_bullet.objects.builtin",
    "tactile_bullet.learn.builtin",
    "tactile_bullet.learn.classifiers.builtin",
    "tactile_bullet.sim.engines.builtin",
)
"""Built-in plugin modules, registered exactly like installed ones."""

ENTRY_POINT_GROUP = hookspecs.PROJECT
ALLOW_ENV = "TACTILE_BULLET_PLUGINS"
BLOCK_ENV = "TACTILE_BULLET_BLOCK_PLUGINS"

KINDS: dict[str, str] = {
    "descriptors": "register_descriptors",
    "classifiers": "register_classifiers",
    "shapes": "register_shapes",
    "engines": "register_engines",
}
"""Registry kind -> the hook that fills it."""

_SINGULAR = {
    "descriptors": "descriptor",
    "classifiers": "classifier",
    "shapes": "shape",
    "engines": "engine",
}
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


class PluginError(TactileBulletError):
    """A plugin could not be registered (import failure, hook error, duplicate name)."""


@dataclass(frozen=True)
class _Entry:
    name: str
    value: Any
    plugin: str


@dataclass
class _PluginInfo:
    name: str
    version: str | None
    builtin: bool
    registered: dict[str, list[str]] = field(default_factory=lambda: {k: [] for k in KINDS})
    error: str | None = None

    def describe(self) -> dict:
        doc: dict[str, Any] = {"name": self.name, "version": self.version, "builtin": self.builtin}
        doc.update({kind: list(names) for kind, names in self.registered.items()})
        if self.error is not None:
            doc["error"] = self.error
        return doc


class _Registry:
    """The plugin manager plus what each plugin registered; one per process."""

    def __init__(self) -> None:
        self.pm = pluggy.PluginManager(hookspecs.PROJECT)
        self.pm.add_hookspecs(hookspecs)
        self.entries: dict[str, dict[str, _Entry]] = {kind: {} for kind in KINDS}
        self.infos: dict[str, _PluginInfo] = {}

    def add(self, plugin: object, name: str, version: str | None, builtin: bool) -> str | None:
        """Register one plugin and run its hooks; all or nothing. Returns the error, if any."""
        if name in self.infos or self.pm.has_plugin(name):
            return f"a plugin named {name!r} is already registered"
        info = _PluginInfo(name, version, builtin)
        self.infos[name] = info
        staged: dict[str, dict[str, _Entry]] = {kind: {} for kind in KINDS}
        try:
            self.pm.register(plugin, name=name)
        except Exception as exc:  # noqa: BLE001 - any failure of a plugin is reported, not raised
            info.error = _describe(exc)
            return info.error
        try:
            try:
                self.pm.check_pending()  # a misspelt hook name would otherwise do nothing
            except pluggy.PluginValidationError as exc:
                raise PluginError(str(exc)) from exc
            for kind, hook in KINDS.items():
                for impl in getattr(self.pm.hook, hook).get_hookimpls():
                    if impl.plugin_name != name:
                        continue
                    register = self._register_callback(kind, name, staged)
                    try:
                        impl.function(*([register] * len(impl.argnames)))
                    except PluginError:
                        raise
                    except Exception as exc:
                        raise PluginError(f"{hook} failed: {_describe(exc)}") from exc
        except PluginError as exc:
            self.pm.unregister(name=name)
            info.error = str(exc)
            return info.error
        for kind, entries in staged.items():
            self.entries[kind].update(entries)
            info.registered[kind] = list(entries)
        return None

    def _register_callback(
        self, kind: str, plugin: str, staged: dict[str, dict[str, _Entry]]
    ) -> Callable[[str, Any], None]:
        what = _SINGULAR[kind]

        def register(name: str, factory: Any) -> None:
            if not isinstance(name, str) or not _NAME.match(name):
                raise PluginError(
                    f"plugin {plugin!r} registered an invalid {what} name {name!r} "
                    "(letters, digits, '.', '_', '-'; no '+')"
                )
            existing = self.entries[kind].get(name) or staged[kind].get(name)
            if existing is not None:
                raise PluginError(
                    f"{what} {name!r} from plugin {plugin!r} is already registered by plugin "
                    f"{existing.plugin!r}"
                )
            _check_value(kind, name, factory, plugin)
            staged[kind][name] = _Entry(name, factory, plugin)

        return register

    def remove(self, name: str) -> None:
        info = self.infos.pop(name, None)
        if self.pm.has_plugin(name):
            self.pm.unregister(name=name)
        if info is not None:
            for kind, names in info.registered.items():
                for entry_name in names:
                    self.entries[kind].pop(entry_name, None)


def _describe(exc: BaseException) -> str:
    text = str(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _check_value(kind: str, name: str, value: Any, plugin: str) -> None:
    if kind == "shapes":
        from .objects.shapes import Shape

        if not isinstance(value, Shape):
            raise PluginError(f"plugin {plugin!r} registered shape {name!r} that is not a Shape")
        if value.name != name:
            raise PluginError(
                f"plugin {plugin!r} registered shape {value.name!r} under the name {name!r}"
            )
    elif not callable(value):
        raise PluginError(
            f"plugin {plugin!r} registered {_SINGULAR[kind]} {name!r} with a factory that is "
            "not callable"
        )


_registry: _Registry | None = None


def _in_test_suite() -> bool:
    return bool(getattr(sys, "_tactile_bullet_testing", False))


def _name_set(text: str) -> set[str]:
    return {_normalise(part) for part in text.split(",") if part.strip()}


def _normalise(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name.strip()).lower()


def _entry_points() -> Iterable[importlib.metadata.EntryPoint]:
    return importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)


def _load_entry_points(registry: _Registry) -> None:
    allow_text = os.environ.get(ALLOW_ENV)
    if allow_text is None and _in_test_suite():
        return
    allow = None if allow_text is None else _name_set(allow_text)
    block = _name_set(os.environ.get(BLOCK_ENV, ""))
    installed: set[str] = set()
    for ep in _entry_points():
        dist = getattr(ep, "dist", None)
        dist_name = dist.metadata["Name"] if dist is not None else None
        version = dist.version if dist is not None else None
        names = {_normalise(ep.name)} | ({_normalise(dist_name)} if dist_name else set())
        installed |= names
        if (allow is not None and not names & allow) or names & block:
            continue
        name = dist_name or ep.name
        if name in registry.infos:
            name = f"{name}:{ep.name}"
        try:
            plugin = ep.load()
        except Exception as exc:  # noqa: BLE001 - a broken plugin must not break the rest
            registry.infos[name] = _PluginInfo(name, version, False, error=_describe(exc))
            _warn(name, registry.infos[name].error)
            continue
        error = registry.add(plugin, name, version, builtin=False)
        if error:
            _warn(name, error)
    for env, wanted in ((ALLOW_ENV, allow or set()), (BLOCK_ENV, block)):
        for missing in sorted(wanted - installed):
            print(
                f"tactile-bullet: warning: {env} names {missing!r}, which is not an installed "
                f"plugin (installed: {', '.join(sorted(installed)) or 'none'})",
                file=sys.stderr,
            )


def _warn(name: str, error: str | None) -> None:
    print(f"tactile-bullet: warning: plugin {name!r} skipped: {error}", file=sys.stderr)


def load_plugins() -> None:
    """Register the built-in plugins and the installed ones, once per process."""
    global _registry
    if _registry is not None:
        return
    registry = _Registry()
    _registry = registry
    for module_name in DEFAULT_PLUGINS:
        module = importlib.import_module(module_name)
        error = registry.add(module, module_name, __version__, builtin=True)
        if error:  # a bug in the package itself, not a user's plugin
            raise PluginError(f"built-in plugin {module_name} failed: {error}")
    _load_entry_points(registry)


def reload_plugins() -> None:
    """Forget every plugin and load again (after installing one, or in tests)."""
    global _registry
    _registry = None
    load_plugins()


def _loaded() -> _Registry:
    load_plugins()
    assert _registry is not None
    return _registry


def register_plugin(plugin: object, name: str | None = None) -> str:
    """Register an object or module as a plugin now (tests, notebooks); returns its name.

    Raises PluginError, with nothing of the plugin kept, if a hook fails or a name is taken.
    """
    registry = _loaded()
    name = name or getattr(plugin, "__name__", None) or f"plugin-{id(plugin):x}"
    taken = name in registry.infos
    error = registry.add(plugin, name, getattr(plugin, "__version__", None), builtin=False)
    if error:
        if not taken:
            registry.infos.pop(name, None)
        raise PluginError(f"plugin {name!r}: {error}")
    return name


def unregister_plugin(name: str) -> None:
    """Remove a plugin and everything it registered."""
    _loaded().remove(name)


def plugin_report() -> list[dict]:
    """One entry per plugin: name, version, builtin, what it registered, and error if any."""
    return [info.describe() for info in _loaded().infos.values()]


KNOWN_PROVIDERS = {
    ("classifiers", "random-forest"): "tactile-bullet-example",
    ("descriptors", "finger-closure"): "tactile-bullet-example",
    ("shapes", "capsule"): "tactile-bullet-example",
}
"""Names registered by packages known to this project, for the error when one is missing."""

_INSTALL = {
    "tactile-bullet-example": "pip install ./plugins/tactile-bullet-example (from a clone of "
    "tactile-bullet; it ships the example plugin)",
}


def _lookup(kind: str, name: str) -> _Entry:
    entries = _loaded().entries[kind]
    if not isinstance(name, str) or name not in entries:
        hint = ""
        package = KNOWN_PROVIDERS.get((kind, _normalise(name) if isinstance(name, str) else ""))
        if package:
            hint = f"; {name!r} comes with the {package} plugin: {_INSTALL[package]}"
        raise UsageError(
            f"unknown {_SINGULAR[kind]} {name!r} ({kind}: {', '.join(entries) or 'none'}){hint}"
        )
    return entries[name]


def shape_names() -> list[str]:
    """Registered shape names, built-in ones first."""
    return list(_loaded().entries["shapes"])


def get_shape(name: str):
    """The registered ``shapes.Shape`` called ``name``."""
    return _lookup("shapes", name).value


def engine_names() -> list[str]:
    """Registered physics engine names, built-in ones first (``bullet`` is the default)."""
    return list(_loaded().entries["engines"])


def get_engine(name: str):
    """The factory of the engine called ``name``; an unknown name lists the registered ones,
    and an engine whose package is missing says how to install it (both UsageError)."""
    factory = _lookup("engines", name).value
    missing = getattr(factory, "missing", None)
    if missing is not None and (why := missing()):
        raise UsageError(why)
    return factory


def descriptor_names() -> list[str]:
    """Registered descriptor names; any of them may be joined with '+' in get_descriptor."""
    return list(_loaded().entries["descriptors"])


def classifier_names() -> list[str]:
    """Registered classifier names, built-in ones first."""
    return list(_loaded().entries["classifiers"])


def plugin_of(kind: str, name: str) -> str:
    """Which plugin registered a descriptor, classifier or shape."""
    if kind not in KINDS:
        raise UsageError(f"unknown kind {kind!r} (kinds: {', '.join(KINDS)})")
    return _lookup(kind, name).plugin


def _factory_parameters(factory: Callable) -> list[str] | None:
    """Keyword parameters a factory accepts; None if it takes **kwargs (anything goes)."""
    try:
        sig = inspect.signature(factory)
    except (TypeError, ValueError):
        return None
    names = []
    for p in sig.parameters.values():
        if p.kind is p.VAR_KEYWORD:
            return None
        if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY):
            names.append(p.name)
    return names


def _build_descriptor(name: str, params: Mapping[str, Any]):
    entry = _lookup("descriptors", name)
    valid = _factory_parameters(entry.value)
    unknown = sorted(set(params) - set(valid)) if valid is not None else []
    if unknown:
        raise UsageError(
            f"descriptor {name!r} has no parameter {unknown[0]!r} "
            f"(parameters: {', '.join(valid) or 'none'})"
        )
    try:
        descriptor = entry.value(**params)
    except UsageError:
        raise
    except (TypeError, ValueError) as exc:
        raise UsageError(f"descriptor {name!r}: {exc}") from None
    if getattr(descriptor, "name", None) != name:
        # models store the descriptor's own name: it must find the same entry again
        raise PluginError(
            f"descriptor {name!r} from plugin {entry.plugin!r} calls itself "
            f"{getattr(descriptor, 'name', None)!r}"
        )
    return descriptor


def get_descriptor(name: str, **params):
    """A descriptor by name; ``"a+b"`` concatenates registered descriptors' features.

    For a combination, ``part.key=value`` sets a parameter of one part and a plain ``key``
    goes to every part that has it.
    """
    if not isinstance(name, str) or not name:
        raise UsageError(f"descriptor name must be a non-empty string, got {name!r}")
    if "+" not in name:
        return _build_descriptor(name, params)
    from .learn.descriptors import ConcatDescriptor

    parts = [p.strip() for p in name.split("+")]
    if any(not p for p in parts) or len(set(parts)) != len(parts):
        raise UsageError(f"descriptor combination {name!r} must join distinct names with '+'")
    for part in parts:
        _lookup("descriptors", part)
    routed: dict[str, dict[str, Any]] = {p: {} for p in parts}
    for key, value in params.items():
        target, dot, sub = key.partition(".")
        if dot and target in routed:
            routed[target][sub] = value
            continue
        takers = [
            p
            for p in parts
            if key in (_factory_parameters(_lookup("descriptors", p).value) or [key])
        ]
        if not takers:
            raise UsageError(f"no part of descriptor {name!r} has a parameter {key!r}")
        for p in takers:
            routed[p][key] = value
    return ConcatDescriptor(tuple(_build_descriptor(p, routed[p]) for p in parts))


def _fresh_estimator(name: str):
    entry = _lookup("classifiers", name)
    try:
        return entry.value()
    except ImportError as exc:
        raise UsageError(
            f"classifier {name!r} (plugin {entry.plugin}) needs a package that is not "
            f"installed: {exc}"
        ) from None


def fitted_form(name: str) -> type | None:
    """The class a saved model of classifier ``name`` loads as, where its factory names one
    (``factory.fitted_form``: a callable returning a class with ``from_state``): a light,
    predict-only form that spares loading the estimator's own imports (a saved knn predicts
    without scikit-learn). None where the factory names none: the model loads as the
    estimator itself."""
    entry = _lookup("classifiers", name)
    form = getattr(entry.value, "fitted_form", None)
    if not callable(form):
        return None
    try:
        kind = form()
    except ImportError as exc:
        raise UsageError(
            f"classifier {name!r} (plugin {entry.plugin}) needs a package that is not "
            f"installed: {exc}"
        ) from None
    if not isinstance(kind, type) or not callable(getattr(kind, "from_state", None)):
        raise UsageError(f"classifier {name!r}'s fitted_form is not a class with from_state")
    return kind


def get_classifier(name: str, **params):
    """A fresh, unfitted estimator; ``params`` go through ``set_params`` (nested ``a__b`` too)."""
    estimator = _fresh_estimator(name)
    if not params:
        return estimator
    valid = sorted(estimator.get_params(deep=True))
    unknown = sorted(set(params) - set(valid))
    if unknown:
        raise UsageError(
            f"classifier {name!r} has no parameter {unknown[0]!r} "
            f"(parameters: {', '.join(valid) or 'none'})"
        )
    try:
        estimator.set_params(**params)
        # scikit-learn checks a value's type and range only when fitting (after minutes of
        # descriptors, inside another function's name): check them now, where it can
        _validate(estimator)
    except (TypeError, ValueError) as exc:
        raise UsageError(f"classifier {name!r}: {str(exc).splitlines()[0]}") from None
    return estimator


def _validate(estimator) -> None:
    """An estimator's own check of its parameters (``check_params``, or scikit-learn's where
    it declares ``_parameter_constraints``), and each step's in a pipeline."""
    steps = getattr(estimator, "steps", None)
    for part in [estimator, *(s for _, s in steps or [])]:
        if callable(getattr(part, "check_params", None)):
            part.check_params()
        elif hasattr(part, "_parameter_constraints"):
            part._validate_params()


def classifier_parameters(name: str) -> dict[str, Any]:
    """Default parameters of a classifier (what ``--param`` may set)."""
    return dict(_fresh_estimator(name).get_params(deep=False))


def required_descriptor(classifier: str) -> str | None:
    """The descriptor a classifier reads, if it reads only one layout (``dtw-template``)."""
    return getattr(_fresh_estimator(classifier), "required_descriptor", None)


def accepted_descriptors(classifier: str) -> tuple[str, ...] | None:
    """Every descriptor a classifier can read, or None when it reads any feature matrix.

    An estimator declares ``required_descriptor`` (its one layout) and may add
    ``accepted_descriptors``: other descriptors with the same columns (``shape-fit`` reads
    ``raw-joints`` and ``robust-joints``, whose columns are the same joints)."""
    estimator = _fresh_estimator(classifier)
    needed = getattr(estimator, "required_descriptor", None)
    if needed is None:
        return None
    more = tuple(getattr(estimator, "accepted_descriptors", ()) or ())
    return tuple(dict.fromkeys((needed, *more)))


def compatible(descriptor: str, classifier: str) -> bool:
    """Whether ``classifier`` can learn from ``descriptor``'s features."""
    accepted = accepted_descriptors(classifier)
    return accepted is None or descriptor in accepted
