"""A bounded history of the bit velocities in time, for constant delays (lumped model III).

Lumped model III (App. B, eqs B.2.7-B.2.8) feeds back the bit velocities one
wave round trip earlier, ``u'(τ - τ_2)`` and ``φ'(τ - τ_3)``: delays that are
constant in *time* (unlike the bit/rock delay, which is one of angle and lives in
:mod:`drill_twin.physics.bottom_surface`).  Samples (τ, U', Φ', U'', Φ'') are kept
in a ring of fixed capacity (the longest delay over the step, plus margin), and
read by cubic Hermite interpolation of the velocities.

Ring layout: ``hist`` of shape (5, capacity): rows τ, U', Φ', U'', Φ''; ``meta =
[start, count, overflows]``.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .hermite import hermite

__all__ = ['new_time_history', 'push_velocities', 'velocities_at_time']

H_T, H_DU, H_DPHI, H_DDU, H_DDPHI = 0, 1, 2, 3, 4
M_START, M_COUNT, M_OVERFLOW = 0, 1, 2


def new_time_history(capacity: int):
    """Empty ring of ``capacity`` samples."""
    return np.zeros((5, max(int(capacity), 4))), np.zeros(3, np.int64)


@njit(cache=True, nogil=True)
def push_velocities(hist, meta, t, du, dphi, ddu, ddphi):
    """Append a sample (τ, U', Φ', U'', Φ''); the oldest is overwritten when full."""
    cap = hist.shape[1]
    count = meta[M_COUNT]
    if count > 0:
        last = (meta[M_START] + count - 1) % cap
        if hist[H_T, last] >= t:        # an event at the same instant: keep the latest
            hist[H_DU, last] = du
            hist[H_DPHI, last] = dphi
            hist[H_DDU, last] = ddu
            hist[H_DDPHI, last] = ddphi
            return
    if count < cap:
        idx = (meta[M_START] + count) % cap
        meta[M_COUNT] = count + 1
    else:
        idx = meta[M_START]
        meta[M_START] = (meta[M_START] + 1) % cap
    hist[H_T, idx] = t
    hist[H_DU, idx] = du
    hist[H_DPHI, idx] = dphi
    hist[H_DDU, idx] = ddu
    hist[H_DDPHI, idx] = ddphi


@njit(cache=True, nogil=True)
def velocities_at_time(hist, meta, t, out):
    """Bit velocities (U', Φ') at time ``t`` (cubic Hermite in time).  Times before the
    oldest sample return its velocities and count an overflow."""
    cap = hist.shape[1]
    start = meta[M_START]
    count = meta[M_COUNT]
    if count == 0:
        out[0] = 0.0
        out[1] = 0.0
        return
    if t <= hist[H_T, start]:
        if t < hist[H_T, start]:
            meta[M_OVERFLOW] += 1
        out[0] = hist[H_DU, start]
        out[1] = hist[H_DPHI, start]
        return
    last = (start + count - 1) % cap
    if t >= hist[H_T, last]:
        out[0] = hist[H_DU, last]
        out[1] = hist[H_DPHI, last]
        return
    lo = 0
    hi = count - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if hist[H_T, (start + mid) % cap] < t:
            lo = mid
        else:
            hi = mid
    i0 = (start + lo) % cap
    i1 = (start + hi) % cap
    h = hist[H_T, i1] - hist[H_T, i0]
    s = (t - hist[H_T, i0]) / h
    out[0] = hermite(hist[H_DU, i0], hist[H_DU, i1], hist[H_DDU, i0], hist[H_DDU, i1], h, s)
    out[1] = hermite(hist[H_DPHI, i0], hist[H_DPHI, i1], hist[H_DDPHI, i0],
                      hist[H_DDPHI, i1], h, s)
