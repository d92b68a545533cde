"""The objects a hand grasps: the thesis' solids of revolution and user meshes.

``shapes`` holds one function per primitive (a radius profile and a watertight trimesh mesh),
``meshes`` turns a user's mesh file into the same kind of shape, ``builtin`` registers the
primitives as the default shape plugin, and ``placement`` says where an object sits in front of
the palm. Nothing here knows about a simulator or a classifier.
"""
