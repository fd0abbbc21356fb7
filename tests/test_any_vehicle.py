"""Any vehicle on any catalogue motor (issue 31), a property on MuJoCo C: over vehicles of 20-2,000 kg, wheel
radius 0.05-0.5 m, drive ratios 5-200, every motor of notebooks/motors.yaml and both wheel-ground models that
roll on the flat (slip, the default, and rigid), a straight run at 30-70% of the wheel's no-load speed V / (K N)
with the drive's own gains (model/drive.py, nothing set by hand):

- the run is ok (status_code 0);
- no applied torque above the current's bound N K eta i_max (motor_torque_ratio, with motor_stats' 1% tolerance);
- no motor `unstable`, none chattering (motor_flip_share 0);
- the steady speed within 1% of the imposed one (speed_track_err, every drive's speed_shortfall).

"Wherever the motor can carry it", by construction: the ramp (smooth_step, its peak acceleration 15/8 of the
mean) is long enough that accelerating the loaded wheel, I_load = M r^2 / 4 + the wheel's and rotor's inertia,
takes at most half the current limit's torque and the vehicle at most half the friction (0.7 g); on the flat
with no rolling resistance the steady torque is next to nothing. An example whose ramp would then be longer
than RAMP_MAX is skipped (`assume`): a 70 W motor on 5:1 moving 2,000 kg on 0.5 m wheels would need hours.

The default run draws a few examples, derandomized (the same ones every run); the long pass
    python -m pytest -m slow tests/test_any_vehicle.py -p no:cacheprovider --hypothesis-show-statistics
draws SLOW_EXAMPLES. With BATCHVEH_ANY_VEHICLE_RECORD=path.jsonl each example's inputs and measured numbers
are appended to that file (validation/results/any_vehicle.json holds the long pass's worst).
"""

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import assume, given, settings, target  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from batchveh.engines.mujoco import MujocoEngine  # noqa: E402
from batchveh.model.motors import load_catalogue  # noqa: E402
from batchveh.model.vehicle import CORNERS  # noqa: E402
from batchveh.stepping.batch import make_batch  # noqa: E402
from batchveh.stepping.motor_stats import MOTOR_STATUS, TORQUE_TOL  # noqa: E402
from batchveh.sweeping.spec import spec_from_mapping  # noqa: E402

CATALOGUE = Path(__file__).resolve().parent.parent / "notebooks" / "motors.yaml"
MOTORS = load_catalogue(CATALOGUE)
STEER = "maxon-353297-48V_NPT025-i40"  # the steering motors (the straight run holds them at 0 deg)
SEED = 144.8  # kg, the seed vehicle: its chassis dimensions scale with (M / SEED)^(1/3)
FRICTION, G = 0.7, 9.81  # the scenario's defaults
CURRENT_SHARE = 0.5  # the ramp's peak acceleration takes at most this share of the current limit's torque
GRIP_SHARE = 0.5  # ... and at most this share of the friction
RAMP_MIN, RAMP_MAX = 1.0, 30.0  # s; longer ramps are skipped (about 1.3 s of MuJoCo C an example at 30 s)
RECOVER, WINDOW = 2.0, 3.0  # s after the ramp before the steady window, and the window's length

# the tolerances. Measured over the long test's 150 derandomized draws (83 on the slip tyre, 67 rigid), after
# the slip tyre's rim mass took the steering's (validation/results/any_vehicle.json, "after_the_tyre_fix"):
TORQUE_RATIO = 1 + TORQUE_TOL  # peak |applied torque| / (N K eta i_max): measured max 1.0 (at the limit, never above;
# 1.047 in CHATTER before the fix)
FLIP_SHARE = 0.0  # steps whose torque flips sign by half the bound: measured 0 (0.65-1.0 in the chatter before)
SPEED_ERR = 0.01  # steady speed against the imposed, relative: measured max 6.0e-5
# (motor_status 'unstable' also reads the applied torque's RMS over the current's, at most 1.2: measured max
# 1.0003; 1.21-1.66 in the chatter before the fix)

FAST_EXAMPLES, SLOW_EXAMPLES = 6, 150
# CI repeats the same draws; no example database (Hypothesis still caches constants in .hypothesis/, which it
# gitignores itself)
COMMON = {"deadline": None, "derandomize": True, "database": None}
RECORD = os.environ.get("BATCHVEH_ANY_VEHICLE_RECORD")


def _loaded_inertia(motor: dict, mass: float, radius: float, wheel_mass: float, ratio: float) -> float:
    """The inertia each drive moves (kg m^2): a quarter of the vehicle at the wheel's radius, the wheel
    (a solid cylinder) and the rotor through the gearhead."""
    return mass * radius**2 / 4 + 0.5 * wheel_mass * radius**2 + motor["J"] * ratio**2


def example(mass: float, radius: float, ratio: float, motor: str, share: float, tyre: str) -> dict | None:
    """The run of one vehicle, drive motor and ratio at `share` of the wheel's no-load speed: the imposed speed
    and the ramp that keeps the motor within CURRENT_SHARE of its limit and the wheels within GRIP_SHARE of
    the friction; None where that ramp exceeds RAMP_MAX."""
    c = MOTORS[motor].resolved()
    wheel_mass = max(0.3, 0.03 * mass)
    omega = share * c["V"] / (c["K"] * ratio)  # rad/s at the wheel
    inertia = _loaded_inertia(c, mass, radius, wheel_mass, ratio)
    torque = CURRENT_SHARE * c["eta"] * ratio * c["K"] * c["i_max"]  # N m at the wheel
    # smooth_step's peak acceleration is 15/8 omega / ramp: within `torque` and within the grip
    ramp = 15 / 8 * max(inertia * omega / torque, omega * radius / (GRIP_SHARE * FRICTION * G))
    ramp = max(RAMP_MIN, math.ceil(ramp * 10) / 10)  # whole 0.1 s: whole steps, so the window ends with the run
    if ramp > RAMP_MAX:
        return None
    return {
        "mass": mass,
        "radius": radius,
        "ratio": ratio,
        "motor": motor,
        "share": share,
        "tyre": tyre,
        "speed_kmh": omega * radius * 3.6,
        "ramp_time": ramp,
        "wheel_mass": wheel_mass,
        "I_load": inertia,
    }


@st.composite
def vehicles(draw) -> dict:
    """One vehicle, motor, ratio and straight run; skipped (assume) where its ramp exceeds RAMP_MAX: a third
    of the draws (74 of 224 in the long pass's 150)."""
    ex = example(
        mass=draw(st.floats(20.0, 2000.0), label="mass"),
        radius=draw(st.floats(0.05, 0.5), label="radius"),
        ratio=draw(st.floats(5.0, 200.0), label="ratio"),
        motor=draw(st.sampled_from(sorted(MOTORS)), label="motor"),
        share=draw(st.floats(0.3, 0.7), label="share"),  # of the no-load wheel speed
        tyre=draw(st.sampled_from(["slip", "rigid"]), label="tyre"),
    )
    assume(ex is not None)
    return ex


def _spec(ex: dict):
    """The example's sweep spec: one variant, the vehicle scaled from the seed's."""
    mass, radius, wheel_mass = ex["mass"], ex["radius"], ex["wheel_mass"]
    s = (mass / SEED) ** (1 / 3)
    hub_mass = max(0.3, 0.05 * mass)  # the hub carries the motor and its gearhead
    vehicle = {
        "chassis": {
            "mass": mass - 4 * (wheel_mass + hub_mass),  # at least 20 - 4 x 0.6 = 17.6 kg
            "length": 1.0 * s,
            "width": 0.6 * s,
            "height": 0.15 * s,
            "z_cg": radius + 0.16 * s,  # the seed's 0.16 m above the axles, clear of the ground
        },
        "wheel": {"radius": radius, "width": 0.09 * s, "mass": wheel_mass, "x_cg": 0.5 * s, "y_cg": 0.4 * s},
        "hub": {"mass": hub_mass, "radius": min(0.063 * s, 0.5 * radius), "length": 0.258 * s, "y_cg": 0.226 * s},
        "tyre": {"model": ex["tyre"]},
        "motors": {
            "model": "dcmotor",
            "catalogue": str(CATALOGUE),
            "drive": ex["motor"],
            "steer": STEER,
            "drive_set": [["gear_ratio", float(ex["ratio"])]],
        },
    }
    total = ex["ramp_time"] + RECOVER + WINDOW
    return spec_from_mapping(
        {
            "name": "any_vehicle",
            "scenario": "straight_line",
            "fixed": {"total_time": total, "ramp_time": ex["ramp_time"], "speed_kmh": ex["speed_kmh"]},
            "vehicle": vehicle,
            "window": [total - WINDOW, total],
            "sweep": {"method": "zip", "params": {"slope_deg": [0.0]}},
        },
        "any_vehicle",
    )


def _measure(ex: dict) -> dict:
    """Run the example on MuJoCo C; its numbers (plain floats) with the drive's derived gains."""
    spec = _spec(ex)
    batch = make_batch(spec.vehicle, spec.scenario, {"slope_deg": np.array([0.0])})
    out = MujocoEngine(spec.scenario, spec.stats_config(), 1).run(batch)
    i_max = MOTORS[ex["motor"]].resolved()["i_max"]
    got = {k: float(np.asarray(out[k])[0]) for k in ("status_code", "speed_track_err", "motor_torque_ratio",
                                                      "motor_flip_share", "motor_rms_ratio", "motor_status_code",
                                                      "motor_check_code")}  # fmt: skip
    got["speed_shortfall"] = max(abs(float(out[f"drive_{c}_speed_shortfall"][0])) for c in CORNERS)
    got["at_current_share"] = max(float(out[f"drive_{c}_at_current_share"][0]) for c in CORNERS)
    got["steady_current_share"] = max(float(out[f"drive_{c}_current_rms"][0]) for c in CORNERS) / i_max
    # the steering motors (STEER, 6.8 A) hold the wheels straight against the drive force's lever, the scrub
    # radius: on a heavy vehicle's ramp they may sit at their current limit, which the torque ratio then reads
    steer_i_max = MOTORS[STEER].resolved()["i_max"]
    got["steer_current_peak_share"] = max(float(out[f"steer_{c}_current_peak"][0]) for c in CORNERS) / steer_i_max
    got["kp"], got["kv"] = (float(batch.params[f"_dc.{k}"][0, 0]) for k in ("kp", "kv"))
    return got


def _check(ex: dict, explore: bool = False) -> None:
    """Run the example and assert the property; explore: lead Hypothesis towards the worst margins (target)."""
    got = _measure(ex)
    if RECORD:
        with open(RECORD, "a") as f:
            f.write(json.dumps({"example": ex, "measured": got}) + "\n")
    if explore:
        target(got["motor_torque_ratio"], label="torque ratio")
        target(max(got["speed_track_err"], got["speed_shortfall"]), label="speed error")
    where = f"{ex} -> {got}"
    assert got["status_code"] == 0, where
    assert got["motor_torque_ratio"] <= TORQUE_RATIO, where
    assert MOTOR_STATUS[int(got["motor_status_code"])] != "unstable", where
    assert got["motor_flip_share"] <= FLIP_SHARE, where
    assert got["speed_track_err"] <= SPEED_ERR and got["speed_shortfall"] <= SPEED_ERR, where


@settings(max_examples=FAST_EXAMPLES, **COMMON)
@given(vehicles())
def test_any_vehicle_keeps_its_speed_within_the_current_bound(ex):
    """FAST_EXAMPLES draws: about 20 s on 2 cores."""
    _check(ex, explore=True)


@pytest.mark.slow
@settings(max_examples=SLOW_EXAMPLES, **COMMON)
@given(vehicles())
def test_any_vehicle_keeps_its_speed_within_the_current_bound_long(ex):
    """SLOW_EXAMPLES draws, the margins' measurement. Fails on the slip tyre's chatter (CHATTER below)."""
    _check(ex, explore=True)


# A failure of the long pass, as Hypothesis shrank it in a first run: 998 kg on 0.05 m wheels, the 48 V maxon
# 353297 on 87:1, 0.40 km/h. On the slip tyre the drives and the steering chattered at 100 Hz (period 2 steps):
# flip share 0.91, the applied torque's RMS 1.57x the current's, a steering motor's applied torque 1.047x its
# bound; the mean speed still within 9e-5. The same vehicle on the rigid contact was clean. The cause was the
# slip tyre's bristle damper and stability floor (model/tyres.py, explicit), sized on the drive joint's rim
# mass, wheel.mass / 2 + J N^2 / r^2 = 420 kg here, while the tyre's force also turns the steering through the
# scrub radius e = 0.19 m, whose inertia there, I_steer / e^2, is 94 kg (validation/results/any_vehicle.json).
# The rim mass is now the lighter of the two (tyres.rim_mass, batch.steer_mass). Also seen, before that: 124 kg,
# r 0.0625 m, 86:1 (RMS ratio 1.21, no flips).
CHATTER = {"mass": 998.0, "radius": 0.05, "ratio": 87.0, "motor": "maxon-353297-48V_NPT025-i28", "share": 0.5}
SMALLER = {"mass": 124.0, "radius": 0.0625, "ratio": 86.0, "motor": "maxon-353297-48V_NPT025-i28", "share": 0.5}


@pytest.mark.parametrize("tyre", ["rigid", "slip"])
@pytest.mark.parametrize("case", [CHATTER, SMALLER], ids=["998kg", "124kg"])
def test_a_heavy_rotor_on_a_small_wheel(tyre, case):
    """A heavy geared rotor on a small wheel, on both wheel-ground models: the property holds."""
    _check(example(**case, tyre=tyre))
