"""Named train/test recipes over simulated grasps: what the benchmark ranks methods on.

The demo's held-out split (``in-distribution``) is saturated: raw joint angles score 100% on it,
so it cannot tell which descriptor generalises. Each other protocol moves the test grasps away
from the training ones along one axis a deployed system meets:

- ``unseen-sizes``: train on the middle of every size range, test at both ends (extrapolation);
- ``unseen-poses``: train within 3 mm of the grasp centre, unrotated; test at the outer offsets
  (+-10 mm along O-O' and along the fingers) and at rotations of 5-25 deg;
- ``sensor-noise``: train clean; test on the in-distribution test grasps read through a
  :class:`~tactile_bullet.learn.perturb.SensorModel` (joint noise, per-joint calibration bias,
  effort noise). Headline: sigma 1 deg with bias 3 deg;
- ``sim-shift``: train at default physics; test on grasps drawn by the in-distribution test
  recipe (sizes and offsets, a seed of their own) simulated with other friction, torque
  threshold, closing speed or phalanx lengths (another hand of the same model: the reality
  gap's stand-in). Headline: every knob shifted by +-20% (friction 0.8 +- 20%, thresT and
  closing speed +-20%, phalanges +-2%), the same grasps once up, once down. The up and down
  sets of a level share their specs, as do the single-knob sets, so those compare grasp for
  grasp; the unshifted level is the in-distribution test set (other draws, 60 grasps);
- ``coupling-shift``: train at default physics; test on the in-distribution test grasps (the
  same specs) made with another J1/J2 tendon rule (``sim/coupling.py``: equal torque, distal
  first): a stand-in for another engine's or a real hand's tendon.

Each protocol's training set also exists randomised (:func:`randomized_name`: the same specs
with ``datasets.randomize.randomized_table`` of the set's engine drawn per grasp), read by the
benchmark's ``randomized`` training.

Two more compare physics engines (``sim/engines/``) and run only when named (``all`` keeps to
the five above, which need no optional package):

- ``cross-engine``: train on one engine, test on the other, both ways: ``bullet->mujoco`` (the
  headline) and ``mujoco->bullet``. The two engines' sets share their draws (same seeds), so
  they are the same grasps simulated twice;
- ``mixed-engine``: train on both engines' training sets together, test on each engine's.

A protocol names datasets (:class:`SetSpec`: a random-mode sweep and a seed) rather than holding
records, so the benchmark simulates each set once through the dataset layer (sharded, resumable)
and every protocol sharing it reads the same grasps. ``quick`` recipes simulate ~200 grasps in
all; the full ones ~1,000.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

from ..datasets.randomize import Randomization, engine_reads, randomized_table
from ..datasets.sweeps import ShapeSweep, Sweep
from ..errors import UsageError
from ..learn.perturb import SensorModel
from ..records import ControllerSettings

SHAPES: tuple[str, ...] = ("cone", "torus", "sphere", "hyperboloid", "cylinder")
"""The thesis' five test shapes, the classes of every protocol."""

TRAIN_FRACTIONS = (0.0, 0.25, 0.5, 0.75, 1.0)
TEST_FRACTIONS = (0.125, 0.375, 0.625, 0.875)
MIDDLE_FRACTIONS = (0.375, 0.5, 0.625)
END_FRACTIONS = (0.0, 0.0625, 0.9375, 1.0)
"""Relative sizes in each parameter's valid range: the demo's (train, test) and the
unseen-sizes split (middle, ends)."""

TRAIN_X, TRAIN_Z = (-0.010, 0.0, 0.010), (-0.005, 0.005)
TEST_X, TEST_Z = (-0.005, 0.0, 0.005), (0.0, 0.0025)
"""Offsets (m) along O-O' and along the fingers: the demo's training and test grids."""
CENTRE = (-0.003, 0.0, 0.003)
OUTER = (-0.010, 0.010)
OUTER_Z = (-0.010, 0.0, 0.010)
ROTATIONS_DEG = (5.0, 10.0, 15.0, 20.0, 25.0)

SHIFT_HEADLINE = 0.2


@dataclass(frozen=True)
class SetSpec:
    """One simulated set: ``per_shape`` grasps of each shape drawn from size fractions and
    offset/rotation lists, at ``controller`` physics, with a seed of its own."""

    name: str
    per_shape: int
    fractions: tuple[float, ...]
    offset_x: tuple[float, ...]
    offset_z: tuple[float, ...]
    rotation_deg: tuple[float, ...] = (0.0,)
    controller: ControllerSettings = field(default_factory=ControllerSettings)
    seed: int = 0
    extra: tuple[SetSpec, ...] = ()
    """More sets simulated into the same dataset (unseen-poses: offsets, then rotations)."""
    randomize: Randomization | None = None
    """Hand and physics drawn per grasp (the randomised training sets)."""

    def sweep(self) -> Sweep:
        """The random-mode sweep the dataset layer simulates for this set."""
        from ..objects.shapes import BUILTIN_SHAPES

        table = {s.name: s for s in BUILTIN_SHAPES}
        shapes = []
        for part in (self, *self.extra):
            for name in SHAPES:
                spec = table[name]
                params = {
                    k: tuple(round(p.min + f * (p.max - p.min), 6) for f in part.fractions)
                    for k, p in spec.params.items()
                }
                shapes.append(
                    ShapeSweep(
                        name,
                        params,
                        offset_x=part.offset_x,
                        offset_z=part.offset_z,
                        rotation_deg=part.rotation_deg,
                        samples=part.per_shape,
                    )
                )
        return Sweep(self.name, tuple(shapes), mode="random", controller=self.controller,
                     randomize=self.randomize)  # fmt: skip


@dataclass(frozen=True)
class Level:
    """One test condition of a protocol: the union of the ``test`` sets, read through
    ``sensor``; ``x`` its place on the protocol's curve (noise in deg, shift in %)."""

    name: str
    test: tuple[str, ...]
    sensor: SensorModel = field(default_factory=SensorModel)
    x: float | None = None
    headline: bool = False
    series: str | None = None
    """Which curve of the protocol's figure the level belongs to (None: on none)."""
    train: str | None = None
    """The training set of this level when it is not the protocol's (cross-engine's reverse)."""


@dataclass(frozen=True)
class Protocol:
    name: str
    description: str
    train: str
    levels: tuple[Level, ...]
    curve: str | None = None
    """x-axis label of the protocol's accuracy curves (None: a single level, no curve)."""

    @property
    def headline(self) -> Level:
        return next(level for level in self.levels if level.headline)


def shifted(base: ControllerSettings, s: float) -> ControllerSettings:
    """Every physics knob moved by the fraction ``s`` (signed): friction, thresT and closing
    speed by ``s``, phalanx lengths by ``s / 10`` (+-3% at +-30%)."""
    return replace(
        base,
        friction=round(base.friction * (1 + s), 6),
        thres_t=round(base.thres_t * (1 + s), 6),
        delta=round(base.delta * (1 + s), 6),
        phalanx_scale=round(base.phalanx_scale * (1 + s / 10), 6),
    )


SCALES: dict[str, tuple[int, int, int]] = {"full": (24, 12, 4), "quick": (8, 4, 2),
                                           "tiny": (5, 2, 1)}  # fmt: skip
"""Grasps per shape (train, test, shift-test) of each scale: ``full`` the benchmark's, ``quick``
its 2-minute form, ``tiny`` the pytest comparison suite's (``testing.py``)."""


def scale_of(quick: bool | str) -> str:
    """``True``/``False`` (the --quick flag) or a scale name -> the scale name."""
    if isinstance(quick, str):
        if quick not in SCALES:
            raise UsageError(f"unknown scale {quick!r} (known: {', '.join(SCALES)})")
        return quick
    return "quick" if quick else "full"


ENGINES: tuple[str, ...] = ("bullet", "mujoco")
"""The engines the cross-engine and mixed-engine protocols compare."""


def set_tag(scale: str, engine: str = "bullet") -> str:
    """The prefix of a set's name: its scale (none for full) and engine (none for bullet), so
    every scale and engine can share one cache folder."""
    return ("" if scale == "full" else f"{scale}-") + ("" if engine == "bullet" else f"{engine}-")


def train_sets(train: str) -> list[str]:
    """The sets a training name joins ('a+b': both, in order)."""
    return train.split("+")


def sets(quick: bool | str = False, engine: str = "bullet") -> dict[str, SetSpec]:
    """Every set the protocols read, by name, simulated with ``engine`` (each scale's and
    engine's names are distinct, so all can share one cache folder); plus every engine's
    demo sets, which the cross-engine protocols read."""
    scale = scale_of(quick)
    out = _sets(scale, engine)
    for other in ENGINES:
        if other != engine:
            out += [s for s in _sets(scale, other) if "demo-" in s.name]
    return {s.name: s for s in out}


def _sets(scale: str, engine: str) -> list[SetSpec]:
    n_train, n_test, n_shift = SCALES[scale]
    tag = set_tag(scale, engine)
    quick = scale != "full"
    base = ControllerSettings(engine=engine)
    out: list[SetSpec] = [
        SetSpec(f"{tag}demo-train", n_train, TRAIN_FRACTIONS, TRAIN_X, TRAIN_Z, seed=1),
        SetSpec(f"{tag}demo-test", n_test, TEST_FRACTIONS, TEST_X, TEST_Z, seed=2),
        SetSpec(f"{tag}sizes-train", n_train, MIDDLE_FRACTIONS, TRAIN_X, TRAIN_Z, seed=3),
        SetSpec(f"{tag}sizes-test", n_test, END_FRACTIONS, TEST_X, TEST_Z, seed=4),
        SetSpec(f"{tag}poses-train", n_train, TRAIN_FRACTIONS, CENTRE, CENTRE, seed=5),
        SetSpec(
            f"{tag}poses-test", (n_test + 1) // 2, TEST_FRACTIONS, OUTER, OUTER_Z, seed=6,
            extra=(SetSpec("rotated", n_test // 2, TEST_FRACTIONS, (0.0,), (0.0,),
                           ROTATIONS_DEG),),
        ),
    ]  # fmt: skip
    table = Randomization.from_dict(randomized_table(engine), base=base)
    for train in [s for s in out if s.name.endswith("-train")]:
        out.append(replace(train, name=randomized_name(train.name), randomize=table))
    for rule in () if engine_reads(engine, "tendon") else COUPLING_SHIFTS:  # a tendon reads no rule
        out.append(SetSpec(f"{tag}coupling-{rule}", n_test, TEST_FRACTIONS, TEST_X, TEST_Z,
                           controller=replace(base, coupling=rule), seed=2))  # fmt: skip
    for s in _shift_fractions(quick):
        for sign, label in ((1, "up"), (-1, "down")):
            out.append(
                SetSpec(f"{tag}shift-{label}-{round(100 * s)}", n_shift, TEST_FRACTIONS,
                        TEST_X, TEST_Z, controller=shifted(base, sign * s), seed=7)
            )  # fmt: skip
    if not quick:
        knobs = {
            "friction-0.5": replace(base, friction=0.5),
            "friction-1.2": replace(base, friction=1.2),
            "thres-0.7": replace(base, thres_t=round(base.thres_t * 0.7, 6)),
            "thres-1.3": replace(base, thres_t=round(base.thres_t * 1.3, 6)),
            "speed-0.7": replace(base, delta=round(base.delta * 0.7, 6)),
            "speed-1.3": replace(base, delta=round(base.delta * 1.3, 6)),
            "phalanx-0.97": replace(base, phalanx_scale=0.97),
            "phalanx-1.03": replace(base, phalanx_scale=1.03),
        }
        for label, ctl in knobs.items():
            out.append(SetSpec(f"{tag}shift-{label}", n_shift, TEST_FRACTIONS, TEST_X, TEST_Z,
                               controller=ctl, seed=8))  # fmt: skip
    return [replace(s, controller=replace(s.controller, engine=engine)) for s in out]


COUPLING_SHIFTS: tuple[str, ...] = ("equal-torque", "distal-first")
"""The tendon rules coupling-shift tests on (training uses the default, j2-first)."""


def randomized_name(train_set: str) -> str:
    """The randomised twin of a training set: the same specs and seed, hand drawn per grasp."""
    return f"{train_set}-randomized"


def _shift_fractions(quick: bool | str) -> tuple[float, ...]:
    return (SHIFT_HEADLINE,) if scale_of(quick) != "full" else (0.1, SHIFT_HEADLINE, 0.3)


NOISE_LEVELS: tuple[tuple[str, SensorModel, str | None, float | None, bool], ...] = (
    ("sigma 0.5 deg", SensorModel.degrees(sigma=0.5), "noise sigma", 0.5, False),
    ("sigma 1 deg", SensorModel.degrees(sigma=1.0), "noise sigma", 1.0, False),
    ("sigma 2 deg", SensorModel.degrees(sigma=2.0), "noise sigma", 2.0, False),
    ("sigma 4 deg", SensorModel.degrees(sigma=4.0), "noise sigma", 4.0, False),
    ("bias 1 deg", SensorModel.degrees(bias=1.0), "calibration bias", 1.0, False),
    ("bias 3 deg", SensorModel.degrees(bias=3.0), "calibration bias", 3.0, False),
    ("bias 5 deg", SensorModel.degrees(bias=5.0), "calibration bias", 5.0, False),
    ("effort 0.05 N m", SensorModel(effort_sigma=0.05), None, None, False),
    ("sigma 1 deg + bias 3 deg", SensorModel.degrees(sigma=1.0, bias=3.0), None, None, True),
    ("sigma 2 deg + bias 5 deg", SensorModel.degrees(sigma=2.0, bias=5.0), None, None, False),
)
"""sensor-noise levels: (name, model, curve, x on it in deg, headline)."""
QUICK_NOISE = ("sigma 1 deg", "bias 3 deg", "sigma 1 deg + bias 3 deg")
TINY_NOISE = ("sigma 1 deg + bias 3 deg",)


def protocols(quick: bool | str = False, engine: str = "bullet") -> dict[str, Protocol]:
    """The protocols, by name, at a scale (``quick`` True/False or a scale name), the five
    single-engine ones on ``engine``'s sets."""
    scale = scale_of(quick)
    tag = set_tag(scale, engine)
    quick = scale != "full"
    kept = TINY_NOISE if scale == "tiny" else QUICK_NOISE
    test = f"{tag}demo-test"
    noise = [Level("clean", (test,), x=0.0, series="clean")] + [
        Level(name, (test,), model, x, head, series)
        for name, model, series, x, head in NOISE_LEVELS
        if not quick or name in kept
    ]
    shift = [Level("none", (test,), x=0.0, series="every knob")]
    for s in _shift_fractions(quick):
        pct = round(100 * s)
        shift.append(
            Level(f"+-{pct}%", (f"{tag}shift-up-{pct}", f"{tag}shift-down-{pct}"),
                  x=float(pct), headline=s == SHIFT_HEADLINE, series="every knob")
        )  # fmt: skip
    if not quick:
        for label in ("friction-0.5", "friction-1.2", "thres-0.7", "thres-1.3", "speed-0.7",
                      "speed-1.3", "phalanx-0.97", "phalanx-1.03"):  # fmt: skip
            shift.append(Level(label.replace("-", " "), (f"shift-{label}",)))
    single = lambda name, t: (Level(name, (t,), headline=True),)  # noqa: E731
    return {
        "in-distribution": Protocol(
            "in-distribution",
            "the demo's split: test sizes and offsets between the training ones",
            f"{tag}demo-train",
            single("held-out", test),
        ),
        "unseen-sizes": Protocol(
            "unseen-sizes",
            "train on the middle 3/8-5/8 of every size range, test within 1/16 of its ends",
            f"{tag}sizes-train",
            single("range ends", f"{tag}sizes-test"),
        ),
        "unseen-poses": Protocol(
            "unseen-poses",
            "train within 3 mm of the centre unrotated; test at +-10 mm and at 5-25 deg",
            f"{tag}poses-train",
            single("outer offsets and rotations", f"{tag}poses-test"),
        ),
        "sensor-noise": Protocol(
            "sensor-noise",
            "train clean; test read with joint noise, calibration bias, effort noise",
            f"{tag}demo-train",
            tuple(noise),
            curve="sensor error (deg)",
        ),
        "sim-shift": Protocol(
            "sim-shift",
            "train at default physics; test simulated with friction, thresT, closing speed "
            "and phalanx lengths shifted",
            f"{tag}demo-train",
            tuple(shift),
            curve="physics shift (%)",
        ),
        "coupling-shift": Protocol(
            "coupling-shift",
            "train with the J1/J2 tendon giving J2 first; test on the held-out grasps made with "
            "equal torque or the distal joint first",
            f"{tag}demo-train",
            tuple(
                Level(rule, (f"{tag}coupling-{rule}",), headline=rule == "distal-first")
                for rule in COUPLING_SHIFTS
            ),
        ),
    } | _engine_protocols(scale)


def _engine_protocols(scale: str) -> dict[str, Protocol]:
    bullet, mujoco = set_tag(scale, "bullet"), set_tag(scale, "mujoco")
    return {
        "cross-engine": Protocol(
            "cross-engine",
            "train on one engine's demo-train grasps, test on the other engine's demo-test",
            f"{bullet}demo-train",
            (
                Level("bullet->mujoco", (f"{mujoco}demo-test",), headline=True),
                Level("mujoco->bullet", (f"{bullet}demo-test",), train=f"{mujoco}demo-train"),
            ),
        ),
        "mixed-engine": Protocol(
            "mixed-engine",
            "train on both engines' demo-train grasps, test on each engine's demo-test",
            f"{bullet}demo-train+{mujoco}demo-train",
            (
                Level("bullet", (f"{bullet}demo-test",)),
                Level("mujoco", (f"{mujoco}demo-test",), headline=True),
            ),
        ),
    }


PROTOCOL_NAMES: tuple[str, ...] = tuple(protocols())
ENGINE_PROTOCOLS: tuple[str, ...] = ("cross-engine", "mixed-engine")
DEFAULT_PROTOCOLS: tuple[str, ...] = tuple(n for n in PROTOCOL_NAMES if n not in ENGINE_PROTOCOLS)
"""What ``all`` runs: the protocols that need no optional package."""


def resolve(names: str | Sequence[str] | None, engine: str = "bullet") -> list[str]:
    """'all', a comma list or a sequence -> protocol names in canonical order; a UsageError
    naming the unknown one otherwise. On an engine whose tendon splits J0 by itself 'all'
    leaves out coupling-shift, and naming it is a UsageError (it has no rule to shift)."""
    if names is None or names == "all" or list(names) == ["all"]:
        tendon = engine_reads(engine, "tendon")
        return [n for n in DEFAULT_PROTOCOLS if n != "coupling-shift" or not tendon]
    items = names.split(",") if isinstance(names, str) else list(names)
    items = [n.strip() for n in items if n.strip()]
    if not items:
        raise UsageError("no protocol named")
    if "all" in items:  # 'all' is every protocol: it names no list of its own
        raise UsageError(f"'all' runs every protocol: give it alone, not with "
                         f"{next(n for n in items if n != 'all')!r}")  # fmt: skip
    for n in items:
        if n not in PROTOCOL_NAMES:
            raise UsageError(
                f"unknown protocol {n!r} (known: {', '.join(PROTOCOL_NAMES)}, or 'all' for "
                f"{', '.join(DEFAULT_PROTOCOLS)}; robustness and active each run alone)"
            )
    if "coupling-shift" in items:
        _no_rule_shift(engine)
    return [n for n in PROTOCOL_NAMES if n in items]


def _no_rule_shift(engine: str) -> None:
    if engine_reads(engine, "tendon"):
        raise UsageError(f"coupling-shift changes a controller's rule for splitting J0; the "
                         f"{engine} engine's tendon splits it by its physics")  # fmt: skip


def needed_sets(
    names: Sequence[str],
    quick: bool | str = False,
    trainings: Sequence[str] = (),
    engine: str = "bullet",
) -> list[SetSpec]:
    """The sets the named protocols read, each once, in a fixed order (with the randomised
    training sets where ``trainings`` holds "randomized"), the single-engine ones simulated
    with ``engine``."""
    table = protocols(quick, engine)
    wanted: list[str] = []
    for name in names:
        if name == "coupling-shift":
            _no_rule_shift(engine)
        p = table[name]
        trains = [t for tr in [p.train] + [lv.train for lv in p.levels if lv.train]
                  for t in train_sets(tr)]  # fmt: skip
        if "randomized" in trainings:
            trains += [randomized_name(t) for t in trains]
        for set_name in (*trains, *(t for level in p.levels for t in level.test)):
            if set_name not in wanted:
                wanted.append(set_name)
    all_sets = sets(quick, engine)
    return [all_sets[n] for n in wanted]
