"""Shared helpers: closed-form references from ../shared/seed/REFERENCE.md."""

import numpy as np
import pytest

from batchveh.vehicle import Vehicle


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
