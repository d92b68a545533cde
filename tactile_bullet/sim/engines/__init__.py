"""Physics engines behind one interface (:class:`~.base.Engine`): ``bullet`` (PyBullet, the
project's first simulator) and ``mujoco``; plugins add more through ``register_engines``."""
