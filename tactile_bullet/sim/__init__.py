"""The simulated hand grasping an object: the scene, Algorithm 1 and the snapshot renderer.

``scene`` owns one physics client with the hand's URDF and a static object, ``grasp`` runs
the enclosure grasp (thesis Algorithm 1) and returns a :class:`~tactile_bullet.records.GraspRecord`,
``render`` draws a snapshot with the CPU renderer.
"""
