"""Built-in plugin: the seven shapes of ``shapes.BUILTIN_SHAPES`` (thesis and modified)."""

from __future__ import annotations

from ..hookspecs import hookimpl


@hookimpl
def register_shapes(register):
    from .shapes import BUILTIN_SHAPES

    for shape in BUILTIN_SHAPES:
        register(shape.name, shape)
