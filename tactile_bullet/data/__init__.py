"""Package data: measured identification thresholds and the rotation calibration (JSON written
by ``tools/invariance.py`` and ``tools/rotation_calibration.py``). A package of its own so that
setuptools installs it as one, without a warning."""
