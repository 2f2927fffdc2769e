"""Shared helpers of the test suite (no expected values live here)."""
from __future__ import annotations

import math

import numpy as np
from scipy.signal import argrelextrema

from drill_twin.physics.simulation import Simulation
from drill_twin.stability.linearize import linearize


def eigenvector_state(model, groups, root, amplitude):
    """Real perturbation state along the null vector of Δ(root), scaled to ``amplitude``."""
    dde = linearize(model, groups)
    v = np.linalg.svd(dde.characteristic_matrix(root))[2][-1].conj()
    v = v / v[np.argmax(np.abs(v))]
    return np.real(v) * amplitude, dde


def measured_growth_rate(model, groups, root, t_fit, h=1e-3, amplitude=1e-8, channel=None):
    """Growth rate of the nonlinear simulation started along the root's mode.

    The log of the local maxima of |signal| is fitted by a line over
    ``t_fit = (start, end)`` (units of t*).  The signal is the state entry
    with the largest mode amplitude unless ``channel`` names a state index.
    """
    y0, dde = eigenvector_state(model, groups, root, amplitude)
    sim = Simulation(model, groups, h)
    sim.set_perturbation_state(y0)
    traj = sim.run(t_fit[1], h, record_state=True)
    assert sim.event_count == 0, 'the perturbation left the smooth (linear) regime'
    idx = int(np.argmax(np.abs(y0))) if channel is None else channel
    s = traj.state[:, idx]
    t = traj.tau
    pk = argrelextrema(np.abs(s), np.greater)[0]
    pk = pk[(t[pk] >= t_fit[0]) & (t[pk] <= t_fit[1])]
    assert pk.size >= 6, 'too few oscillation peaks in the fit window'
    return np.polyfit(t[pk], np.log(np.abs(s[pk])), 1)[0]


#: unit round-off of IEEE double precision
EPS = float(np.finfo(float).eps)


def roundoff_bound(steps: int, growth_rate: float = 0.0, span: float = 0.0,
                   terms: float = 1.0) -> float:
    """Relative difference two mathematically equal integrations can have after ``steps``
    steps from round-off alone: each step commits at most ``terms`` units of round-off
    relative to the state's scale (``terms``: a factor for the longest sum the two
    computations order differently), and what a step commits grows at most as the linear
    dynamics does, ``exp(growth_rate * span)`` (``growth_rate``: the spectral abscissa
    [1/t*] of the linearised model over ``span`` [t*]; 0 for a stable one).  Summed
    linearly over the steps (Wilkinson's bound; the statistical sqrt(steps) is typical,
    the bound is what any CPU, BLAS or instruction set may give)."""
    return steps * terms * EPS * math.exp(max(growth_rate, 0.0) * span)
