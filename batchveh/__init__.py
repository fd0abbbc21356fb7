"""batchveh: batch simulation of a four-wheeled vehicle for motor sizing.

Public API: the vehicle and scenario definitions, single runs, sweeps and results, and motor sizing's
loaders. Each name is imported from its module on first use (`simulate` and `run_sweep` from
the CLI modules `batchveh.run` and `batchveh.sweep`), so `python -m batchveh.run`
and `python -m batchveh.sweep` start cleanly and quickly. `batchveh.sensitivity(result, ...)`
is the module `batchveh.sensitivity` (its CLI), which calls its function of that name.

The loaders:
- `load_spec(path)` -> SweepSpec, a validated sweep (run it with `run_sweep`, its variants: `variant_table`);
- `load_catalogue(path)` -> {name: DCMotor}, the `motors:` list of a motor catalogue (notebooks/motors.yaml);
- `load_battery(path)` -> Battery, that catalogue's `battery:` section;
- `load_scenario(name_or_path)` -> Scenario, `load_vehicle(path)` -> Vehicle;
and `load(folder)` -> DataFrame, a sweep's results, one row per variant. Motor sizing itself is
`batchveh.sizing` (`screen`, `in_loop`; the battery's loader: `batchveh.model.battery`).
"""

__version__ = "0.1.0"

import os as _os


def _choose_gl() -> str | None:
    """MuJoCo picks its OpenGL platform when first imported; a headless machine needs EGL.

    EGL is chosen only where libEGL can be found: MUJOCO_GL=egl without it breaks `import
    mujoco`. Where the user's own MUJOCO_GL names a library that is missing, `import
    mujoco` would die in PyOpenGL, taking simulation down with rendering: mujoco is then
    imported with OpenGL disabled (the user's value is restored right after), and the
    problem is returned, for the renderer to report in one line."""
    import ctypes.util

    gl = _os.environ.get("MUJOCO_GL", "").lower().strip()
    if not gl and not _os.environ.get("DISPLAY") and ctypes.util.find_library("EGL"):
        _os.environ["MUJOCO_GL"] = "egl"
        return None
    lib = {"egl": "EGL", "osmesa": "OSMesa"}.get(gl)
    if lib is None or ctypes.util.find_library(lib):
        return None
    user = _os.environ["MUJOCO_GL"]
    _os.environ["MUJOCO_GL"] = "disable"
    try:
        import mujoco  # noqa: F401
    finally:
        _os.environ["MUJOCO_GL"] = user
    return f"MUJOCO_GL={user} but lib{lib} is not installed"


GL_PROBLEM = _choose_gl()

# The public names, each imported from its module on first use (PEP 562): `python -m batchveh.sweep` reaches its
# own code in a fraction of a second, so that it can start the other GPUs' worker processes before its imports
# (batchveh/sweeping/prestart.py). The scenario kind 'mission' registers itself with batchveh.model's import.
_LAZY = {
    "ConfigError": "batchveh.config",
    "SCENARIOS": "batchveh.model.scenarios",
    "Scenario": "batchveh.model.scenarios",
    "load_scenario": "batchveh.model.scenarios",
    "make_scenario": "batchveh.model.scenarios",
    "MOTORS": "batchveh.model.vehicle",
    "Vehicle": "batchveh.model.vehicle",
    "load_vehicle": "batchveh.model.vehicle",
    "load_catalogue": "batchveh.model.motors",
    "load_battery": "batchveh.model.battery",
    "ResultError": "batchveh.sweeping.results",
    "load": "batchveh.sweeping.results",
    "metadata": "batchveh.sweeping.results",
    "units": "batchveh.sweeping.results",
    "SweepSpec": "batchveh.sweeping.spec",
    "load_spec": "batchveh.sweeping.spec",
    "spec_from_mapping": "batchveh.sweeping.spec",
    "variant_table": "batchveh.sweeping.spec",
    "simulate": "batchveh.run",
    "run_sweep": "batchveh.sweep",
}

__all__ = [
    "ConfigError",
    "MOTORS",
    "ResultError",
    "SCENARIOS",
    "Scenario",
    "SweepSpec",
    "Vehicle",
    "load",
    "load_battery",
    "load_catalogue",
    "load_scenario",
    "load_spec",
    "load_vehicle",
    "make_scenario",
    "metadata",
    "run_sweep",
    "sensitivity",
    "simulate",
    "spec_from_mapping",
    "units",
    "variant_table",
]


def __getattr__(name):
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value  # once
        return value
    if name == "sensitivity":  # the module, which is callable: importing it binds it here anyway
        import importlib

        return importlib.import_module("batchveh.sensitivity")
    raise AttributeError(f"module 'batchveh' has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *__all__})
