"""Built-in classifiers: scikit-learn estimators registered by ``classifiers.builtin``.

Each module holds one estimator and imports scikit-learn only when it is itself imported, so
listing the registry (``tactile-bullet plugins``) stays fast.
"""
