"""A configuration run offline, start to end (``drill-twin simulate``, the demo, tests)."""
from __future__ import annotations

import math
import time

from ..analysis.statistics import output_series
from ..config.scenario import Scenario
from ..errors import ParameterError
from ..physics.simulation import Simulation

__all__ = ['run_scenario', 'positive']


def run_scenario(scenario: Scenario, duration=None, progress=None):
    """Run a scenario; return (series in config units, wall seconds, simulation)."""
    sim = Simulation.from_scenario(scenario)
    t0 = time.perf_counter()
    traj = sim.run(duration or scenario.duration, scenario.record_interval, progress=progress)
    wall = time.perf_counter() - t0
    return output_series(scenario, traj), wall, sim


def positive(name, value, unit):
    """``value`` if finite and > 0, else a one-line error naming ``name`` and ``unit``."""
    if not (math.isfinite(value) and value > 0):
        raise ParameterError(f'{name} {value:g} {unit}: must be a finite number > 0')
    return value
