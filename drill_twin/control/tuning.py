"""The stability-tuned top-drive controller: gains chosen by the stability module.

Objective (docs/control.md, "Stability-tuned mode")
---------------------------------------------------
The closed loop (motor drive + controller + string + bit, linearised at the operating
point: :func:`drill_twin.stability.linearize.linearize`) is scored by its spectral
abscissa and, since the rightmost root can be one no top boundary moves (at the
benchmark point: 0.158 + 20.57 i per t*, a coupled axial-torsional mode whose growth is
unchanged by a stiff, a Soft-Torque or even an ideal impedance-matched top), by the sum
of the growth rates of all unstable roots (each complex pair once)::

    J(K_p, K_i, g_T) = max Re λ + Σ_{Re λ > 0, Im λ >= 0} Re λ.

Gains are searched by Nelder-Mead in ``(log K_p, log K_i, g_T Z)`` (bounded to four
decades around the mode tunings, ``0 <= g_T Z <= 2``) from the Soft-Torque and the
Z-Torque tunings; the best is kept, never one that scores worse than Soft-Torque.
"""
from __future__ import annotations

import copy
import functools
import math

import numpy as np
from scipy.optimize import minimize

from ..physics.parameters import BitRockGroups
from ..physics.top_drive import (
    DriveGains,
    kernel_drive,
    mode_gains,
    pipe_torsional_impedance,
)
from ..stability.linearize import linearize
from ..stability.spectrum import rightmost_roots

__all__ = ['closed_loop_score', 'tune_gains', 'with_gains']

#: roots examined per evaluation (the unstable ones lie among the rightmost few)
ROOTS = 24


def closed_loop_score(model, groups: BitRockGroups) -> dict:
    """``{'abscissa', 'unstable_growth', 'score', 'roots'}`` of the closed loop (per t*;
    structural zero roots left out)."""
    res = rightmost_roots(linearize(model, groups), count=ROOTS)
    upper = res.roots[res.roots.imag >= 0]
    growth = float(np.sum(np.maximum(upper.real, 0.0)))
    return {'abscissa': res.abscissa, 'unstable_growth': growth,
            'score': res.abscissa + growth, 'roots': res.roots}


def with_gains(model, system, gains: DriveGains):
    """A copy of a motor-drive model with other controller gains."""
    out = copy.copy(model)
    out.__dict__.pop('_chain_eigenvalues', None)   # the RK4 limit depends on the gains
    out.top_drive = model.top_drive.with_gains(gains)
    out.motor_drive = kernel_drive(out.top_drive, system)
    return out


def tune_gains(model, groups: BitRockGroups, system, max_evaluations: int = 160):
    """Gains minimising the score of :func:`closed_loop_score`; returns them and a report
    (Soft-Torque's and the tuned score and abscissa)."""
    drive = model.top_drive
    z = pipe_torsional_impedance(system)
    J, wc = drive.motor_inertia_kgm2, drive.speed_loop_bandwidth_rad_s
    st = mode_gains('soft_torque', system, J, wc)
    zt = mode_gains('z_torque', system, J, wc)
    lo = np.array([math.log(st.proportional_Nms_rad) - 4.6, math.log(st.integral_Nm_rad) - 4.6,
                   0.0])
    hi = np.array([math.log(zt.proportional_Nms_rad) + 4.6, math.log(zt.integral_Nm_rad) + 4.6,
                   2.0])

    def gains_of(p):
        p = np.clip(p, lo, hi)
        return DriveGains(math.exp(p[0]), math.exp(p[1]), p[2] / z)

    @functools.cache
    def evaluate(key):
        try:
            return closed_loop_score(with_gains(model, system, gains_of(np.array(key))),
                                     groups)
        except (np.linalg.LinAlgError, ValueError):
            return {'score': math.inf, 'abscissa': math.inf}

    def f(p):
        return evaluate(tuple(np.round(np.clip(p, lo, hi), 9)))['score']

    starts = [np.array([math.log(g.proportional_Nms_rad), math.log(g.integral_Nm_rad),
                        g.torque_feedback_rad_s_Nm * z]) for g in (st, zt)]
    best_p = starts[0]
    for p0 in starts:
        simplex = p0 + np.vstack([np.zeros(3), np.diag([0.7, 0.7, 0.3])])
        res = minimize(f, p0, method='Nelder-Mead', options={
            'maxfev': max_evaluations // 2, 'xatol': 1e-3, 'fatol': 1e-7,
            'initial_simplex': simplex})
        if res.fun < f(best_p):
            best_p = res.x
    start, tuned = evaluate(tuple(np.round(starts[0], 9))), \
        evaluate(tuple(np.round(np.clip(best_p, lo, hi), 9)))
    return gains_of(best_p), {
        'soft_torque_score': start['score'], 'soft_torque_abscissa': start['abscissa'],
        'tuned_score': tuned['score'], 'tuned_abscissa': tuned['abscissa'],
        'evaluations': evaluate.cache_info().misses}
