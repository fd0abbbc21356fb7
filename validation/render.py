"""Write docs/validation.md: every physics check in one table, read from the tests' constants and
validation/results/*.json, so that the page cannot drift from what is checked.

    python validation/render.py            # rewrite docs/validation.md
    python validation/render.py --check    # exit 1 if docs/validation.md is not what this writes

A row names what is checked and its closed form or reference (the text here); the tolerance is the
value of the test module's constant (read by parsing the module, nothing imported or run) and the
measured value is the "measured ..." note the test keeps beside that constant, or a value of a
validation study's result file. tests/test_validation_page.py checks the committed page.
"""

from __future__ import annotations

import ast
import json
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TESTS = ROOT / "tests"
RESULTS = ROOT / "validation" / "results"
OUT = ROOT / "docs" / "validation.md"


def constants(module: str) -> dict[str, object]:
    """The module-level constants of tests/MODULE that are literals (or names of conftest's)."""
    found: dict[str, object] = {}
    for path in (TESTS / "conftest.py", TESTS / module):
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name):
                try:
                    found[node.targets[0].id] = ast.literal_eval(node.value)
                except ValueError:
                    if isinstance(node.value, ast.Name) and node.value.id in found:
                        found[node.targets[0].id] = found[node.value.id]
    return found


def notes(module: str, name: str) -> list[str]:
    """The comments the test keeps beside a constant: the one on its line, then the lines just above it."""
    lines = (TESTS / module).read_text().splitlines()
    i = next(k for k, line in enumerate(lines) if re.match(rf"{name}\s*=", line))
    same = lines[i].split("#", 1)[1].strip() if "#" in lines[i] else ""
    above = []
    k = i - 1
    while k >= 0 and lines[k].startswith("#"):
        above.insert(0, lines[k].lstrip("# "))
        k -= 1
    return [same, " ".join(above)]


def measured(module: str, name: str) -> str:
    """The first "measured ..." beside a constant, to the end of its clause."""
    for text in notes(module, name):
        m = re.search(r"[Mm]easured:? (.+?)(?:;|\. |\.$|$)", text)
        if not m:
            continue
        value = m.group(1)
        if value.startswith("on ") and ": " in value:  # "measured on WHERE: VALUE"
            value = value.split(": ", 1)[1]
        if value.count("(") < value.count(")"):  # "(measured 1.000)"
            value = value[: value.rindex(")")]
        if value.count("(") > value.count(")"):  # a parenthesis the comment's next line closes
            value = value[: value.rindex("(")]
        if len(value) > 70 and " (" in value[10:]:  # a long aside: the page keeps the figures
            value = value[: value.index(" (", 10)]
        return value.replace(" on the project's 2-core machine", "").strip().rstrip(",:")
    raise ValueError(f"tests/{module}: no 'measured' beside {name}")


def e(x: float) -> str:
    return f"{x:.1e}".replace("e-0", "e-").replace("e+0", "e")


def tol(value: object) -> str:
    if isinstance(value, dict):
        return ", ".join(f"{k} {tol(v)}" for k, v in value.items())
    return f"{value:g}" if isinstance(value, float) else str(value)


# (what is checked, closed form or reference, test module, the tolerance's constants, the constant
# whose note gives the measured value (default: the first tolerance's))
CHECKS = [
    ("Four-wheel drive sum on a steady climb", "m g sin(s) r", "conftest.py", ["SLOPE_SUM_RTOL"], None),
    ("The same, 194.8 kg at 10 deg", "m g sin(s) r", "test_physics.py", ["SUM_RTOL_HEAVY"], None),
    ("The same, sphere wheel contacts", "m g sin(s) r", "test_physics.py", ["SUM_RTOL_SPHERE"], None),
    ("Drive sum on flat ground (N m)", "0", "test_physics.py", ["SUM_ATOL_FLAT"], None),
    ("Left against right wheel on a straight line (N m)", "mirror symmetry", "test_physics.py", ["MIRROR_ATOL"], None),
    ("Wheel speed tracking, 20 deg, mu 0.9", "the imposed speed", "test_physics.py", ["SPEED_TRACK_RTOL"], None),
    ("Steering angle under the slope's load (deg)", "the imposed angle", "test_physics.py", ["STEER_TRACK_DEG"], None),
    ("Steady mean when dt halves", "dt-independent force balance", "test_physics.py", ["DT_HALVING_RTOL"], None),
    (
        "Peaks (rms, peak_lp_all, peak_all) per halving of dt",
        "convergence in dt",
        "test_physics.py",
        ["PEAK_HALVING_RTOL"],
        None,
    ),
    (
        "Drive sum's peak at 1.25 ms",
        "r m (g sin s + a_max) + 4 (I + armature) a_max / r",
        "test_physics.py",
        ["PEAK_CLOSED_FORM_RTOL"],
        None,
    ),
    (
        "Drive sum during a linear ramp",
        "r m (g sin s + a) + 4 (I + armature) a / r",
        "test_physics.py",
        ["RAMP_SUM_RTOL"],
        None,
    ),
    ("Towing: free wheel speed", "v / r", "test_physics.py", ["FREE_WHEEL_RTOL"], None),
    ("Sliding down a slope: acceleration", "g (mu cos s - sin s)", "test_physics.py", ["SLIDING_ACCEL_RTOL"], None),
    ("Pivot turn: yaw rate", "rigid kinematics", "test_physics.py", ["PIVOT_YAW_RTOL"], None),
    ("Ackermann turn: yaw rate", "v / R", "test_physics.py", ["ACKERMANN_YAW_RTOL"], None),
    ("Ackermann turn: path radius", "R", "test_physics.py", ["ACKERMANN_RADIUS_RTOL"], None),
    ("Crab: heading (deg)", "the steering angle", "test_physics.py", ["CRAB_ANGLE_DEG"], None),
    ("Pivot centre drift (m)", "0 by symmetry", "test_physics.py", ["SYMMETRY_ATOL_M"], None),
    ("Chassis acceleration over a linear ramp", "1 m/s^2 / (1 + creep)", "test_physics.py", ["RAMP_ACCEL_RTOL"], None),
    ("Friction force never above mu N", "Coulomb: mu N (ratio)", "test_contact.py", ["UPPER"], None),
    ("Sum with rolling resistance", "m g (sin s + C_rr cos s) r", "test_contact.py", ["RR_RTOL"], None),
    ("Drive work over a step", "m g h + rolling work + kinetic energy", "test_course.py", ["ENERGY_RTOL"], None),
    ("Warp against C over a bump: peaks and RMS", "MuJoCo C float64", "test_course.py", ["BUMP_PEAK_RTOL"], None),
    (
        "Any steering motor with 1.5x the servo's peak, 20-2,000 kg, contact 0.1 m off its axis",
        "holds its angle, off its current limit",
        "test_any_steering.py",
        ["AT_LIMIT_SHARE", "LOST_DEG"],
        None,
    ),
    ("Steering in place: wheel load", "m g / 4", "test_scrub.py", ["NORMAL_RTOL"], None),
    ("Steering in place: edge couple", "mu N w / 2", "test_scrub.py", ["EDGE_COUPLE_RTOL"], None),
    (
        "Slip tyre: each wheel's share of the drive",
        "its static load share",
        "test_tyres.py",
        ["SHARE_ATOL", "SHARE_REGRESSION"],
        "SHARE_REGRESSION",
    ),
    (
        "Slip tyre: share change between 1 and 3 km/h",
        "0",
        "test_tyres.py",
        ["SPEED_SHARE_ATOL", "SPEED_SHARE_REGRESSION"],
        "SPEED_SHARE_REGRESSION",
    ),
    ("Slip tyre: four-wheel sum", "m g sin(s) r", "test_tyres.py", ["SUM_RTOL", "SUM_REGRESSION"], "SUM_REGRESSION"),
    (
        "Slip tyre: slip curve",
        "the brush model's closed form",
        "test_tyres.py",
        ["CURVE_RTOL", "CURVE_REGRESSION"],
        "CURVE_REGRESSION",
    ),
    ("Slip tyre: force at full sliding", "mu N (ratio 1)", "test_tyres.py", ["SATURATION_ATOL"], None),
    (
        "Slip tyre: creep while held on 10 and 20 deg (m in 5 s)",
        "0",
        "test_tyres.py",
        ["HOLD_MAX", "HOLD_REGRESSION"],
        "HOLD_REGRESSION",
    ),
    (
        "Slip tyre: sliding down a slope",
        "g (mu cos s - sin s)",
        "test_tyres.py",
        ["SLIDE_RTOL", "SLIDE_REGRESSION"],
        "SLIDE_REGRESSION",
    ),
    ("Soil: static sinkage", "Bekker's pressure-sinkage", "test_soil.py", ["SINKAGE_RTOL"], None),
    ("Soil: driving torque", "Wong-Reece", "test_soil.py", ["TORQUE_RTOL"], None),
    ("Soil: the stress integrals", "scipy quad", "test_soil.py", ["QUAD_RTOL", "QUAD_REGRESSION"], "QUAD_REGRESSION"),
    (
        "Soil: MJX float64 against C",
        "MuJoCo C float64",
        "test_soil.py",
        ["ENGINE_RTOL", "ENGINE_REGRESSION"],
        "ENGINE_REGRESSION",
    ),
    (
        "Soil: warp float32 against C, p99",
        "MuJoCo C float64",
        "test_soil.py",
        ["WARP_RTOL", "WARP_REGRESSION"],
        "WARP_REGRESSION",
    ),
    ("Soil: drive means over dt 2.5 -> 20 ms", "dt-independence", "test_soil.py", ["DT_RTOL"], None),
    ("MJX float64 torque series (N m)", "MuJoCo C float64", "test_mjx.py", ["F64_SERIES_ATOL"], None),
    ("MJX float32 four-wheel sum", "MuJoCo C float64", "test_mjx.py", ["F32_SUM_VS_C_RTOL"], None),
    (
        "Mission on a slope: body forces against tilted gravity",
        "the straight-line run",
        "test_missions.py",
        ["SLOPE_FORCE_RTOL"],
        None,
    ),
    ("Mission segments sum to the mission", "the whole run's statistics", "test_missions.py", ["PARTITION_RTOL"], None),
    (
        "Structural variants: fields without a compile",
        "a MuJoCo compile per variant",
        "test_fields.py",
        ["FIELD_RTOL", "TORQUE_RTOL"],
        "TORQUE_RTOL",
    ),
    (
        "Sobol' indices of the drive sum",
        "SALib on m g sin(s) r at the same points",
        "test_sensitivity.py",
        ["SAME_POINTS_ATOL"],
        None,
    ),
    (
        "DC motors with every limit off: four-wheel torque on a climb",
        "the ideal servo",
        "test_dcmotor.py",
        ["CLIMB_SUM_RTOL"],
        None,
    ),
    (
        "DC motors: the drop below no-load speed on the voltage line",
        "(R(T) T / (eta N K)) / (K N), T from the weight",
        "test_drive.py",
        ["LINE_RTOL", "LINE_REGRESSION"],
        None,
    ),
    (
        "DC motors: the approach to the line after a current-limited start",
        "tau = (M r^2 / 4) R / (eta N^2 K^2)",
        "test_drive.py",
        ["TAU_RTOL", "TAU_REGRESSION"],
        None,
    ),
    (
        "DC motors: the resistance the motor used against the reported winding (K)",
        "the drive's winding temperature",
        "test_drive.py",
        ["T_FROM_R_TOL"],
        None,
    ),
    (
        "DC motors: the winding after a current-limited start (K)",
        "solve_ivp of the one-node model",
        "test_drive.py",
        ["HEAT_ODE_TOL"],
        None,
    ),
    ("DC motors on warp: four-wheel mean", "MuJoCo C float64", "test_dcmotor.py", ["WARP_SUM_RTOL"], None),
    ("DC motors on warp: a wheel's mean and peak", "MuJoCo C float64", "test_dcmotor.py", ["WARP_WHEEL_RTOL"], None),
    (
        "Skid pivot: the four wheels' mean drive torque (30 kg-1 t; validation/LAYOUTS.md)",
        "mu N r L / sqrt(L^2 + B^2) (Coulomb, four point contacts)",
        "test_layouts.py",
        ["SKID_MEAN_RTOL"],
        None,
    ),
    ("Skid pivot: the steady yaw rate", "b^2 / h^2 of the command", "test_layouts.py", ["SKID_YAW_RTOL"], None),
    (
        "Skid turn of radius R: the yaw rate",
        "the slip tyre's steady state",
        "test_layouts.py",
        ["SKID_TURN_YAW_RTOL"],
        None,
    ),
    (
        "Front steering: the yaw rate of a steady turn",
        "v / hypot(x_cg, R)",
        "test_layouts.py",
        ["FRONT_YAW_RTOL"],
        None,
    ),
    (
        "Front steering: the path's radius",
        "hypot(x_cg, R)",
        "test_layouts.py",
        ["FRONT_RADIUS_RTOL"],
        None,
    ),
]


def _json(name: str) -> dict:
    return json.loads((RESULTS / name).read_text())


# validation studies: (what, reference, criterion, measured from the result file, script and page)
STUDIES = [
    (
        "Servo rig: imposed speed held while dragging",
        "the imposed speed",
        "-",
        lambda: f"{e(_json('drag.json')['checks']['actual_speed_rel_err_max'])} relative, largest",
        "validation/drag.py, [DRAG.md](../validation/DRAG.md)",
    ),
    (
        "Soil against Yoshida et al. 2003's wheel test: drawbar pull",
        "published measurements",
        "within 20%",
        lambda: (
            f"{_json('soil.json')['published']['points_within_20_percent']} of "
            f"{len(_json('soil.json')['published']['rows'])} points"
        ),
        "validation/soil.py, [SOIL.md](../validation/SOIL.md)",
    ),
    (
        "Soil: change over dt",
        "dt-independence",
        "-",
        lambda: f"{e(_json('soil.json')['dt_study']['largest_change'])} largest",
        "validation/soil.py, [SOIL.md](../validation/SOIL.md)",
    ),
    (
        "Sobol' study, climb: drive sum",
        "m g sin(s) r",
        "-",
        lambda: f"{e(_json('sensitivity.json')['climb_N64']['drive_sum_mean_vs_m_g_sin_r_max_rel'])} largest",
        "validation/sensitivity.py, [sensitivity.md](sensitivity.md)",
    ),
    (
        "The loop's hot run in closed form from its cold run (issue 52), MuJoCo C",
        "every variant run hot (`in_loop(closed=False)`)",
        "verdicts equal; the peak never below",
        lambda: _hot("hot_closed_form.json"),
        "validation/hot_closed_form.py, [motors.md](motors.md)",
    ),
    (
        "The same on one H100 (float32), the seed, with the GPU's run-to-run floor",
        "every variant run hot, twice",
        "differences within the floor's",
        lambda: _hot_floor("hot_closed_form-h100-floor.json"),
        "validation/hot_closed_form.py --floor, [motors.md](motors.md)",
    ),
]


def _hot(name: str) -> str:
    """hot_closed_form's cases: the verdict rows that differ (motors' verdicts; `steady`, `slipping` and
    `motor_status` apart), and the drive's winding peak, closed form minus the run (p99 of |d|, signed range)."""
    parts = []
    for case, c in _json(name)["cases"].items():
        rows = c["verdict_rows_differing"]
        motors = sum(v for k, v in rows.items() if k.startswith(("fails_", "steer_fails_", "where", "judged")))
        peak = c["differences_by_kind"].get("drive winding_temp_peak", {"p99": 0.0, "min_signed": 0.0, "max": 0.0})
        parts.append(
            f"{case} ({c['conditions']:,}): {motors} verdict rows differ, peak p99 {peak['p99']:.2g} K "
            f"(range {peak['min_signed']:+.2g}..{peak['max']:.2g} K)"
        )
    return "; ".join(parts)


def _hot_floor(name: str) -> str:
    """The same case against the engine's own noise: every variant run hot twice."""
    out = []
    for case, c in _json(name)["cases"].items():
        f = c["floor_every_variant_hot_twice"]
        peak, floor = (
            c["differences_by_kind"]["drive winding_temp_peak"],
            f["differences_by_kind"]["drive winding_temp_peak"],
        )
        out.append(
            f"{case} ({c['conditions']:,}): the closed form against a hot run, largest {peak['max']:.2g} K, p99 "
            f"{peak['p99']:.2g} K; two hot runs against each other, largest {floor['max']:.2g} K, p99 "
            f"{floor['p99']:.2g} K"
        )
    return "; ".join(out)


def render() -> str:
    out = [
        "# Validation",
        "",
        "<!-- Generated by `python validation/render.py` from the tests' constants and validation/results/*.json:",
        "edit those, not this page. tests/test_validation_page.py checks it. -->",
        "",
        "Every physics check of the test suite, with the closed form or reference it is held to. The tolerance",
        "is the test's constant (two values: the bound the issue asked for, then the tighter regression bound",
        "the test holds); the measured value is the note the test keeps beside it, on this project's 2-core",
        "machine unless it says otherwise. The studies behind them are the pages in",
        "[validation/](../validation/).",
        "",
        "| what is checked | closed form or reference | tolerance | measured | test |",
        "| --- | --- | --- | --- | --- |",
    ]
    cache: dict[str, dict] = {}
    for what, ref, module, names, source in CHECKS:
        found = cache.setdefault(module, constants(module))
        tolerance = "; ".join(tol(found[n]) for n in names)
        value = measured(module, source or names[0])
        out.append(f"| {what} | {ref} | {tolerance} | {value} | `tests/{module}` ({', '.join(names)}) |")
    out += [
        "",
        "## Studies",
        "",
        "| what is checked | reference | criterion | measured | script and page |",
        "| --- | --- | --- | --- | --- |",
    ]
    out += [f"| {w} | {r} | {c} | {m()} | {s} |" for w, r, c, m, s in STUDIES]
    return "\n".join(out) + "\n"


def main() -> None:
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from render import publish  # benchmarks/render.py: write the page, or --check it

    publish(OUT, render(), "validation/render.py", __doc__)


if __name__ == "__main__":
    main()
