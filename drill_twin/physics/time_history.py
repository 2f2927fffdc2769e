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

Signals (:data:`~drill_twin.physics.layout.SIGNAL`): total bit axial velocity U', total
bit angular speed Φ', motor speed perturbation ω_m and surface (first-element) torque
perturbation T_s.  Ring layout: ``hist`` of shape (1 + 2 S, capacity): row 0 τ, rows
1..S the values, rows S+1..2S the slopes; ``meta`` (``HISTORY``): the first sample, the
samples held, the reads before the first.
"""
from __future__ import annotations

import numpy as np

from .hermite import hermite
from .jit import kernel_jit
from .layout import HISTORY, RING, SIGNAL

__all__ = ['new_time_history', 'push_sample', 'sample_at_time']


def new_time_history(capacity: int):
    """Empty ring of ``capacity`` samples of the signals (:data:`SIGNAL`)."""
    return (np.zeros((RING.size, max(int(capacity), 4))),
            np.zeros(len(HISTORY), np.int64))


@kernel_jit
def push_sample(hist, meta, t, values, slopes):
    """Append a sample at ``t`` (every signal's value and slope); the oldest is
    overwritten when full, and a sample at the same instant (an event) replaces the
    last one."""
    cap = hist.shape[1]
    n_sig = len(SIGNAL)
    count = meta[HISTORY.count]
    idx = -1
    if count > 0:
        last = (meta[HISTORY.start] + count - 1) % cap
        if hist[RING.time, last] >= t:    # an event at the same instant: keep the latest
            idx = last
    if idx < 0:
        if count < cap:
            idx = (meta[HISTORY.start] + count) % cap
            meta[HISTORY.count] = count + 1
        else:
            idx = meta[HISTORY.start]
            meta[HISTORY.start] = (meta[HISTORY.start] + 1) % cap
        hist[RING.time, idx] = t
    for k in range(n_sig):
        hist[RING.values + k, idx] = values[k]
        hist[RING.slopes + k, idx] = slopes[k]


@kernel_jit
def sample_at_time(hist, meta, t, out):
    """Every signal at time ``t`` into ``out`` (cubic Hermite in time).  Times before the
    oldest sample return its values and count an overflow; times after the newest return
    the newest."""
    cap = hist.shape[1]
    n_sig = len(SIGNAL)
    start = meta[HISTORY.start]
    count = meta[HISTORY.count]
    if count == 0:
        for k in range(n_sig):
            out[k] = 0.0
        return
    last = (start + count - 1) % cap
    if t <= hist[RING.time, start] or t >= hist[RING.time, last]:
        i = start if t <= hist[RING.time, start] else last
        if t < hist[RING.time, start]:
            meta[HISTORY.overflows] += 1
        for k in range(n_sig):
            out[k] = hist[RING.values + k, i]
        return
    lo = 0
    hi = count - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if hist[RING.time, (start + mid) % cap] < t:
            lo = mid
        else:
            hi = mid
    i0 = (start + lo) % cap
    i1 = (start + hi) % cap
    h = hist[RING.time, i1] - hist[RING.time, i0]
    s = (t - hist[RING.time, i0]) / h
    for k in range(n_sig):
        out[k] = hermite(hist[RING.values + k, i0], hist[RING.values + k, i1],
                         hist[RING.slopes + k, i0], hist[RING.slopes + k, i1], h, s)
