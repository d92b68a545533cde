"""A real Shadow hand's data: recordings in, datasets out, live identification.

``joints`` (Shadow's published joint names and the coupled J0), ``segment`` (finding grasps in
a stream), ``bags`` and ``tables`` (ROS bags; CSV and Parquet), ``recordings`` (samples ->
records -> a dataset), ``calibration`` (per-joint offsets and scales), ``export`` (records ->
bags and CSV) and ``streaming`` (the live :class:`Identifier`).
"""
