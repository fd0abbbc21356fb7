"""A second-hand table of Ding et al. (2011) against the soil model: a guide, not the check.

Ding L., Gao H., Deng Z., Tao J., Iagnemma K., Liu G., "Experimental study and analysis on
driving wheels' performance for planetary exploration rovers moving in deformable soil",
Journal of Terramechanics 48(1), 27-45, 2011, Fig. 9: a smooth wheel (r 0.15735 m, b 0.165 m)
at 80 N in a lunar soil simulant, drawbar pull, driving torque and sinkage against slip.

The paper is not readable from this workplace. The numbers below are the smooth-wheel rows of
`data/validation/single_wheel_experiments.csv` and the soil row "Ding2011_planetary_simulant"
of `data/soil_simulants.csv` in github.com/Autonomous-Mission-Systems-Lab/roverdevkit @
69e1c815, which marks them "digitised_approx" (rounded to 0.5 N) with the raw digitisation not
committed: neither the values nor the soil set (n 1.10, k_c 15.6 kN/m^(n+1), k_phi 2407.4
kN/m^(n+2), c 0.25 kPa, phi 31.9 deg, K 9.7-13.1 mm, 11 mm used) could be checked against
the paper. So this comparison is not validation/SOIL.md's published-data check; it says how
far the model is from a smooth wheel with torque, if these rows are right.

The model: batchveh's soil at that wheel, load and soil, the Wong-Reece coefficients of
soil.WONG_REECE, sinkage where the soil carries the load (validation/soil.py's `equilibrium`).

    python validation/soil_data/ding2011_secondhand.py     (a few seconds; writes ding2011_secondhand.json)
"""

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parent.parent))

from soil import equilibrium, wheel_params  # noqa: E402 (validation/soil.py)

from batchveh.model import soil  # noqa: E402

SOURCE = (
    "github.com/Autonomous-Mission-Systems-Lab/roverdevkit @ 69e1c815b6353e0016d67eace11e84641df896d6, "
    "data/validation/single_wheel_experiments.csv (smooth wheel, ding2011, status digitised_approx) and "
    "data/soil_simulants.csv (Ding2011_planetary_simulant), citing Ding et al. 2011, J. Terramechanics 48(1) "
    "27-45, Fig. 9 and Table 2"
)
WHEEL = {"radius_m": 0.15735, "width_m": 0.165, "load_N": 80.0}
SOIL = {"n": 1.10, "k_c": 15.6, "k_phi": 2407.4, "c": 0.25, "phi": 31.9, "K": 0.011}
# slip: drawbar pull N, driving torque N m, sinkage m (slip 0 left out: the wheel is towed there)
ROWS = {0.1: (11.0, 3.0, 0.0055), 0.2: (14.5, 4.2, 0.0075), 0.3: (15.0, 4.8, 0.010), 0.4: (15.0, 5.0, 0.0125)}
ROWS[0.6] = (15.0, 5.3, 0.0175)


def main():
    so = {**soil.WONG_REECE, **SOIL}
    sp = wheel_params(WHEEL["radius_m"], WHEEL["width_m"], so)
    rows = []
    for slip, (dp, torque, sinkage) in ROWS.items():
        m = equilibrium(sp, WHEEL["load_N"], slip)
        rows.append(
            {
                "slip": slip,
                "table": {"drawbar_pull_N": dp, "torque_Nm": torque, "sinkage_m": sinkage},
                "model": m,
                "drawbar_pull_relative_error": (m["drawbar_pull_N"] - dp) / dp,
                "torque_relative_error": (m["torque_Nm"] - torque) / torque,
            }
        )
        e_dp, e_t = rows[-1]["drawbar_pull_relative_error"], rows[-1]["torque_relative_error"]
        print(
            f"slip {slip:.1f}: DP {m['drawbar_pull_N']:6.2f} N vs {dp:5.1f} ({e_dp:+.0%}), "
            f"T {m['torque_Nm']:5.2f} N m vs {torque:4.1f} ({e_t:+.0%}), "
            f"sinkage {m['sinkage_m'] * 1e3:5.1f} mm vs {sinkage * 1e3:4.1f}"
        )
    out = {"source": SOURCE, "wheel": WHEEL, "soil": so, "rows": rows}
    (HERE / "ding2011_secondhand.json").write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
