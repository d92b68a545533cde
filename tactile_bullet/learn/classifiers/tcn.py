"""``tcn``: a small temporal convolutional network over the ``time-series`` descriptor.

A row of ``time-series`` features is ``channels x length`` values (channel-major); the network
reads it as a multichannel signal: ``n_layers`` 1D convolutions (``width`` filters of
``kernel_size`` taps, dilation 1, 2, 4, ... so the last layer sees most of the grasp, ReLU,
residual from the second layer on), then the time-mean and the last instant of the last layer
(the grasp's course and its end state, which alone carries the final configuration) into a
linear layer over the classes (softmax). Inputs are standardised per channel.

Trained with Adam on cross-entropy in seeded mini-batches on torch; weights are initialised in
numpy from the seed, so the same data and ``random_state`` give the same model. Prediction runs
in numpy (a few small matrix products), so identifying a grasp and loading a saved model need
no torch. Saved through ``to_state``/``from_state`` (``learn/models.py``: JSON + arrays, no pickle).

``length`` must equal the descriptor's ``length`` (both default to 32): change them together
(``--descriptor-param length=64 --param length=64``). ``length=1`` reads each feature as a
channel of one instant, which makes the network a small MLP on any feature vector.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils import check_random_state
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

from ...errors import UsageError
from ..time_series import TIME_SERIES_LENGTH
from ..torch_support import (
    check_device_name,
    check_memory,
    import_torch,
    torch_device,
    torch_threads,
)

_TRAIN_THREADS = 1
"""torch threads while training on the CPU. The network is tiny (a 32 x 34 x 32 batch): on the
2-core development machine one thread fitted the demo set in about the same time as two, and a
fixed count keeps the floating-point reduction order, so the same seed gives the same model on
any machine."""


def _relu(x: np.ndarray) -> np.ndarray:
    return np.maximum(x, 0.0)


def _conv1d_numpy(x: np.ndarray, w: np.ndarray, b: np.ndarray, dilation: int) -> np.ndarray:
    """'Same' 1D convolution (cross-correlation, as torch's conv1d): (B, I, L) -> (B, O, L)."""
    k = w.shape[2]
    pad = dilation * (k - 1) // 2
    length = x.shape[2]
    xp = np.pad(x, ((0, 0), (0, 0), (pad, pad)))
    cols = np.stack([xp[:, :, j * dilation : j * dilation + length] for j in range(k)], axis=-1)
    out = np.tensordot(cols, w, axes=([1, 3], [1, 2]))  # (B, L, O)
    return out.transpose(0, 2, 1) + b[None, :, None]


def _logits_torch(
    torch: Any, h: Any, conv_w: list, conv_b: list, head_w: Any, head_b: Any, kernel_size: int
) -> Any:
    """The network in torch (training): the same function as ``TCNClassifier._logits``."""
    functional = torch.nn.functional
    for layer, (w, b) in enumerate(zip(conv_w, conv_b, strict=True)):
        dilation = 2**layer
        pad = dilation * (kernel_size - 1) // 2
        out = torch.relu(functional.conv1d(h, w, b, padding=pad, dilation=dilation))
        h = out + h if layer > 0 else out
    pooled = torch.cat((h.mean(dim=2), h[:, :, -1]), dim=1)
    return pooled @ head_w.T + head_b


class TCNClassifier(ClassifierMixin, BaseEstimator):
    """Dilated 1D CNN on multichannel series; scikit-learn estimator, seeded, saved without
    pickle.

    Parameters
    ----------
    length : int
        Instants per channel in a feature row (the ``time-series`` descriptor's ``length``).
    width : int
        Filters per convolution layer.
    kernel_size : int
        Taps per filter (odd, so the output stays centred).
    n_layers : int
        Convolution layers; layer i has dilation 2**i.
    epochs : int
        Passes over the training set.
    batch_size : int
        Samples per Adam step (shuffled each epoch).
    learning_rate : float
        Adam step size.
    weight_decay : float
        L2 penalty (Adam's ``weight_decay``).
    device : str
        Torch device for training ("cpu", "cuda"); prediction runs in numpy.
    random_state : int, RandomState instance or None
        Seeds the initial weights and the batch order (0 by default, like the other built-ins).

    Attributes
    ----------
    classes_, n_features_in_, n_channels_ (input channels), mean_, scale_ (per channel),
    conv_weights_, conv_biases_ (lists, one array per layer), head_weight_, head_bias_,
    loss_curve_ (mean training loss per epoch), fit_time_s_.
    """

    required_descriptor = "time-series"
    accepted_descriptors = ("coupled-time-series",)
    """Same channels and layout: J2 and J1 both carry J0 / 2 (``learn/coupled.py``)."""

    def __init__(
        self,
        length: int = TIME_SERIES_LENGTH,
        width: int = 32,
        kernel_size: int = 5,
        n_layers: int = 3,
        epochs: int = 150,
        batch_size: int = 32,
        learning_rate: float = 0.003,
        weight_decay: float = 0.0001,
        device: str = "cpu",
        random_state: int | np.random.RandomState | None = 0,
    ) -> None:
        self.length = length
        self.width = width
        self.kernel_size = kernel_size
        self.n_layers = n_layers
        self.epochs = epochs
        self.batch_size = batch_size
        self.learning_rate = learning_rate
        self.weight_decay = weight_decay
        self.device = device
        self.random_state = random_state

    # -- checks -------------------------------------------------------------------------------

    def _check_params(self) -> None:
        limits = {
            "length": (1, 4096),
            "width": (1, 1024),
            "kernel_size": (1, 63),
            "n_layers": (1, 12),
            "epochs": (1, 100_000),
            "batch_size": (1, 65_536),
        }
        for name, (low, high) in limits.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer):
                raise UsageError(f"tcn {name} must be an integer, got {value!r}")
            if not low <= value <= high:
                raise UsageError(f"tcn {name} must be from {low} to {high}, got {value}")
        if self.kernel_size % 2 == 0:
            raise UsageError(f"tcn kernel_size must be odd, got {self.kernel_size}")
        for name in ("learning_rate", "weight_decay"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float | np.number):
                raise UsageError(f"tcn {name} must be a number, got {value!r}")
            if not np.isfinite(value) or value < 0 or (name == "learning_rate" and value == 0):
                raise UsageError(f"tcn {name} must be a finite number > 0, got {value!r}")
        check_device_name(self.device, "tcn")

    def _channels_of(self, n_features: int) -> int:
        if n_features % self.length:
            raise UsageError(
                f"tcn length={self.length} does not divide the {n_features} features: set it "
                "to the time-series descriptor's length"
            )
        return n_features // self.length

    def _memory_estimate(self, n_samples: int, n_channels: int, n_classes: int) -> float:
        """Bytes: parameters x 4 (weights, gradient, Adam's two moments) in float32, plus one
        step's activations (kept for back-propagation) and the unfolded input of a layer."""
        w, k, L = self.width, self.kernel_size, self.length
        n_params = n_channels * w * k + (self.n_layers - 1) * w * w * k + 2 * w * n_classes
        batch = min(self.batch_size, n_samples)
        activations = batch * L * (n_channels + 3 * w * self.n_layers) + batch * L * k * max(
            n_channels, w
        )
        data = n_samples * n_channels * L
        return 4.0 * (4 * n_params + 2 * activations + data)

    # -- fitting ------------------------------------------------------------------------------

    def _reshape(self, X: np.ndarray) -> np.ndarray:
        return X.reshape(X.shape[0], self.n_channels_, self.length)

    def _init_weights(self, n_channels: int, n_classes: int, rng: np.random.Generator) -> None:
        """He-normal convolutions, small head, zero biases (numpy, so the seed alone decides)."""
        weights, biases = [], []
        inputs = n_channels
        for _ in range(self.n_layers):
            fan_in = inputs * self.kernel_size
            weights.append(
                rng.normal(0.0, np.sqrt(2.0 / fan_in), (self.width, inputs, self.kernel_size))
            )
            biases.append(np.zeros(self.width))
            inputs = self.width
        self.conv_weights_, self.conv_biases_ = weights, biases
        self.head_weight_ = rng.normal(
            0.0, np.sqrt(1.0 / (2 * self.width)), (n_classes, 2 * self.width)
        )
        self.head_bias_ = np.zeros(n_classes)

    def fit(self, X: Any, y: Any) -> TCNClassifier:
        """Train on (n, channels * length) rows; ``y`` any labels (at least two classes)."""
        self._check_params()
        X, y = validate_data(self, X, y, dtype=np.float64)
        check_classification_targets(y)
        start = time.perf_counter()
        n_channels = self._channels_of(X.shape[1])
        classes, y_idx = np.unique(y, return_inverse=True)
        if len(classes) < 2:
            raise ValueError(f"tcn needs at least 2 classes; the data holds {len(classes)} class")
        check_memory(
            self._memory_estimate(X.shape[0], n_channels, len(classes)),
            f"tcn (width={self.width}, n_layers={self.n_layers}, length={self.length})",
            f"{X.shape[0]} samples x {n_channels} channels",
        )
        torch = import_torch()
        device = torch_device(torch, self.device, "tcn")
        seed = int(check_random_state(self.random_state).randint(np.iinfo(np.int32).max))
        rng = np.random.default_rng(seed)
        self.classes_ = classes
        self.n_channels_ = n_channels
        series = self._reshape(X)
        self.mean_ = series.mean(axis=(0, 2))
        std = series.std(axis=(0, 2))
        self.scale_ = np.where(std > 1e-12 * np.maximum(1.0, np.abs(self.mean_)), std, 1.0)
        self._init_weights(n_channels, len(classes), rng)
        order = np.stack([rng.permutation(X.shape[0]) for _ in range(self.epochs)])
        threads = _TRAIN_THREADS if device.type == "cpu" else None
        with torch_threads(torch, threads):
            self._train(torch, device, self._standardise(series), y_idx, order)
        self.fit_time_s_ = time.perf_counter() - start
        return self

    def _standardise(self, series: np.ndarray) -> np.ndarray:
        return (series - self.mean_[None, :, None]) / self.scale_[None, :, None]

    def _train(
        self, torch: Any, device: Any, xs: np.ndarray, y_idx: np.ndarray, order: np.ndarray
    ) -> None:
        functional = torch.nn.functional

        def tensor(a: np.ndarray, grad: bool = True) -> Any:
            return torch.tensor(a, dtype=torch.float32, device=device, requires_grad=grad)

        conv_w = [tensor(w) for w in self.conv_weights_]
        conv_b = [tensor(b) for b in self.conv_biases_]
        head_w, head_b = tensor(self.head_weight_), tensor(self.head_bias_)
        params = [*conv_w, *conv_b, head_w, head_b]
        optimiser = torch.optim.Adam(
            params, lr=float(self.learning_rate), weight_decay=float(self.weight_decay)
        )
        data = tensor(xs, grad=False)
        targets = torch.as_tensor(y_idx, dtype=torch.long, device=device)
        n = xs.shape[0]
        batch = min(int(self.batch_size), n)
        from ...console import tick

        curve = []
        for epoch, epoch_order in enumerate(order):
            tick("tcn training epochs", epoch, len(order))
            total = 0.0
            for lo in range(0, n, batch):
                rows = torch.as_tensor(epoch_order[lo : lo + batch], device=device)
                logits = _logits_torch(
                    torch, data[rows], conv_w, conv_b, head_w, head_b, self.kernel_size
                )
                loss = functional.cross_entropy(logits, targets[rows])
                optimiser.zero_grad(set_to_none=True)
                loss.backward()
                optimiser.step()
                total += float(loss.detach()) * len(rows)
            curve.append(total / n)
        self.loss_curve_ = np.asarray(curve)

        def back(t: Any) -> np.ndarray:
            return t.detach().cpu().double().numpy()

        self.conv_weights_ = [back(w) for w in conv_w]
        self.conv_biases_ = [back(b) for b in conv_b]
        self.head_weight_, self.head_bias_ = back(head_w), back(head_b)

    # -- prediction (numpy) -------------------------------------------------------------------

    def _logits(self, X: np.ndarray) -> np.ndarray:
        h = self._standardise(self._reshape(X))
        for layer, (w, b) in enumerate(zip(self.conv_weights_, self.conv_biases_, strict=True)):
            out = _relu(_conv1d_numpy(h, w, b, 2**layer))
            h = out + h if layer > 0 else out
        pooled = np.concatenate((h.mean(axis=2), h[:, :, -1]), axis=1)
        return pooled @ self.head_weight_.T + self.head_bias_

    def predict_proba(self, X: Any) -> np.ndarray:
        """Softmax of the network's class scores; columns follow ``classes_``."""
        check_is_fitted(self)
        X = validate_data(self, X, dtype=np.float64, reset=False)
        logits = self._logits(X)
        logits -= logits.max(axis=1, keepdims=True)
        e = np.exp(logits)
        return e / e.sum(axis=1, keepdims=True)

    def predict(self, X: Any) -> np.ndarray:
        """The most probable class."""
        proba = self.predict_proba(X)
        return self.classes_[np.argmax(proba, axis=1)]

    # -- saving (learn/models.py's state protocol) -------------------------------------------

    def to_state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """Parameters as JSON, fitted weights as numeric arrays (no pickle)."""
        check_is_fitted(self)
        classes = np.asarray(self.classes_)
        if classes.dtype.kind not in "biuU":
            classes = classes.astype(str)
        arrays = {
            "classes": classes,
            "mean": self.mean_,
            "scale": self.scale_,
            "head_weight": self.head_weight_,
            "head_bias": self.head_bias_,
            "loss_curve": self.loss_curve_,
        }
        for i, (w, b) in enumerate(zip(self.conv_weights_, self.conv_biases_, strict=True)):
            arrays[f"conv{i}_weight"], arrays[f"conv{i}_bias"] = w, b
        params = self.get_params(deep=False)
        if not isinstance(params["random_state"], int | type(None)):
            params["random_state"] = None
        state = {
            "params": params,
            "n_features_in": int(self.n_features_in_),
            "n_channels": int(self.n_channels_),
            "fit_time_s": float(self.fit_time_s_),
        }
        return state, arrays

    @classmethod
    def from_state(cls, state: dict, arrays: dict[str, np.ndarray]) -> TCNClassifier:
        """Rebuild a fitted estimator from ``to_state``'s output, checking every shape."""
        est = cls(**state["params"])
        est._check_params()
        n_features, n_channels = int(state["n_features_in"]), int(state["n_channels"])
        if n_features != n_channels * est.length:
            raise ValueError("n_features_in does not match channels x length")
        est.classes_ = np.asarray(arrays["classes"])
        est.n_features_in_, est.n_channels_ = n_features, n_channels
        est.mean_ = np.asarray(arrays["mean"], dtype=float)
        est.scale_ = np.asarray(arrays["scale"], dtype=float)
        est.conv_weights_, est.conv_biases_ = [], []
        inputs = n_channels
        for i in range(est.n_layers):
            w = np.asarray(arrays[f"conv{i}_weight"], dtype=float)
            b = np.asarray(arrays[f"conv{i}_bias"], dtype=float)
            if w.shape != (est.width, inputs, est.kernel_size) or b.shape != (est.width,):
                raise ValueError(f"layer {i} has weights of shape {w.shape}")
            est.conv_weights_.append(w)
            est.conv_biases_.append(b)
            inputs = est.width
        est.head_weight_ = np.asarray(arrays["head_weight"], dtype=float)
        est.head_bias_ = np.asarray(arrays["head_bias"], dtype=float)
        k = len(est.classes_)
        if est.head_weight_.shape != (k, 2 * est.width) or est.head_bias_.shape != (k,):
            raise ValueError("the output layer does not match the classes")
        if est.mean_.shape != (n_channels,) or est.scale_.shape != (n_channels,):
            raise ValueError("standardisation statistics do not match the channels")
        est.loss_curve_ = np.asarray(arrays.get("loss_curve", np.zeros(0)), dtype=float)
        est.fit_time_s_ = float(state.get("fit_time_s", 0.0))
        return est
