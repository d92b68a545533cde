"""Which physics engine a sweep's grasps run on: the TOML's top-level ``engine`` key, checked
before any grasp, and ``generate --engine`` / ``--hand-model`` applied to a sweep."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

from ..errors import UsageError


def merge_engine(data: Mapping[str, Any], controller_data: Any, source: str) -> dict:
    """``[controller]`` (which must be a table) with the top-level ``engine = "..."`` shorthand
    folded in (the two may not disagree)."""
    if not isinstance(controller_data, Mapping):
        raise UsageError(f"{source}: [controller] must be a table")
    out = dict(controller_data)
    if "engine" in data:
        if out.get("engine", data["engine"]) != data["engine"]:
            raise UsageError(f"{source}: engine and [controller] engine disagree")
        out["engine"] = data["engine"]
    return out


def check_engine(controller, source: str, load_model: bool = True) -> None:
    """An unknown or uninstalled engine, a knob it does not read, or a ``hand_model`` that is
    not a usable MJCF Shadow hand for mujoco, is refused before any grasp, naming the sweep
    (otherwise every grasp would fail on its own and the run would end 'successfully' with
    nothing in it). ``load_model=False``: the hand model was loaded already (it is compiled
    to be checked)."""
    if controller.hand_model is not None and controller.engine != "mujoco":
        raise UsageError(
            f"{source}: hand_model is an MJCF model for the mujoco engine, not {controller.engine}"
        )
    if controller.engine == "bullet":
        return
    from ..plugins import get_engine
    from ..sim.engines.base import unread_knob

    try:
        if why := unread_knob(controller, get_engine(controller.engine)):
            raise UsageError(why)
        if load_model and controller.hand_model is not None:
            from ..sim.engines.mujoco_hand import load_hand_spec

            load_hand_spec(controller.hand_model)
    except UsageError as exc:
        raise UsageError(f"{source}: {exc}") from None


def stamp_hand_model(controller, source: str):
    """``controller`` with its hand model's content digest (``hand_model_digest``), taken
    now; one it already carries must still be the model's (a UsageError names the file)."""
    if controller.hand_model is None:
        return controller
    from ..sim.engines.mujoco_hand import with_digest

    try:
        return with_digest(controller)
    except UsageError as exc:
        raise UsageError(f"{source}: {exc}") from None


def with_engine(
    sweep, engine: str, hand_model: str | None = None, hand_model_digest: str | None = None
):
    """The sweep simulated with another physics engine (``generate --engine``) and, for
    mujoco, another hand model (``--hand-model``, with its content digest)."""
    drawn = getattr(sweep.randomize, "engine", None)
    if drawn is not None:
        raise UsageError(f"--engine {engine} contradicts the sweep's [randomize] engine draw "
                         f"({', '.join(drawn)}): leave out one of them")
    settings = {"engine": engine} | ({"hand_model": hand_model} if hand_model else {})
    if hand_model:
        settings["hand_model_digest"] = hand_model_digest
    controller = replace(sweep.controller, **settings)
    check_engine(controller, "--engine", load_model=False)  # generate's flags loaded it
    if sweep.randomize is not None:  # its knobs were checked against the sweep's own engine
        from .randomize import Randomization

        Randomization.from_dict(sweep.randomize.to_dict(), "[randomize]", controller)
    return replace(sweep, controller=controller)
