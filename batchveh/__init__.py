"""batchveh: batch simulation of a four-wheeled vehicle for motor sizing.

Public API: the vehicle and scenario definitions, single runs, sweeps and results.
`simulate` and `run_sweep` live in the CLI modules `batchveh.run` and
`batchveh.sweep`; they are imported on first use, so `python -m batchveh.run`
and `python -m batchveh.sweep` start cleanly.
"""

__version__ = "0.1.0"

import os as _os


def _choose_gl() -> None:
    """MuJoCo picks its OpenGL platform when first imported; a headless machine needs EGL.

    Chosen only where libEGL can be found: MUJOCO_GL=egl without it breaks `import mujoco`.
    """
    import ctypes.util

    if "MUJOCO_GL" not in _os.environ and not _os.environ.get("DISPLAY") and ctypes.util.find_library("EGL"):
        _os.environ["MUJOCO_GL"] = "egl"


_choose_gl()

from batchveh.config import ConfigError  # noqa: E402  (after _choose_gl: these import mujoco)
from batchveh.results import ResultError, load, metadata, units  # noqa: E402
from batchveh.scenarios import SCENARIOS, Scenario, load_scenario, make_scenario  # noqa: E402
from batchveh.spec import SweepSpec, load_spec, spec_from_mapping, variant_table  # noqa: E402
from batchveh.vehicle import MOTORS, Vehicle, load_vehicle  # noqa: E402

_LAZY = {"simulate": "batchveh.run", "run_sweep": "batchveh.sweep"}

__all__ = [
    "ConfigError",
    "MOTORS",
    "ResultError",
    "SCENARIOS",
    "Scenario",
    "SweepSpec",
    "Vehicle",
    "load",
    "load_scenario",
    "load_spec",
    "load_vehicle",
    "make_scenario",
    "metadata",
    "run_sweep",
    "simulate",
    "spec_from_mapping",
    "units",
    "variant_table",
]


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'batchveh' has no attribute {name!r}")
