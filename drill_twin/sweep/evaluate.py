"""One block of sweep points, evaluated in the calling process (a Dask task, or the
in-process reference): no Dask, no I/O.

Linear points: the configuration at the point, linearised (:mod:`drill_twin.stability`),
its rightmost roots; along a line of ``x`` the roots of the previous point seed the Newton
refinement of the next one, as in the stability charts.  Nonlinear points: the
configuration simulated for ``duration`` and the statistics of
:func:`drill_twin.analysis.statistics.stick_slip_summary` after ``settle``.  A point where
the configuration is invalid (no drilling, a rejected value) or the run diverges is NaN
(``unstable``: -1).
"""
from __future__ import annotations

import json
import math
import time

import numpy as np

from ..analysis.statistics import output_series, stick_slip_summary
from ..config.scenario import scenario_from_dict, with_values
from ..errors import ParameterError
from ..physics.simulation import Simulation, SimulationDiverged
from .spec import UPSILON_O, SweepSpec

__all__ = ['evaluate_block', 'evaluate_points', 'BlockResult', 'UPSILON_O']


class BlockResult(dict):
    """``{output: values of the block's points}`` plus ``block`` and ``compute_s`` (the wall
    time the evaluation took in the worker [s])."""


def evaluate_block(spec: SweepSpec, block: int) -> BlockResult:
    """Evaluate the points of ``block`` of ``spec`` (see module docstring)."""
    t0 = time.perf_counter()
    result = BlockResult(evaluate_points(spec, spec.block_range(block)))
    result['block'] = block
    result['compute_s'] = time.perf_counter() - t0
    return result


def evaluate_points(spec: SweepSpec, flats: range) -> dict:
    """``{output: values}`` at the flat point indices ``flats`` (consecutive) of ``spec``."""
    return _linear(spec, flats) if spec.kind == 'linear' else _nonlinear(spec, flats)


#: scenarios a worker has built, by (configuration as JSON, point values); see _scenario_at
_SCENARIOS: dict = {}
_SCENARIO_CACHE_SIZE = 1024


def _scenario_at(spec: SweepSpec, values: dict, raw_json: str | None):
    """The validated scenario of the sweep's configuration at the point ``values``.  A
    worker meets the same configuration once per line of a chart (the virtual key υ_o
    aside), so it is built once and kept, keyed by the configuration's JSON text
    (``raw_json``; None: not cached)."""
    key = None if raw_json is None else (raw_json, tuple(sorted(values.items())))
    sc = _SCENARIOS.get(key) if key is not None else None
    if sc is None:
        sc = scenario_from_dict(with_values(spec.raw, values), 'sweep', check_step=False)
        if key is not None:
            if len(_SCENARIOS) >= _SCENARIO_CACHE_SIZE:
                _SCENARIOS.clear()
            _SCENARIOS[key] = sc
    return sc


def _config_json(spec: SweepSpec):
    try:
        return json.dumps(spec.raw, sort_keys=True)
    except (TypeError, ValueError):   # a value JSON cannot write: no caching
        return None


def _linear_system(spec: SweepSpec, values: dict, raw_json: str | None = None):
    from ..stability.linearize import linearize_scenario
    ups = values.pop(UPSILON_O, None)
    sc = _scenario_at(spec, values, raw_json)
    g = sc.groups
    if ups is not None:
        g = g.replace(W_o=g.n_b * g.lam + 2 * math.pi * ups / g.omega_o)
    return linearize_scenario(sc, g)


def _linear(spec: SweepSpec, flats) -> dict:
    from ..stability.spectrum import rightmost_roots
    abscissa = np.full(len(flats), np.nan)
    unstable = np.full(len(flats), -1, dtype=np.int32)
    seeds = None
    raw_json = _config_json(spec)
    for i, flat in enumerate(flats):
        if spec.starts_line(flat):
            seeds = None
        try:
            dde = _linear_system(spec, spec.values_at(flat), raw_json)
        except (ValueError, ParameterError):
            seeds = None     # no drilling / an invalid point
            continue
        res = rightmost_roots(dde, count=16, seeds=seeds)
        abscissa[i] = res.abscissa
        unstable[i] = int(np.sum(res.roots.real > spec.threshold))
        seeds = res.roots
    return {'abscissa': abscissa, 'unstable': unstable}


def _nonlinear(spec: SweepSpec, flats) -> dict:
    out = {stat: np.full(len(flats), np.nan) for stat in spec.stats}
    for i, flat in enumerate(flats):
        try:
            sc = scenario_from_dict(with_values(spec.raw, spec.values_at(flat)), 'sweep')
            unit = sc.time_unit_s
            traj = Simulation.from_scenario(sc).run(spec.duration / unit, sc.record_interval)
            summary = stick_slip_summary(output_series(sc, traj), spec.settle)
        except (ValueError, ParameterError, SimulationDiverged):
            continue
        for stat in spec.stats:
            value = summary[stat]
            out[stat][i] = np.nan if value is None else float(value)
    return out
