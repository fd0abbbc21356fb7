"""The wheel-ground models that batchveh applies itself, one entry point for every engine:
`slip` (batchveh/model/tyres.py) and `soil` (batchveh/model/soil.py). `rigid` is MuJoCo's own contact and
needs nothing here.

Each step, from the last forward pass's positions and contact forces and the velocities now:
the models' next state and the wrench on each wheel body (xfrc_applied). Numpy or jax.numpy
(`xp`), any leading shape.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from batchveh.model import soil, tyres


def params(p: Mapping[str, Any], model: str, xp=np) -> dict[str, Any] | None:
    """The per-variant inputs of wheel-ground model `model`, or None for `rigid`."""
    if model == "slip":
        return tyres.params(p, xp)
    if model == "soil":
        return soil.params(p, xp)
    return None


def init_state(shape: tuple[int, ...], xp=np, dtype=None):
    """The state of `shape` variants at rest (the models share its size)."""
    return tyres.init_state(shape, xp, dtype)


def step(state, xpos, xmat, qvel, cfrc_ext, xfrc_applied, wp: Mapping[str, Any], lay, dt, xp=np):
    """(next state, wheel wrenches (..., 4, 6), diagnostics) of the model `lay.wheel_ground`."""
    kin = tyres.kinematics(xpos, xmat, qvel, lay, xp)
    if lay.wheel_ground == "soil":
        return soil.step(state, kin, wp, dt, xp)
    return tyres.step(state, kin, tyres.contact_force(cfrc_ext, xfrc_applied, lay), wp, dt, xp)


def step_xfrc(state, xpos, xmat, qvel, cfrc_ext, xfrc_applied, wp: Mapping[str, Any], lay, dt, nbody: int, xp=np):
    """`step`'s next state and its wrenches as xfrc_applied (..., nbody, 6): what MuJoCo C's engine applies
    between its steps."""
    state, wrench, _ = step(state, xpos, xmat, qvel, cfrc_ext, xfrc_applied, wp, lay, dt, xp)
    return state, tyres.wheel_wrench_xfrc(wrench, nbody, lay, xp)
