"""What mesh files are read and how they may be declared: plain constants, importable without
numpy or trimesh so that the CLI's parser builds fast."""

from __future__ import annotations

FORMATS: tuple[str, ...] = ("stl", "obj", "ply", "glb", "gltf", "off")
"""File types read (by extension)."""

UNITS: dict[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001}
"""Length unit of the numbers in a file -> metres."""

AXES: tuple[str, ...] = ("auto", "x", "y", "z")
"""Main-axis choices: ``auto`` (principal axes of inertia) or a file axis."""
