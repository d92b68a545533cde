"""The ``random-forest`` estimator: scikit-learn's forest, plus the checks it cannot pass."""

from __future__ import annotations

from sklearn.ensemble import RandomForestClassifier


class ExampleForest(RandomForestClassifier):
    """RandomForestClassifier as registered by the example plugin.

    A subclass only to tell tactile-bullet's conformance tests which scikit-learn checks do not
    apply (``expected_failed_checks``); everything else is the parent's.
    """

    def expected_failed_checks(self) -> dict[str, str]:
        reason = (
            "bootstrap draws rows, so a weight of 2 is not the same as a repeated row "
            "(scikit-learn's own forests fail this check too)"
        )
        return {
            "check_sample_weight_equivalence_on_dense_data": reason,
            "check_sample_weight_equivalence_on_sparse_data": reason,
        }
