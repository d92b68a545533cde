"""Live identification: feed joint-state messages as they arrive, ask for the shape any time.

::

    from tactile_bullet import Identifier

    ident = Identifier.load("model.npz")
    ident.update(t, msg.name, msg.position, msg.effort)   # per JointState message
    ident.result()  # {"shape", "probabilities", "rotation_deg", "grasp_over", ...}

Names are taken as the hand publishes them (``rh_FFJ3``, coupled ``FFJ0``: see
``realhand/recordings.py``); an optional joint calibration corrects the sensors. Grasps are
cut the way ``segment.segment_by_silence`` cuts a file (one :class:`segment.GraspSegmenter`
fed sample by sample): a grasp starts when the hand's closure rises, and is over once the hand
has held still for ``segment.SETTLE_S``, has opened, or has fallen silent for over
``gap_s`` (seen at the next message), or when the caller says so with :meth:`finish`.

``update`` only maps names, stores the sample and steps the segmenter (tens of
microseconds); ``result`` builds the grasp's record and runs the model (about a millisecond
for signature + svm), and is cached until the next ``update``. ``benchmarks/bench_streaming.py``
measures both.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..errors import UsageError
from ..hand import JOINT_NAMES
from .calibration import Calibration
from .joints import JointMap, closure
from .names import is_hand_message
from .recordings import record_from_samples
from .segment import GAP_S, GraspSegmenter

TRIM_AT = 4096
"""Samples kept before a grasp starts are trimmed once the buffer holds this many; where the
open hand's lowest closure is older than that, it is looked for again among the newest
half (a grasp's start is the lowest closure before it), so an idle hand keeps at most this
many samples (~40 s at 100 Hz)."""
MAX_GRASP_SAMPLES = 60_000
"""A grasp still unsettled after this many samples (10 min at 100 Hz: a hand that never
holds still) is decided as it stands, so the buffer and ``result``'s cost stay bounded."""


def checked_message(
    t: Any, names: Any, positions: Any, efforts: Any
) -> tuple[float, tuple[str, ...], np.ndarray, np.ndarray | None]:
    """A joint-state message's fields as (time, names, positions, efforts or None), or the
    CLI's kind of one-line UsageError: a caller's wrong type must not surface as a bare
    TypeError from deep inside numpy."""
    if isinstance(t, bool) or not isinstance(t, int | float | np.integer | np.floating):
        raise UsageError(f"joint-state time must be a number of seconds, got {t!r}")
    if names is None or isinstance(names, str | bytes) or not isinstance(
        names, Sequence | np.ndarray
    ):
        raise UsageError(f"joint names must be a list of strings, got {names!r}")
    if not all(isinstance(n, str) for n in names):
        bad = next(n for n in names if not isinstance(n, str))
        raise UsageError(f"joint names must be strings, got {bad!r}")
    arrays = []
    for what, values in (("positions", positions), ("efforts", efforts)):
        if values is None or (what == "efforts" and len(values) == 0):
            arrays.append(None)
            continue
        try:
            array = np.asarray(values, dtype=float)
        except (TypeError, ValueError):
            raise UsageError(f"joint {what} must be numbers, got {values!r:.60}") from None
        if array.ndim != 1:
            raise UsageError(
                f"joint {what} must be one list of numbers, got an array of shape {array.shape}"
            )
        arrays.append(array)
    if arrays[0] is None:
        raise UsageError("joint positions must be a list of numbers, got None")
    if arrays[1] is not None and not np.isfinite(arrays[1]).all():
        raise UsageError("joint-state efforts hold NaN or infinity")
    return float(t), tuple(names), arrays[0], arrays[1]


def _of_type(value: Any, kinds: tuple, name: str, wanted: str) -> None:
    """A UsageError naming ``name`` where ``value`` is none of ``kinds`` (bytes is no path)."""
    if isinstance(value, bytes) or not isinstance(value, kinds):
        raise UsageError(f"Identifier {name} must be {wanted}, got {type(value).__name__}")


class Identifier:
    """Streaming shape identification with a trained model (see the module docstring)."""

    def __init__(
        self, model, calibration: Calibration | None = None, gap_s: float = GAP_S,
        cross_check: bool = True, hand_calibration=None,
    ) -> None:  # fmt: skip
        from ..learn.models import Model
        from ..perception.shape_model import Calibration as ShapeFitCalibration

        _of_type(model, (Model,), "model", "a Model (Identifier.load reads a file)")
        _of_type(calibration, (Calibration, type(None)), "calibration", "a Calibration or None")
        _of_type(hand_calibration, (ShapeFitCalibration, type(None)), "hand_calibration",
                 "shape-fit coefficients or None (Identifier.load reads a file)")  # fmt: skip
        _of_type(cross_check, (bool,), "cross_check", "True or False")
        self.model = model
        self.calibration = calibration
        self.hand_calibration = hand_calibration
        """The shape fit's coefficients for this hand (``shape_model.Calibration``, from
        ``tactile-bullet calibrate``; None: the shipped ones), used by every shape fit this
        identifier runs (a shape-fit model, the cross-check)."""
        self.cross_check = cross_check
        """Whether the answer at a grasp's end asks the model's second opinion: its second
        svm for the shipped default, the shape fit where a trained model's calibration wants
        it (``learn/doubt.py``; ~60 ms), its nearest known grasp for ``train --known``'s;
        False: the margin only."""
        self._segmenter = GraspSegmenter(gap_s)
        self._maps: dict[tuple[str, ...], JointMap | None] = {}
        self._map: JointMap | None = None
        self._names: tuple[str, ...] | None = None
        self._hand: str | None = None  # the prefix of the first hand message
        self._classes = [str(c) for c in model.classes]
        self.reset()

    @classmethod
    def load(
        cls,
        model: str | os.PathLike | Any = None,
        calibration: str | os.PathLike | Calibration | None = None,
        gap_s: float = GAP_S,
        cross_check: bool = True,
        hand_calibration: str | os.PathLike | Any = None,
    ) -> Identifier:
        """An identifier for a saved model file (or a loaded Model; None or ``"default"``:
        the built-in default identifier, docs/robustness.md); ``calibration`` a TOML
        path or a :class:`Calibration`; ``cross_check`` as in the constructor;
        ``hand_calibration`` the file ``tactile-bullet calibrate`` wrote (or its loaded
        coefficients)."""
        from ..learn.models import Model
        from ..perception.shape_model import Calibration as ShapeFitCalibration
        from .calibration import load_calibration
        from .hand_calibration import HandCalibration
        from .hand_calibration import load as load_hand

        _of_type(model, (str, os.PathLike, Model, type(None)), "model",
                 "a model file path, a Model or None (the default identifier)")
        _of_type(calibration, (str, os.PathLike, Calibration, type(None)), "calibration",
                 "a calibration file path, a Calibration or None")  # fmt: skip
        _of_type(hand_calibration, (str, os.PathLike, HandCalibration, ShapeFitCalibration,
                                    type(None)), "hand_calibration",
                 "the path of a file calibrate wrote, its coefficients or None")  # fmt: skip
        if isinstance(hand_calibration, HandCalibration):
            hand_calibration = hand_calibration.calibration
        if isinstance(hand_calibration, str | os.PathLike):
            hand_calibration = load_hand(hand_calibration).calibration
        if model is None or isinstance(model, str | os.PathLike):
            from ..learn.default import resolve_model

            model = resolve_model(model)
        if isinstance(calibration, str | os.PathLike):
            calibration = load_calibration(calibration)
        return cls(model, calibration, gap_s, cross_check, hand_calibration)

    def reset(self) -> None:
        """Forget every sample and grasp (a new session)."""
        self._segmenter.reset()
        self._t: list[float] = []
        self._q: list[np.ndarray] = []
        self._e: list[np.ndarray] = []
        self._offset = 0  # global index of the buffer's first sample
        self._count = 0
        self._no_efforts = False
        self._done: tuple[np.ndarray, np.ndarray, np.ndarray, bool] | None = None
        self._cache: dict[str, Any] | None = None

    # --- input ------------------------------------------------------------------------------

    def _joint_map(self, names: Sequence[str]) -> JointMap | None:
        """The map of a name list (cached); None for another robot's message."""
        key = names if isinstance(names, tuple) else tuple(names)
        if key != self._names:
            if key in self._maps:
                jmap = self._maps[key]
            elif is_hand_message(key):
                jmap = self._maps[key] = JointMap(key, self.calibration, "joint state")
            else:
                jmap = self._maps[key] = None
            if jmap is None:
                return None
            self._map, self._names = jmap, key
        return self._map

    def update(
        self,
        t: float,
        names: Sequence[str],
        positions: Sequence[float],
        efforts: Sequence[float] | None = None,
    ) -> None:
        """One joint-state message: time ``t`` (s, any origin), published ``names``,
        ``positions`` (rad) and optionally ``efforts`` (N m, same order; empty or None when
        the hand publishes none). A message naming no Shadow joint (an arm sharing the
        topic) is ignored."""
        t, names, raw, efforts = checked_message(t, names, positions, efforts)
        jmap = self._joint_map(names)
        if jmap is None:
            return
        if self._hand is None:
            self._hand = jmap.prefix
        elif jmap.prefix != self._hand:
            raise UsageError(
                f"joint state of hand prefix {jmap.prefix or '(none)'!r} after "
                f"{self._hand or '(none)'!r}: one hand per Identifier"
            )
        if raw.shape != (len(jmap.names),):
            raise UsageError(f"{len(jmap.names)} joint names but {raw.size} positions")
        if not (math.isfinite(t) and np.isfinite(raw).all()):
            raise UsageError("joint state holds NaN or infinity")
        if self._t and t <= self._t[-1]:
            raise UsageError(f"joint-state time went backwards ({self._t[-1]} s then {t} s)")
        q = jmap.positions(raw, t)
        if efforts is None:
            e = np.zeros(len(JOINT_NAMES))
            self._no_efforts = True
        elif len(efforts) != len(jmap.names):
            raise UsageError(f"{len(jmap.names)} joint names but {len(efforts)} efforts")
        else:
            e = jmap.efforts(efforts)
        seg = self._segmenter
        c = float(closure(q))
        if seg.closing and seg.settled:
            # held: the last sample follows the hand instead of the buffer growing for as
            # long as the object is held (result() stays as fast as at the grasp's end)
            index = self._offset + len(self._t) - 1
            self._t[-1], self._q[-1], self._e[-1] = t, q, e
        else:
            index = self._offset + len(self._t)
            self._t.append(t)
            self._q.append(q)
            self._e.append(e)
        self._count += 1
        self._cache = None
        done = seg.push(index, t, c)
        if done is not None:
            self._keep(done)
        if seg.closing and index - seg.start >= MAX_GRASP_SAMPLES:
            self.finish()
            seg._open_at(index, c)
        if not seg.closing and len(self._t) > TRIM_AT:
            self._trim(seg.i_min)
            if len(self._t) > TRIM_AT:  # the lowest closure is old: look again, newest half
                half = TRIM_AT // 2
                levels = closure(np.array(self._q[-half:]))
                k = int(np.argmin(levels))
                seg.c_min, seg.i_min = float(levels[k]), self._offset + len(self._t) - half + k
                self._trim(seg.i_min)

    def finish(self) -> None:
        """The caller knows the grasp is over (end of a replay, a marker): close it now."""
        done = self._segmenter.finish()
        if done is not None:
            self._keep(done)
            self._cache = None

    def _keep(self, span: tuple[int, int]) -> None:
        lo, hi = span[0] - self._offset, span[1] - self._offset + 1
        self._done = (
            np.array(self._t[lo:hi]),
            np.array(self._q[lo:hi]),
            np.array(self._e[lo:hi]),
            self._no_efforts,
        )

    def _trim(self, keep_from: int) -> None:
        cut = max(0, keep_from - self._offset)
        del self._t[:cut], self._q[:cut], self._e[:cut]
        self._offset += cut

    # --- output -----------------------------------------------------------------------------

    @property
    def samples(self) -> int:
        """Messages received since the last reset."""
        return self._count

    def current_record(self):
        """The grasp the answer is about, as a recorded GraspRecord (None before any)."""
        seg = self._segmenter
        if seg.closing:
            lo = seg.start - self._offset
            return record_from_samples(
                np.array(self._t[lo:]),
                np.array(self._q[lo:]),
                np.array(self._e[lo:]),
                has_efforts=not self._no_efforts,
            )
        if self._done is not None:
            t, q, e, no_eff = self._done
            return record_from_samples(t, q, e, has_efforts=not no_eff)
        return None

    def result(self) -> dict[str, Any]:
        """``shape`` (None until the grasp is over), ``probabilities`` (of the grasp so far),
        ``margin``, ``ambiguous``, ``cross_check``, ``unknown`` and ``novelty`` (as in
        ``workflow.identify``; None until the grasp is over: the shape fit's cross-check adds
        ~60 ms then), ``rotation_deg``
        (calibrated object rotation, None where unknown), ``grasp_over``,
        and ``samples`` (messages in the grasp)."""
        if self._cache is None:
            from ..perception.shape_model import use_calibration

            with use_calibration(self.hand_calibration):
                self._cache = self._result()
        return self._cache

    def _result(self) -> dict[str, Any]:
        from ..learn.doubt import no_doubt

        seg = self._segmenter
        record = self.current_record()
        if record is None:
            doc = {"shape": None, "probabilities": {}, **no_doubt(), "rotation_deg": None,
                   "grasp_over": False, "samples": 0}  # fmt: skip
        else:
            over = not seg.closing or seg.settled
            answer, probabilities = self._predict(record, decide=over)
            doubt = no_doubt()
            if over and answer is not None:
                from ..learn.doubt import doubts

                (instead,) = self.model.contact_names([record], [answer])  # as Model.answers
                was, answer = (answer, instead) if instead else (None, answer)
                proba = np.array([[probabilities[c] for c in self._classes]])
                (doubt,) = doubts(self.model, [record], [answer], proba, self.cross_check,
                                  renamed_from=[was])  # fmt: skip
            doc = {
                "shape": answer if over else None,
                "probabilities": probabilities,
                **doubt,
                "rotation_deg": _rotation(record, answer) if over else None,
                "grasp_over": over,
                "samples": int(record.time.size),
            }
        return doc

    def _predict(self, record, decide: bool) -> tuple[str | None, dict[str, float]]:
        """(the estimator's own decision when ``decide``, else None; probabilities). The
        decision is asked for separately because it can differ from the probabilities'
        argmax (an SVM with Platt scaling); a grasp still closing skips it."""
        features = self.model.features([record])
        estimator = self.model.estimator
        shape = str(np.asarray(estimator.predict(features))[0]) if decide else None
        try:
            proba = np.asarray(estimator.predict_proba(features), dtype=float)[0]
        except (AttributeError, NotImplementedError):
            shape = shape or str(np.asarray(estimator.predict(features))[0])
            return shape, {c: float(c == shape) for c in self._classes}
        return shape, {c: float(p) for c, p in zip(self._classes, proba, strict=True)}


def _rotation(record, shape: str) -> float | None:
    """Calibrated object rotation (deg) from the signature's slope, with ``shape``'s own
    line; None where the packaged calibration has none. Only the raw lines' end points are
    needed, so the enhancement is skipped."""
    from types import SimpleNamespace

    from ..perception.rotation import alpha_of, estimate_rotation_deg, load_calibration
    from ..perception.signature import end_point_angle, fci, raw_signature

    cal = load_calibration()
    if cal is None:
        return None
    try:
        lower, upper = raw_signature(fci(record.fci_angles()))
    except UsageError:
        return None
    a_lo, a_up = end_point_angle(lower), end_point_angle(upper)
    alphas = SimpleNamespace(alpha_lower=a_lo, alpha_upper=a_up, alpha_deg=0.5 * (a_lo + a_up))
    return estimate_rotation_deg(alpha_of(alphas, cal.line), cal, shape)
