"""Many grasps on disk: sweep definitions, the sharded dataset format and parallel generation.

``sweeps`` (what to grasp: shapes, sizes, poses, presets, TOML), ``executors`` (where grasps
run: processes or a dask cluster), ``shards`` (one shard's bytes), ``integrity`` (checking a
manifest and its shards), ``generate`` (writing a dataset atomically, resumable) and
``dataset`` (reading one back, ``verify``, ``read_records``).
"""
