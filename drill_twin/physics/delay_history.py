"""Bounded-memory history of the bit state and the state-dependent delay (eqs 2.4.13-2.4.14).

The delayed state is the bit position when the bit was one blade angle
``2π/n_b`` behind its current total angle Φ(τ): find τ_d with
``Φ(τ_d) = Φ(τ) - 2π/n_b`` (eq. 2.4.13); then ``τ_1 = τ - τ_d`` and the depth
of cut is ``δ = U(τ) - U(τ_d)``.  Φ never decreases (no backward rotation),
so the samples are sorted in Φ: a binary search brackets the target and the
cubic Hermite interpolant (positions *and* velocities stored, 4th-order
consistent with the RK4 integrator) is inverted by safeguarded Newton.  The
residual ``Φ_H(τ_d) - (Φ(τ) - 2π/n_b)`` of eq. 2.4.14 is returned.

Memory is a ring buffer of fixed capacity: samples older than one blade angle
are overwritten.  While the bit is frozen (stick) only the first and the latest frozen
sample are kept, so a long stick phase costs no memory.  If a lookup needs a
sample that has been overwritten, the overflow counter is incremented.

Ring layout: arrays ``hist`` of shape (5, capacity): rows τ, U, Φ, U', Φ';
``meta = [start, count, overflows, hint]`` (int64; hint = ring index of the
last bracket found, tried first since the bracket moves little between calls).
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ['new_history', 'push_sample', 'delayed_state', 'velocities_at_time']

H_T, H_U, H_PHI, H_DU, H_DPHI = 0, 1, 2, 3, 4
M_START, M_COUNT, M_OVERFLOW, M_HINT = 0, 1, 2, 3


def new_history(capacity: int):
    """Empty ring buffer of ``capacity`` samples."""
    return np.zeros((5, int(capacity))), np.zeros(4, np.int64)


@njit(cache=True, nogil=True)
def push_sample(hist, meta, t, u, phi, du, dphi):
    """Append a bit sample (τ, U, Φ, U', Φ'); skipped when the bit did not move."""
    cap = hist.shape[1]
    count = meta[M_COUNT]
    if count > 1:
        last = (meta[M_START] + count - 1) % cap
        prev = (meta[M_START] + count - 2) % cap
        if (hist[H_U, last] == u and hist[H_PHI, last] == phi
                and hist[H_U, prev] == u and hist[H_PHI, prev] == phi):
            # frozen bit (stick): the first and the latest sample of the frozen
            # interval bound it; only move the latest one forward in time.
            hist[H_T, last] = t
            hist[H_DU, last] = du
            hist[H_DPHI, last] = dphi
            return
    if count < cap:
        idx = (meta[M_START] + count) % cap
        meta[M_COUNT] = count + 1
    else:
        idx = meta[M_START]
        meta[M_START] = (meta[M_START] + 1) % cap
    hist[H_T, idx] = t
    hist[H_U, idx] = u
    hist[H_PHI, idx] = phi
    hist[H_DU, idx] = du
    hist[H_DPHI, idx] = dphi


@njit(cache=True, nogil=True, inline='always')
def _hermite(y0, y1, d0, d1, h, s):
    s2 = s * s
    s3 = s2 * s
    return ((2 * s3 - 3 * s2 + 1) * y0 + (s3 - 2 * s2 + s) * h * d0
            + (-2 * s3 + 3 * s2) * y1 + (s3 - s2) * h * d1)


@njit(cache=True, nogil=True, inline='always')
def _hermite_slope(y0, y1, d0, d1, h, s):
    """d/ds of the Hermite interpolant (s in [0, 1])."""
    s2 = s * s
    return ((6 * s2 - 6 * s) * y0 + (3 * s2 - 4 * s + 1) * h * d0
            + (-6 * s2 + 6 * s) * y1 + (3 * s2 - 2 * s) * h * d1)


@njit(cache=True, nogil=True, inline='always')
def _bracket(hist, row, start, count, value):
    """Ring positions (lo, hi) with hist[row, lo] < value <= hist[row, hi] (row sorted)."""
    cap = hist.shape[1]
    lo = 0
    hi = count - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if hist[row, (start + mid) % cap] < value:
            lo = mid
        else:
            hi = mid
    return (start + lo) % cap, (start + hi) % cap


@njit(cache=True, nogil=True)
def delayed_state(hist, meta, phi_target, out):
    """Bit state at the time the total angle was ``phi_target``.

    Writes ``out[0] = τ_d``, ``out[1] = U(τ_d)``, ``out[2] = residual`` of
    eq. 2.4.14 (Φ_H(τ_d) - phi_target).  Increments the overflow counter when
    the target is older than the oldest stored sample.
    """
    cap = hist.shape[1]
    start = meta[M_START]
    count = meta[M_COUNT]
    first = start
    last_k = count - 1
    if phi_target <= hist[H_PHI, first]:
        if phi_target < hist[H_PHI, first]:
            meta[M_OVERFLOW] += 1
        out[0] = hist[H_T, first]
        out[1] = hist[H_U, first]
        out[2] = hist[H_PHI, first] - phi_target
        return
    last = (start + last_k) % cap
    if phi_target >= hist[H_PHI, last]:
        out[0] = hist[H_T, last]
        out[1] = hist[H_U, last]
        out[2] = hist[H_PHI, last] - phi_target
        return
    # the bracket moves by at most a few samples per call: try last call's first
    k = (meta[M_HINT] - start) % cap
    found = False
    for _ in range(3):
        if 0 <= k < count - 1:
            a = hist[H_PHI, (start + k) % cap]
            if a < phi_target:
                if phi_target <= hist[H_PHI, (start + k + 1) % cap]:
                    found = True
                    break
                k += 1
            else:
                k -= 1
        else:
            break
    if found:
        i0 = (start + k) % cap
        i1 = (start + k + 1) % cap
    else:
        i0, i1 = _bracket(hist, H_PHI, start, count, phi_target)
    meta[M_HINT] = i0
    t0 = hist[H_T, i0]
    h = hist[H_T, i1] - t0
    p0 = hist[H_PHI, i0]
    p1 = hist[H_PHI, i1]
    dp0 = hist[H_DPHI, i0]
    dp1 = hist[H_DPHI, i1]
    # safeguarded Newton on s in [0, 1]
    a = 0.0
    b = 1.0
    s = (phi_target - p0) / (p1 - p0)
    for _ in range(50):
        f = _hermite(p0, p1, dp0, dp1, h, s) - phi_target
        if f > 0.0:
            b = s
        else:
            a = s
        if abs(f) <= 1e-14 * (1.0 + abs(phi_target)):
            break
        fp = _hermite_slope(p0, p1, dp0, dp1, h, s)
        s_new = s - f / fp if fp > 0.0 else 0.5 * (a + b)
        if not (a < s_new < b):
            s_new = 0.5 * (a + b)
        s = s_new
    out[0] = t0 + s * h
    out[1] = _hermite(hist[H_U, i0], hist[H_U, i1], hist[H_DU, i0], hist[H_DU, i1], h, s)
    out[2] = _hermite(p0, p1, dp0, dp1, h, s) - phi_target


@njit(cache=True, nogil=True)
def velocities_at_time(hist, meta, t, out):
    """Bit velocities (U', Φ') at time ``t`` from the derivative of the Hermite interpolant.

    Used for the constant (wave round-trip) delays of lumped model III.  Times
    before the oldest sample return its velocities (and count an overflow).
    """
    cap = hist.shape[1]
    start = meta[M_START]
    count = meta[M_COUNT]
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
    i0, i1 = _bracket(hist, H_T, start, count, t)
    h = hist[H_T, i1] - hist[H_T, i0]
    s = (t - hist[H_T, i0]) / h
    out[0] = _hermite_slope(hist[H_U, i0], hist[H_U, i1], hist[H_DU, i0], hist[H_DU, i1],
                            h, s) / h
    out[1] = _hermite_slope(hist[H_PHI, i0], hist[H_PHI, i1], hist[H_DPHI, i0],
                            hist[H_DPHI, i1], h, s) / h
