"""Shared helpers: closed-form references from ../shared/seed/REFERENCE.md."""

import numpy as np
import pytest

from batchveh.model.tyres import Tyre
from batchveh.model.vehicle import Vehicle

# MuJoCo's frictional contact (`tyre: {model: rigid}`): the tests of that contact's own behaviour
RIGID = Vehicle(tyre=Tyre(model="rigid"))

# The four-wheel drive sum on a steady climb against m g sin(s) r: the soft contact sinks 1.5 mm,
# so the lever arm is about r - 0.75 mm (tests/test_physics.py); measured -2.8e-3 to -3.9e-3 on
# MuJoCo C, MJX and warp alike. The bound is 1%.
SLOPE_SUM_RTOL = 5e-3


def slope_torque(vehicle: Vehicle, slope_deg: float, g: float = 9.81) -> float:
    """Quasi-static four-wheel drive-torque sum on a slope: m g sin(slope) r, N m."""
    return vehicle.total_mass * g * np.sin(np.deg2rad(slope_deg)) * vehicle.wheel.radius


@pytest.fixture(scope="session")
def vehicle() -> Vehicle:
    return Vehicle()


@pytest.fixture
def mjx_output_dtypes(monkeypatch) -> set[str]:
    """The dtypes of the arrays MJX runs hand back during the test (simulate brings them to the
    host with jax.device_get); the series DataFrame is float64 whatever MJX computed in."""
    import jax

    seen: set[str] = set()
    device_get = jax.device_get

    def spy(tree):
        out = device_get(tree)
        seen.update(str(np.asarray(x).dtype) for x in jax.tree_util.tree_leaves(out))
        return out

    monkeypatch.setattr(jax, "device_get", spy)
    return seen
