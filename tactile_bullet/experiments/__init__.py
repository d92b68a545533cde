"""What users run end to end: train / evaluate / compare / demo, the benchmark and the thesis
experiments, with their reports and figures.

``workflow`` (the CLI's and the API's train, evaluate, compare, identify, demo; the first
four live in ``training``),
``benchmark`` and ``protocols`` (transfer protocols), ``sequential`` (ch. 4), ``temporal``
(ch. 3), ``reports`` and the ``figures_*`` modules.
"""
