"""batchveh: batch simulation of a four-wheeled vehicle for motor sizing.

Public API: the vehicle and scenario definitions, single runs, sweeps and results.
"""

__version__ = "0.1.0"

from batchveh.config import ConfigError
from batchveh.io import load, metadata, units
from batchveh.run import simulate
from batchveh.scenarios import SCENARIOS, Scenario, load_scenario, make_scenario
from batchveh.spec import load_spec, variants
from batchveh.vehicle import MOTORS, Vehicle, load_vehicle

__all__ = ["ConfigError", "MOTORS", "SCENARIOS", "Scenario", "Vehicle", "load", "load_scenario", "load_spec",
           "load_vehicle", "make_scenario", "metadata", "run_sweep", "simulate", "units", "variants"]


def run_sweep(*args, **kwargs):
    """Run a sweep spec; see batchveh.sweep.run_sweep (imported lazily so `python -m batchveh.sweep` stays clean)."""
    from batchveh.sweep import run_sweep as _run

    return _run(*args, **kwargs)
