"""A bounded history of a few signals in time, for constant time delays.

Two parts of the twin feed back signals from a fixed time earlier: lumped model III
(App. B, eqs B.2.7-B.2.8) the bit velocities one wave round trip earlier,
``u'(τ - τ_2)`` and ``φ'(τ - τ_3)``, and the motor top drive
(:mod:`drill_twin.physics.top_drive`) the motor speed and the string torque its sensors
report after their delay.  These delays are constant in *time* (unlike the bit/rock
delay, which is one of angle and lives in :mod:`drill_twin.physics.bottom_surface`).
Samples are kept in a ring of fixed capacity (the longest delay over the step, plus
margin), and read by cubic Hermite interpolation of each signal from its values and
slopes.

Signals, in this order (:data:`SIGNALS`): total bit axial velocity U', total bit angular
speed Φ', motor speed perturbation ω_m and surface (first-element) torque perturbation
T_s.  Ring layout: ``hist`` of shape (1 + 2 S, capacity): row 0 τ, rows 1..S the values,
rows S+1..2S the slopes; ``meta = [start, count, overflows]``.
"""
from __future__ import annotations

import numpy as np

from .hermite import hermite
from .jit import kernel_jit

__all__ = ['new_time_history', 'push_sample', 'sample_at_time', 'SIGNALS',
           'S_BIT_AXIAL_SPEED', 'S_BIT_ANGULAR_SPEED', 'S_MOTOR_SPEED', 'S_SURFACE_TORQUE',
           'N_SIGNALS']

SIGNALS = ('bit_axial_speed', 'bit_angular_speed', 'motor_speed', 'surface_torque')
S_BIT_AXIAL_SPEED, S_BIT_ANGULAR_SPEED, S_MOTOR_SPEED, S_SURFACE_TORQUE = 0, 1, 2, 3
N_SIGNALS = len(SIGNALS)
M_START, M_COUNT, M_OVERFLOW = 0, 1, 2


def new_time_history(capacity: int):
    """Empty ring of ``capacity`` samples of the :data:`SIGNALS`."""
    return np.zeros((1 + 2 * N_SIGNALS, max(int(capacity), 4))), np.zeros(3, np.int64)


@kernel_jit
def push_sample(hist, meta, t, values, slopes):
    """Append a sample at ``t`` (every signal's value and slope); the oldest is
    overwritten when full, and a sample at the same instant (an event) replaces the
    last one."""
    cap = hist.shape[1]
    n_sig = (hist.shape[0] - 1) // 2
    count = meta[M_COUNT]
    idx = -1
    if count > 0:
        last = (meta[M_START] + count - 1) % cap
        if hist[0, last] >= t:        # an event at the same instant: keep the latest
            idx = last
    if idx < 0:
        if count < cap:
            idx = (meta[M_START] + count) % cap
            meta[M_COUNT] = count + 1
        else:
            idx = meta[M_START]
            meta[M_START] = (meta[M_START] + 1) % cap
        hist[0, idx] = t
    for k in range(n_sig):
        hist[1 + k, idx] = values[k]
        hist[1 + n_sig + k, idx] = slopes[k]


@kernel_jit
def sample_at_time(hist, meta, t, out):
    """Every signal at time ``t`` into ``out`` (cubic Hermite in time).  Times before the
    oldest sample return its values and count an overflow; times after the newest return
    the newest."""
    cap = hist.shape[1]
    n_sig = (hist.shape[0] - 1) // 2
    start = meta[M_START]
    count = meta[M_COUNT]
    if count == 0:
        for k in range(n_sig):
            out[k] = 0.0
        return
    last = (start + count - 1) % cap
    if t <= hist[0, start] or t >= hist[0, last]:
        i = start if t <= hist[0, start] else last
        if t < hist[0, start]:
            meta[M_OVERFLOW] += 1
        for k in range(n_sig):
            out[k] = hist[1 + k, i]
        return
    lo = 0
    hi = count - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if hist[0, (start + mid) % cap] < t:
            lo = mid
        else:
            hi = mid
    i0 = (start + lo) % cap
    i1 = (start + hi) % cap
    h = hist[0, i1] - hist[0, i0]
    s = (t - hist[0, i0]) / h
    for k in range(n_sig):
        out[k] = hermite(hist[1 + k, i0], hist[1 + k, i1], hist[1 + n_sig + k, i0],
                         hist[1 + n_sig + k, i1], h, s)
