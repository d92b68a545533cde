"""Neural decision forests and the sequential collection of them (thesis ch. 4).

A soft binary tree of depth D has 2**D - 1 split nodes and 2**D leaves. Split node n of tree t
sends a sample left with probability sigmoid(w_n . x_S(t) + b_n), where S(t) is a random subset
of the input features drawn once per tree; a sample reaches each leaf with the product of the
routing probabilities on its path, and the tree's prediction is the leaf distributions mixed with
those weights (Kontschieder et al., Deep Neural Decision Forests, ICCV 2015). Everything is
differentiable, so the forest trains by back-propagation in mini-batches (Adam).

The classifier is a *collection* of such forests, one per class (the thesis' "each object's
tree"): the forest of class c has leaves holding the distribution over {c, not c}, and the
collection's probabilities are the forests' probabilities of "c" normalised over the classes.
One forest per class is what makes sequential learning cheap: a class seen for the first time
gets a forest of its own, trained on its samples plus a small replay memory of earlier ones,
while the existing forests only get a short re-calibration against the newcomer. ``fit`` builds
the same collection from all classes at once with the same number of updates per forest, so
offline and sequential models are directly comparable (thesis Fig. 4.13).

Only numpy is imported here; torch is imported when training starts, so importing this module
(the CLI) stays fast, and a fitted model predicts (and unpickles) without torch.
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import numpy as np
from scipy.special import expit
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils import check_random_state
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

from ..console import tick
from .torch_support import check_device_name, check_memory, import_torch, torch_device

__all__ = ["NeuralForestClassifier", "per_class_accuracy"]

_PROBA_FLOOR = 1e-7
"""Bounds the forests' outputs away from 0 and 1 in the loss (log of a mixture, no logits)."""

_SMALL_STEP = 10_000_000
"""Multiply-adds per routing step below which training runs on one torch thread. Measured on 2
busy cores: a 64-sample step over 28 trees of depth 4 (0.5 M) took 3-10 ms on one thread and
40-140 ms on two (thread wake-ups dominate such tiny kernels); a 72 M step was still faster on one
thread, a 720 M one broke even. Larger problems keep torch's own setting.
"""

_PREDICT_CHUNK = 4096
"""Most rows routed at once in predict; fewer when a row's temporaries are large."""

_PREDICT_CHUNK_BYTES = 64 * 1024**2
"""Budget for one predict chunk's routing temporaries (about four float64 arrays of rows x
trees x nodes): a deep or wide forest predicts in smaller chunks instead of taking gigabytes."""


def _torch() -> Any:
    """Import torch on first use: it costs about a second, which the CLI should not pay."""
    return import_torch()


@contextmanager
def _threads_for(torch: Any, work: int, device: Any) -> Iterator[None]:
    """Run tiny CPU training steps on one thread, restoring torch's global setting afterwards."""
    previous = torch.get_num_threads()
    if device.type == "cpu" and work < _SMALL_STEP and previous > 1:
        torch.set_num_threads(1)
    try:
        yield
    finally:
        if torch.get_num_threads() != previous:
            torch.set_num_threads(previous)


_WHITEN_FLOOR = 1e-3
"""Smallest eigenvalue kept when whitening a tree's inputs, relative to their mean: directions
the training pool hardly spans are not blown up (they may vary in new data)."""


def _whitening(xs: np.ndarray, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per tree, A = V diag(1/sqrt(l)) and its inverse from the covariance V diag(l) V^T of the
    tree's (standardised) inputs in ``xs``: A^T x has identity covariance, and a split w_z on
    A^T x equals the split A w_z on x."""
    n_trees, n_subset = idx.shape
    basis = np.empty((n_trees, n_subset, n_subset))
    inverse = np.empty_like(basis)
    for g in range(n_trees):
        sub = xs[:, idx[g]]
        cov = np.cov(sub, rowvar=False).reshape(n_subset, n_subset) if len(sub) > 1 else None
        if cov is None or not np.all(np.isfinite(cov)):
            cov = np.eye(n_subset)
        lam, vec = np.linalg.eigh((cov + cov.T) / 2.0)
        lam = np.maximum(lam, _WHITEN_FLOOR * max(float(lam.mean()), 1e-12))
        basis[g] = vec / np.sqrt(lam)
        inverse[g] = (vec * np.sqrt(lam)).T
    return basis, inverse


def _routing_numpy(xs: np.ndarray, idx: np.ndarray, w: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Leaf-reaching probabilities (rows, trees, leaves) for flattened trees, in numpy."""
    z = np.matmul(xs[:, idx].transpose(1, 0, 2), w).transpose(1, 0, 2) + b
    d = expit(z)  # overflow-free logistic: large |z| from unseen inputs is common
    mu = np.ones((xs.shape[0], idx.shape[0], 1))
    level_start = 0
    while mu.shape[-1] < d.shape[-1] + 1:
        width = mu.shape[-1]
        dl = d[:, :, level_start : level_start + width]
        mu = np.stack((mu * dl, mu * (1.0 - dl)), axis=-1).reshape(mu.shape[0], mu.shape[1], -1)
        level_start += width
    return mu


def _routing_torch(torch: Any, xs: Any, idx: Any, w: Any, b: Any, depth: int) -> Any:
    """The same routing as ``_routing_numpy``, differentiable, for training."""
    z = torch.einsum("bgf,gfn->bgn", xs[:, idx], w) + b
    d = torch.sigmoid(z)
    rows, trees = xs.shape[0], idx.shape[0]
    mu = xs.new_ones((rows, trees, 1))
    for level in range(depth):
        dl = d[:, :, 2**level - 1 : 2 ** (level + 1) - 1]
        mu = torch.stack((mu * dl, mu * (1.0 - dl)), dim=-1).reshape(rows, trees, -1)
    return mu


class NeuralForestClassifier(ClassifierMixin, BaseEstimator):
    """A collection of neural decision forests, one per class, that can learn classes one by one.

    Leaves are learned jointly with the splits (leaf logits by gradient, sigmoid to a
    probability), not by the paper's alternating fixed-point rule: that rule needs a pass over
    the whole training set between epochs, which sequential learning no longer has (only the new
    class and a bounded memory), and joint training keeps one mini-batch loop for ``fit`` and
    ``partial_fit``. Re-calibrating old forests by the fixed-point rule on their leaves alone
    (splits frozen) was tried and lost 3 points of sequential accuracy against 30 gradient steps
    that also move the splits (7 synthetic classes, 0.84 vs 0.87; offline 0.89).

    ``partial_fit`` accepts classes never seen before. Each new class gets its own forest,
    trained ``n_updates`` times on the new samples plus the replay memory; every existing forest
    is re-calibrated ``n_recalibration_updates`` times on the same pool, so it learns to reject
    the newcomer. The cost of an addition depends on the new class's data and the fixed update
    counts, not on the history. The replay memory (``memory_size`` samples in all, split equally
    between classes, randomly sub-sampled) is kept because without negatives from the old
    classes a new forest would claim every sample, and without positives an old forest's
    re-calibration would teach it to reject everything; ``memory_size=0`` switches it off to
    measure that forgetting. Inputs are standardised inside; running statistics are merged at
    each ``partial_fit`` and the old forests' split weights are re-expressed exactly in the new
    scale, so their functions do not change.

    Parameters
    ----------
    n_trees : int
        Soft trees per class forest.
    depth : int
        Depth of each tree (2**depth leaves).
    feature_fraction : float
        Fraction of the input features each tree sees (a random subset fixed per tree).
    n_updates : int
        Adam updates (mini-batches) each class forest gets when its class is fitted.
    n_recalibration_updates : int
        Adam updates each existing forest gets when ``partial_fit`` brings other classes.
    batch_size : int
        Samples per mini-batch, drawn with replacement, balanced over classes.
    learning_rate : float
        Adam step size.
    memory_size : int
        Replay memory kept for ``partial_fit`` (samples in all, balanced over classes).
    whiten : bool
        Train each tree's split weights in whitened coordinates of its inputs (decorrelated,
        unit variance, from the covariance of the data being trained on), then store them back
        in standardised coordinates. The model class and prediction are unchanged; only the
        optimisation is better conditioned. The signature's line samples are strongly
        correlated, and on raw standardised inputs Adam fits the training grasps (98.5%) but
        splits cylinder from hyperboloid at unseen sizes poorly. Demo protocol, four splits
        (``python benchmarks/bench_accuracy.py --seeds 0,1,2,3 --classifier neural-forest``):
        signature 84.5% without whitening, 95.8% with it (svm 96.2%); signature +
        contact-normals 98.2% with it (svm 97.0%). More updates (1000: 89.5%), deeper trees,
        more trees, all features per tree or a lower learning rate did not close the gap.
        The other way on the sequential preset (7 classes incl. the rot90 ones, random split,
        signature + contact-normals, 3 orders of ``tactile-bullet sequential --orders 3``):
        offline 0.894 with vs 0.926 without, sequential 0.887 vs 0.904, though the worst
        disturbance halves (-0.15 vs -0.35); so ``tactile-bullet sequential`` keeps the
        unwhitened forests by default (its README figures) and ``--whiten`` runs these.
    device : str
        Torch device for training ("cpu", "cuda"); prediction runs in numpy. A device this
        torch build or machine lacks is refused (``UsageError``) when ``fit`` starts.
    random_state : int, RandomState instance or None
        Seeds the feature subsets, initial weights and mini-batches (0 by default, like the
        other built-in classifiers, so the same data trains the same model; None draws one).

    Limits: ``fit`` and ``partial_fit`` compute :meth:`memory_estimate` (parameters, Adam
    state, a training step's temporaries; it doubles with each level of ``depth``) and refuse
    a forest above ``torch_support.MEMORY_LIMIT_BYTES`` (2 GiB) before allocating anything;
    ``predict_proba`` routes rows in chunks of at most 64 MiB of temporaries.

    Attributes
    ----------
    classes_ : ndarray of shape (n_classes,)
        Known class labels, sorted; the columns of ``predict_proba``.
    n_features_in_ : int
        Number of input features.
    mean_, scale_, var_ : ndarray of shape (n_features_in_,)
        Standardisation statistics of all samples seen so far.
    n_samples_seen_ : int
        Samples the statistics were computed from.
    feature_indices_ : ndarray of shape (n_classes, n_trees, n_subset)
        Features each tree reads.
    split_weights_ : ndarray of shape (n_classes, n_trees, n_subset, 2**depth - 1)
    split_biases_ : ndarray of shape (n_classes, n_trees, 2**depth - 1)
    leaf_logits_ : ndarray of shape (n_classes, n_trees, 2**depth)
        Logit of "this class" held by each leaf.
    n_updates_ : ndarray of shape (n_classes,)
        Adam updates each class forest received in total (thesis Fig. 4.13's updates per tree).
    memory_X_ : ndarray of shape (n_memory, n_features_in_)
    memory_y_ : ndarray of shape (n_memory,)
        Replay memory (raw, unstandardised samples).
    history_ : list of dict
        One entry per ``fit``/``partial_fit`` call: classes added, samples, seconds.
    """

    def __init__(
        self,
        n_trees: int = 4,
        depth: int = 4,
        feature_fraction: float = 0.5,
        n_updates: int = 300,
        n_recalibration_updates: int = 100,
        batch_size: int = 64,
        learning_rate: float = 0.03,
        memory_size: int = 500,
        whiten: bool = True,
        device: str = "cpu",
        random_state: int | np.random.RandomState | None = 0,
    ) -> None:
        self.n_trees = n_trees
        self.depth = depth
        self.feature_fraction = feature_fraction
        self.n_updates = n_updates
        self.n_recalibration_updates = n_recalibration_updates
        self.batch_size = batch_size
        self.learning_rate = learning_rate
        self.memory_size = memory_size
        self.whiten = whiten
        self.device = device
        self.random_state = random_state

    # -- public API ---------------------------------------------------------------------------

    def fit(self, X: Any, y: Any) -> NeuralForestClassifier:
        """Train one forest per class on all the data at once (the offline reference)."""
        self._check_params()
        for name in list(vars(self)):
            if name.endswith("_") and not name.startswith("_"):
                delattr(self, name)
        X, y = validate_data(self, X, y, dtype=np.float64)
        check_classification_targets(y)
        classes = np.unique(y)
        self._check_size(X.shape[1], len(classes))
        torch_device(_torch(), self.device, "neural-forest")  # refused before any work
        start = time.perf_counter()
        seed = check_random_state(self.random_state).randint(np.iinfo(np.int32).max)
        self._seed = int(seed)
        self._n_calls = 0
        self._start_statistics(X)
        rng = np.random.default_rng([self._seed, 0])
        self._init_members(classes, rng)
        if len(classes) > 1:  # one class: every forest would learn "always"; predict it anyway
            y_idx = np.searchsorted(self.classes_, y)
            self._train(X, y_idx, np.arange(len(classes)), self.n_updates, rng)
        self._remember(X, y, rng)
        self.history_ = [self._record(classes, X.shape[0], [], start)]
        return self

    def partial_fit(
        self, X: Any, y: Any, classes: Sequence[Any] | None = None
    ) -> NeuralForestClassifier:
        """Learn from one more batch, which may bring classes never seen before.

        Forests of the classes present in ``y`` (new or not) get ``n_updates`` updates on the
        batch plus the replay memory; the other forests get ``n_recalibration_updates``. While
        batch and memory hold a single class nothing is trained (there is nothing to tell
        apart); forests still untrained get the full ``n_updates`` once a second class comes.
        ``classes`` may announce labels ahead of their data (their forests then only learn to
        reject); unlike sklearn's linear models it is never required.
        """
        first = not hasattr(self, "classes_")
        if first:
            self._check_params()
        X, y = validate_data(self, X, y, dtype=np.float64, reset=first)
        check_classification_targets(y)
        start = time.perf_counter()
        present = np.unique(y)
        announced = present if classes is None else np.unique(np.asarray(classes))
        if classes is not None and not np.all(np.isin(present, announced)):
            missing = np.setdiff1d(present, announced)
            raise ValueError(f"y holds labels not in `classes`: {missing.tolist()}")
        known = announced if first else np.union1d(self.classes_, announced)
        self._check_size(self.n_features_in_, len(known))
        torch_device(_torch(), self.device, "neural-forest")
        if first:
            seed = check_random_state(self.random_state).randint(np.iinfo(np.int32).max)
            self._seed = int(seed)
            self._n_calls = 0
            self._start_statistics(X)
            new = announced
            self.history_ = []
        else:
            self._merge_statistics(X)
            new = np.setdiff1d(announced, self.classes_)
        self._n_calls += 1
        rng = np.random.default_rng([self._seed, self._n_calls])
        old_classes = self.classes_ if not first else np.asarray(new[:0])
        self._init_members(new, rng)
        trained = np.searchsorted(self.classes_, np.union1d(present, new))
        recalibrated = np.searchsorted(self.classes_, np.setdiff1d(old_classes, present))
        if not first and self.memory_X_.shape[0]:
            pool_X = np.concatenate([X, self.memory_X_])
            pool_y = np.concatenate([y, self.memory_y_])
        else:
            pool_X, pool_y = X, y
        pool_idx = np.searchsorted(self.classes_, pool_y)
        if len(np.unique(pool_idx)) < 2:  # nothing to tell apart: a forest would learn "always"
            trained = recalibrated = trained[:0]
        else:  # forests that never trained (their first pool had one class) get a full share
            untrained = np.flatnonzero(self.n_updates_ == 0)
            trained = np.union1d(trained, untrained)
            recalibrated = np.setdiff1d(recalibrated, untrained)
        self._train(pool_X, pool_idx, trained, self.n_updates, rng)
        self._train(pool_X, pool_idx, recalibrated, self.n_recalibration_updates, rng)
        self._remember(X, y, rng)
        self.history_.append(self._record(new, X.shape[0], self.classes_[recalibrated], start))
        return self

    def predict_proba(self, X: Any) -> np.ndarray:
        """Each forest's probability of its class, normalised over the classes (rows sum to 1)."""
        check_is_fitted(self)
        X = validate_data(self, X, dtype=np.float64, reset=False)
        xs = (X - self.mean_) / self.scale_
        k, t = self.leaf_logits_.shape[:2]
        idx = self.feature_indices_.reshape(k * t, -1)
        w = self.split_weights_.reshape(k * t, *self.split_weights_.shape[2:])
        b = self.split_biases_.reshape(k * t, -1)
        leaves = 1.0 / (1.0 + np.exp(-self.leaf_logits_.reshape(k * t, -1)))
        out = np.empty((X.shape[0], k))
        row_bytes = 8.0 * k * t * (4 * leaves.shape[-1] + idx.shape[-1])
        chunk = int(max(1, min(_PREDICT_CHUNK, _PREDICT_CHUNK_BYTES // row_bytes)))
        for lo in range(0, X.shape[0], chunk):
            mu = _routing_numpy(xs[lo : lo + chunk], idx, w, b)
            q = (mu * leaves).sum(-1).reshape(mu.shape[0], k, t).mean(-1)
            out[lo : lo + chunk] = np.maximum(q, _PROBA_FLOOR)
        return out / out.sum(axis=1, keepdims=True)

    def predict(self, X: Any) -> np.ndarray:
        """The class whose forest claims the sample most strongly."""
        proba = self.predict_proba(X)
        return self.classes_[np.argmax(proba, axis=1)]

    # -- internals ----------------------------------------------------------------------------

    def _check_params(self) -> None:
        for name in ("n_trees", "depth", "n_updates", "batch_size"):
            value = getattr(self, name)
            if not isinstance(value, int | np.integer) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        for name in ("n_recalibration_updates", "memory_size"):
            value = getattr(self, name)
            if not isinstance(value, int | np.integer) or value < 0:
                raise ValueError(f"{name} must be a non-negative integer, got {value!r}")
        if not 0.0 < float(self.feature_fraction) <= 1.0:
            raise ValueError(f"feature_fraction must be in (0, 1], got {self.feature_fraction!r}")
        if not float(self.learning_rate) > 0.0:
            raise ValueError(f"learning_rate must be positive, got {self.learning_rate!r}")
        if not isinstance(self.whiten, bool | np.bool_):
            raise ValueError(f"whiten must be true or false, got {self.whiten!r}")
        check_device_name(self.device, "neural-forest")

    def memory_estimate(self, n_features: int, n_classes: int) -> float:
        """Bytes the forest would need: its parameters (float64 here; float32 in torch with a
        gradient and Adam's two moments), one training step's routing temporaries kept for
        back-propagation (about six (batch, trees, 2**depth) arrays), and one row of predict
        temporaries. Computed in floats, so depth=40 gives petabytes instead of an overflow."""
        trees = float(n_classes) * self.n_trees
        leaves = 2.0 ** int(self.depth)
        n_subset = max(1, int(round(float(self.feature_fraction) * n_features)))
        per_tree = n_subset * (leaves - 1) + (leaves - 1) + leaves
        parameters = trees * per_tree * (8 + 4 * 4)
        step = float(self.batch_size) * trees * (6 * leaves + n_subset) * 4
        predict_row = trees * (4 * leaves + n_subset) * 8
        whitening = trees * n_subset**2 * (8 * 2 + 4) if self.whiten else 0.0
        return parameters + step + predict_row + whitening

    def _check_size(self, n_features: int, n_classes: int) -> None:
        """Refuse (UsageError) a forest beyond ``torch_support.MEMORY_LIMIT_BYTES`` before any
        allocation."""
        check_memory(
            self.memory_estimate(n_features, n_classes),
            f"neural-forest depth={self.depth}, n_trees={self.n_trees}",
            f"{n_classes} classes x {self.n_trees} trees x 2**{self.depth} leaves, "
            f"{n_features} features",
        )

    def _start_statistics(self, X: np.ndarray) -> None:
        self.n_samples_seen_ = X.shape[0]
        self.mean_ = X.mean(axis=0)
        self.var_ = X.var(axis=0)
        self.scale_ = self._scale(self.var_, self.mean_)

    @staticmethod
    def _scale(var: np.ndarray, mean: np.ndarray) -> np.ndarray:
        """Standard deviation, with 1 for (numerically) constant features."""
        scale = np.sqrt(var)
        return np.where(scale > 1e-10 * np.maximum(1.0, np.abs(mean)), scale, 1.0)

    def _merge_statistics(self, X: np.ndarray) -> None:
        """Merge the batch into the running mean/variance and keep old forests' functions.

        A split computes w . (x - m) / s + b; with new statistics (m', s') the weights
        w' = w s' / s and bias b' = b + w . (m' - m) / s give the same value for every x.
        """
        n_a, n_b = self.n_samples_seen_, X.shape[0]
        n = n_a + n_b
        mean_b, var_b = X.mean(axis=0), X.var(axis=0)
        delta = mean_b - self.mean_
        mean = self.mean_ + delta * n_b / n
        var = (self.var_ * n_a + var_b * n_b + delta**2 * n_a * n_b / n) / n
        scale = self._scale(var, mean)
        idx = self.feature_indices_
        old_s, new_s = self.scale_[idx], scale[idx]
        shift = (mean - self.mean_)[idx] / old_s
        self.split_biases_ = self.split_biases_ + np.einsum(
            "ktfn,ktf->ktn", self.split_weights_, shift
        )
        self.split_weights_ = self.split_weights_ * (new_s / old_s)[..., None]
        self.n_samples_seen_, self.mean_, self.var_, self.scale_ = n, mean, var, scale

    def _init_members(self, classes: np.ndarray, rng: np.random.Generator) -> None:
        """Add a freshly initialised forest for each label in ``classes`` (sorted into place)."""
        if len(classes) == 0 and hasattr(self, "classes_"):
            return
        n_features = self.n_features_in_
        n_subset = max(1, int(round(self.feature_fraction * n_features)))
        n_nodes = 2**self.depth - 1
        k, t = len(classes), self.n_trees
        idx = np.stack([rng.permutation(n_features)[:n_subset] for _ in range(k * t)]).reshape(
            k, t, n_subset
        )
        w = rng.normal(0.0, 1.0 / np.sqrt(n_subset), size=(k, t, n_subset, n_nodes))
        b = rng.normal(0.0, 0.1, size=(k, t, n_nodes))
        leaves = np.zeros((k, t, n_nodes + 1))
        if not hasattr(self, "classes_"):
            self.classes_ = np.asarray(classes)
            self.feature_indices_, self.split_weights_ = idx, w
            self.split_biases_, self.leaf_logits_ = b, leaves
            self.n_updates_ = np.zeros(k, dtype=np.int64)
            return
        merged = np.concatenate([self.classes_, classes])
        order = np.argsort(merged, kind="stable")
        self.classes_ = merged[order]
        self.feature_indices_ = np.concatenate([self.feature_indices_, idx])[order]
        self.split_weights_ = np.concatenate([self.split_weights_, w])[order]
        self.split_biases_ = np.concatenate([self.split_biases_, b])[order]
        self.leaf_logits_ = np.concatenate([self.leaf_logits_, leaves])[order]
        self.n_updates_ = np.concatenate([self.n_updates_, np.zeros(k, np.int64)])[order]

    def _train(
        self,
        X: np.ndarray,
        y_idx: np.ndarray,
        members: np.ndarray,
        n_steps: int,
        rng: np.random.Generator,
    ) -> None:
        """Adam on the forests ``members`` (indices into classes_), batches balanced by class."""
        if len(members) == 0 or n_steps == 0:
            return
        torch = _torch()
        device = torch_device(torch, self.device, "neural-forest")
        counts = np.bincount(y_idx, minlength=len(self.classes_)).astype(np.float64)
        weights = 1.0 / counts[y_idx]
        batches = rng.choice(len(y_idx), size=(n_steps, self.batch_size), p=weights / weights.sum())
        torch_seed = int(rng.integers(np.iinfo(np.int32).max))
        k, t = len(members), self.n_trees

        def param(array: np.ndarray) -> Any:
            flat = array[members].reshape(k * t, *array.shape[2:])
            return torch.tensor(flat, dtype=torch.float32, device=device, requires_grad=True)

        xs_np = (X - self.mean_) / self.scale_
        idx_np = self.feature_indices_[members].reshape(k * t, -1)
        basis = inverse = None
        w_start = self.split_weights_
        if self.whiten:
            basis, inverse = _whitening(xs_np, idx_np)
            # trained splits are re-expressed in whitened coordinates; a fresh forest's random
            # weights are taken as whitened-coordinate weights (its initial scale)
            flat = w_start[members].reshape(k * t, *w_start.shape[2:])
            fresh = np.repeat(self.n_updates_[members] == 0, t)
            flat = np.where(fresh[:, None, None], flat, inverse @ flat)
            w_start = w_start.copy()
            w_start[members] = flat.reshape(k, t, *w_start.shape[2:])
        w, b, leaves = (
            param(w_start),
            param(self.split_biases_),
            param(self.leaf_logits_),
        )
        basis_t = (
            None if basis is None else torch.as_tensor(basis, dtype=torch.float32, device=device)
        )
        idx = torch.as_tensor(idx_np, device=device)
        xs = torch.as_tensor(xs_np, dtype=torch.float32, device=device)
        targets = torch.as_tensor(
            y_idx[:, None] == members[None, :], dtype=torch.float32, device=device
        )
        batches_t = torch.as_tensor(batches, device=device)
        torch.manual_seed(torch_seed)  # Adam itself draws nothing; kept for any backend op
        optimiser = torch.optim.Adam([w, b, leaves], lr=float(self.learning_rate))
        work = self.batch_size * w.numel()
        with _threads_for(torch, work, device):
            self._steps(torch, optimiser, xs, targets, batches_t, idx, w, b, leaves, basis_t)
        with torch.no_grad():
            if basis is not None:  # back to standardised coordinates, in float64
                w = basis @ w.detach().cpu().double().numpy()
                w = torch.as_tensor(w)
            for name, tensor in (
                ("split_weights_", w),
                ("split_biases_", b),
                ("leaf_logits_", leaves),
            ):
                array = getattr(self, name).copy()
                array[members] = (
                    tensor.detach().cpu().double().numpy().reshape(k, t, *array.shape[2:])
                )
                setattr(self, name, array)
        self.n_updates_ = self.n_updates_.copy()
        self.n_updates_[members] += n_steps

    def _steps(
        self,
        torch: Any,
        optimiser: Any,
        xs: Any,
        targets: Any,
        batches: Any,
        idx: Any,
        w: Any,
        b: Any,
        leaves: Any,
        basis: Any,
    ) -> None:
        """The Adam loop: binary cross-entropy of each forest's mixture against "its class";
        each update a progress step (a fit runs for seconds: compare, the demo, sequential)."""
        k = targets.shape[1]
        for step, rows in enumerate(batches):
            tick("neural-forest: training updates", step, len(batches))
            w_eff = w if basis is None else basis @ w
            mu = _routing_torch(torch, xs[rows], idx, w_eff, b, self.depth)
            q = (mu * torch.sigmoid(leaves)).sum(-1).reshape(-1, k, self.n_trees).mean(-1)
            q = q.clamp(_PROBA_FLOOR, 1.0 - _PROBA_FLOOR)
            target = targets[rows]
            loss = -(target * q.log() + (1.0 - target) * (1.0 - q).log()).mean(0).sum()
            optimiser.zero_grad(set_to_none=True)
            loss.backward()
            optimiser.step()

    def _remember(self, X: np.ndarray, y: np.ndarray, rng: np.random.Generator) -> None:
        """Keep at most ``memory_size`` samples, an equal random share per class."""
        if hasattr(self, "memory_X_"):
            X = np.concatenate([self.memory_X_, X])
            y = np.concatenate([self.memory_y_, y])
        labels = np.unique(y)
        quota = self.memory_size // max(1, len(labels))
        keep = [np.sort(rng.permutation(np.flatnonzero(y == label))[:quota]) for label in labels]
        kept = np.concatenate(keep) if keep else np.zeros(0, dtype=np.int64)
        self.memory_X_, self.memory_y_ = X[kept], y[kept]

    def _record(self, added: Any, n_samples: int, recalibrated: Any, start: float) -> dict:
        return {
            "classes_added": list(np.asarray(added).tolist()),
            "classes_recalibrated": list(np.asarray(recalibrated).tolist()),
            "n_samples": int(n_samples),
            "seconds": time.perf_counter() - start,
        }


def per_class_accuracy(estimator: Any, X: Any, y: Any, labels: Sequence[Any] | None = None) -> dict:
    """Recall of each label (fraction of its samples predicted as it): the unit of forgetting.

    Evaluate after every ``partial_fit`` and compare a class's entry before and after an
    addition to get one cell of a disturbance matrix.
    """
    y = np.asarray(y)
    predicted = estimator.predict(X)
    labels = np.unique(y) if labels is None else labels
    return {
        label: float(np.mean(predicted[y == label] == label))
        if np.any(y == label)
        else float("nan")
        for label in labels
    }
