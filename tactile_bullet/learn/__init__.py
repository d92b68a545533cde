"""From records to shape names with training: descriptors, classifiers and saved models.

``descriptors`` (signature, raw joints, contact normals and their concatenations),
``robust`` (descriptors and augmentation that expect a real hand's noise), ``perturb`` (the
sensor noise and bias models), ``time_series``, ``classifiers/`` (every built-in scikit-learn
estimator), ``neural_forest`` (ch. 4), ``models`` (a descriptor and a fitted classifier saved
together, without pickle) and ``builtin`` (the default plugin registering the descriptors).
"""
