"""The bottom-hole surface as a function of angle (what the state-dependent delay stands for).

The rock under the bit is a surface ``S(ξ)`` over the angle ξ around the hole
axis: the axial position (down-hole, units d*) of the rock left by the blades
(thesis §2.3-2.4).  A blade at angle ξ with the bit at axial position U cuts
``d = U - S(ξ)`` when ``d > 0`` and leaves ``S(ξ) = max(S(ξ), U)``; off bottom
(``d <= 0``) it neither cuts nor touches.  The delay formulation of eqs
2.4.13-2.4.14, ``d = U(τ) - U(τ - τ_1)`` with ``Φ(τ - τ_1) = Φ(τ) - 2π/n_b``, is this
surface read where the preceding blade wrote it; the surface also holds when the
bit stops, lifts off or tags bottom again, in memory that does not depend on the
speed or on how long the bit is stopped.

Representation
--------------
* A uniform grid of ``N`` nodes over one **period** P of the surface: the blade
  pitch 2π/n_b for evenly spaced blades (all blades cut identically, so S is
  P-periodic), 2π for blades at arbitrary angles.  Node j is at ξ_j = j P/N.
* A blade at bit angle Φ is at unwrapped surface position X = Φ + θ_b (θ_b its
  offset).  When an accepted integration step takes X from X_0 to X_1, every node
  position ξ_j + kP in (X_0, X_1] is **written**: the crossing instant is found by
  safeguarded Newton on the step's cubic Hermite interpolant of Φ(τ) (positions and
  velocities at both ends: 4th order, as the RK4 steps), and the node gets
  ``max(S, U(τ_c))``.  Each node keeps its previous value, the bit angle and the
  time of the write (for the delay and its residual).
* A blade reads S just ahead of itself — the rock the preceding blade left: a
  4-point Lagrange cubic on nodes j-1 … j+2 around X.  Nodes behind the blade that
  the reading blade itself has just written (bit angle of the write within half
  the smallest blade gap of now) contribute their previous value.  Reads never
  search: the node index is ``floor(X/Δξ)``.

Layout: ``surf`` (6 × N): rows :data:`S_CUR` (height), :data:`S_PREV` (height
before the latest write), :data:`S_ANGLE` (bit angle Φ at the latest write),
:data:`S_TIME`, :data:`S_PREV_TIME` (times of the latest and previous writes),
:data:`S_RES` (Newton residual of the crossing, rad); ``geom = [period, spacing,
min_gap]``.
"""
from __future__ import annotations

import math

import numpy as np

from .hermite import hermite, hermite_slope
from .jit import kernel_jit

__all__ = ['new_surface', 'fill_steady', 'fill_flat', 'write_step', 'read_surface',
           'S_CUR', 'S_PREV', 'S_ANGLE', 'S_TIME', 'S_PREV_TIME', 'S_RES', 'nodes_for']

S_CUR, S_PREV, S_ANGLE, S_TIME, S_PREV_TIME, S_RES = 0, 1, 2, 3, 4, 5
G_PERIOD, G_SPACING, G_MIN_GAP = 0, 1, 2


def nodes_for(period: float, angle_per_step: float, min_gap: float, minimum: int = 64,
              maximum: int = 1 << 16) -> int:
    """Grid size: four nodes per nominal integration step of rotation (so that the node
    spacing resolves the surface as finely as the steps resolve the motion), and at least
    eight per smallest blade gap (a read's four nodes then never reach the next blade)."""
    need = 8.0 * period / min_gap
    if angle_per_step > 0:
        need = max(need, 4.0 * period / angle_per_step)
    return int(min(max(minimum, math.ceil(need)), maximum))


def new_surface(period: float, nodes: int, min_gap: float):
    """Empty surface arrays over one period (rad) with ``nodes`` nodes."""
    if not (period > 0 and nodes >= 8 and 0 < min_gap <= period + 1e-12):
        raise ValueError('surface needs period > 0, >= 8 nodes and 0 < min_gap <= period')
    surf = np.zeros((6, int(nodes)))
    surf[S_ANGLE] = -np.inf
    geom = np.array([float(period), float(period) / nodes, float(min_gap)])
    return surf, geom


def fill_steady(surf, geom, offsets, upsilon, omega, t0: float = 0.0):
    """The surface of steady drilling at bit angle Φ = ω τ, U = υ τ, at time ``t0``: every
    node as the blades that passed it last (and, for the previous value, before) left it.
    ``offsets``: blade angles on the period (one 0 for an even bit)."""
    period, spacing = geom[G_PERIOD], geom[G_SPACING]
    n = surf.shape[1]
    phi_now = omega * t0
    offs = np.sort(np.mod(np.asarray(offsets, float), period))
    for j in range(n):
        x_node = j * spacing
        # the latest bit angle Φ <= Φ_now at which some blade stood on this node
        best = -np.inf
        for th in offs:
            k = math.floor((phi_now + th - x_node) / period)
            best = max(best, x_node + k * period - th)
        prev = -np.inf
        for th in offs:
            k = math.floor((best - 1e-12 * period + th - x_node) / period)
            cand = x_node + k * period - th
            if cand < best - 1e-12 * period:
                prev = max(prev, cand)
        t_w, t_p = best / omega, prev / omega
        surf[S_CUR, j] = upsilon * t_w
        surf[S_PREV, j] = upsilon * t_p
        surf[S_ANGLE, j] = best
        surf[S_TIME, j] = t_w
        surf[S_PREV_TIME, j] = t_p
        surf[S_RES, j] = 0.0


def fill_flat(surf, depth: float, time: float = 0.0):
    """A flat bottom at axial position ``depth`` (d*), never cut by these blades."""
    surf[S_CUR] = depth
    surf[S_PREV] = depth
    surf[S_ANGLE] = -np.inf
    surf[S_TIME] = time
    surf[S_PREV_TIME] = time
    surf[S_RES] = 0.0


@kernel_jit
def _crossing(p0, p1, dp0, dp1, h, target):
    """Fraction s in [0, 1] of the step where the Hermite angle equals ``target``
    (safeguarded Newton; the angle never decreases), and the residual."""
    a = 0.0
    b = 1.0
    s = (target - p0) / (p1 - p0) if p1 > p0 else 1.0
    s = min(max(s, 0.0), 1.0)
    f = 0.0
    for _ in range(60):
        f = hermite(p0, p1, dp0, dp1, h, s) - target
        if f > 0.0:
            b = s
        else:
            a = s
        if abs(f) <= 1e-14 * (1.0 + abs(target)) or b - a < 1e-15:
            break
        fp = hermite_slope(p0, p1, dp0, dp1, h, s)
        s_new = s - f / fp if fp > 0.0 else 0.5 * (a + b)
        if not (a < s_new < b):
            s_new = 0.5 * (a + b)
        s = s_new
    return s, f


@kernel_jit
def write_step(surf, geom, offsets, t0, t1, u0, u1, p0, p1, du0, du1, dp0, dp1):
    """Let every blade write the nodes it swept while the bit went from angle ``p0`` (time
    ``t0``, position ``u0``, velocities ``du0, dp0``) to ``p1`` (``t1`` ...).  Returns the
    number of nodes written."""
    if not p1 > p0:
        return 0
    spacing = geom[G_SPACING]
    n = surf.shape[1]
    h = t1 - t0
    written = 0
    for b in range(offsets.size):
        th = offsets[b]
        first = math.floor((p0 + th) / spacing) + 1
        last = math.floor((p1 + th) / spacing)
        for jj in range(first, last + 1):
            target = jj * spacing - th            # bit angle when this blade is on the node
            s, res = _crossing(p0, p1, dp0, dp1, h, target)
            u = hermite(u0, u1, du0, du1, h, s)
            j = jj % n
            surf[S_PREV, j] = surf[S_CUR, j]
            surf[S_PREV_TIME, j] = surf[S_TIME, j]
            if u > surf[S_CUR, j]:
                surf[S_CUR, j] = u
            surf[S_ANGLE, j] = target
            surf[S_TIME, j] = t0 + s * h
            surf[S_RES, j] = res
            written += 1
    return written


@kernel_jit(inline='always')
def read_surface(surf, geom, phi, offset, out):
    """The rock ahead of the blade at ``offset`` when the bit angle is ``phi``.

    Writes ``out[0]`` = surface height S (d*), ``out[1]`` = time at which the preceding
    blade left it (so the delay is τ - out[1]), ``out[2]`` = largest |residual| of the
    crossings used (rad).
    """
    spacing = geom[G_SPACING]
    half_gap = 0.5 * geom[G_MIN_GAP]
    n = surf.shape[1]
    x = phi + offset
    q = x / spacing
    j0 = math.floor(q)
    f = q - j0
    # Lagrange weights on nodes j0-1, j0, j0+1, j0+2 at fraction f
    w0 = -f * (f - 1.0) * (f - 2.0) / 6.0
    w1 = (f + 1.0) * (f - 1.0) * (f - 2.0) / 2.0
    w2 = -(f + 1.0) * f * (f - 2.0) / 2.0
    w3 = (f + 1.0) * f * (f - 1.0) / 6.0
    height = 0.0
    time = 0.0
    res = 0.0
    for k in range(4):
        jj = j0 - 1 + k
        j = jj % n
        w = w0 if k == 0 else (w1 if k == 1 else (w2 if k == 2 else w3))
        # written by this blade on this pass (the bit angle of the write is within half a
        # blade gap of now): the rock before it is what this blade cuts
        if surf[S_ANGLE, j] > phi - half_gap:
            height += w * surf[S_PREV, j]
            time += w * surf[S_PREV_TIME, j]
        else:
            height += w * surf[S_CUR, j]
            time += w * surf[S_TIME, j]
        r = abs(surf[S_RES, j])
        if r > res:
            res = r
    out[0] = height
    out[1] = time
    out[2] = res
