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
