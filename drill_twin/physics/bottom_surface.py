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

Layout (names of :mod:`drill_twin.physics.layout`): ``surf`` (``len(SURFACE)`` × N): rows
``SURFACE.height``, ``previous`` (height before the latest write), ``angle`` (bit angle Φ
at the latest write), ``time``, ``previous_time`` (times of the latest and previous
writes), ``residual`` (Newton residual of the crossing, rad); ``geom`` (``GEOM``): the
period, the node spacing and the smallest blade gap [rad].
"""
from __future__ import annotations

import math

import numpy as np

from .hermite import hermite, hermite_slope
from .jit import kernel_jit
from .layout import GEOM, READ, SURFACE

__all__ = ['new_surface', 'fill_steady', 'fill_flat', 'write_step', 'read_surface',
           'nodes_for']


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
    surf = np.zeros((len(SURFACE), int(nodes)))
    surf[SURFACE.angle] = -np.inf
    geom = np.zeros(len(GEOM))
    geom[GEOM.period], geom[GEOM.spacing] = float(period), float(period) / nodes
    geom[GEOM.min_gap] = float(min_gap)
    return surf, geom


def fill_steady(surf, geom, offsets, upsilon, omega, t0: float = 0.0):
    """The surface of steady drilling at bit angle Φ = ω τ, U = υ τ, at time ``t0``: every
    node as the blades that passed it last (and, for the previous value, before) left it.
    ``offsets``: blade angles on the period (one 0 for an even bit)."""
    period, spacing = geom[GEOM.period], geom[GEOM.spacing]
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
        surf[SURFACE.height, j] = upsilon * t_w
        surf[SURFACE.previous, j] = upsilon * t_p
        surf[SURFACE.angle, j] = best
        surf[SURFACE.time, j] = t_w
        surf[SURFACE.previous_time, j] = t_p
        surf[SURFACE.residual, j] = 0.0


def fill_flat(surf, depth: float, time: float = 0.0):
    """A flat bottom at axial position ``depth`` (d*), never cut by these blades."""
    surf[SURFACE.height] = depth
    surf[SURFACE.previous] = depth
    surf[SURFACE.angle] = -np.inf
    surf[SURFACE.time] = time
    surf[SURFACE.previous_time] = time
    surf[SURFACE.residual] = 0.0


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
def write_step(surf, geom, offsets, t0, t1, b0, b1):
    """Let every blade write the nodes it swept while the bit moved from ``b0`` (a
    :class:`~drill_twin.physics.layout.BitMotion`, at time ``t0``) to ``b1`` (at ``t1``).
    Returns the number of nodes written."""
    u0, u1, p0, p1 = b0.position, b1.position, b0.angle, b1.angle
    du0, du1, dp0, dp1 = b0.velocity, b1.velocity, b0.speed, b1.speed
    if not p1 > p0:
        return 0
    spacing = geom[GEOM.spacing]
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
            surf[SURFACE.previous, j] = surf[SURFACE.height, j]
            surf[SURFACE.previous_time, j] = surf[SURFACE.time, j]
            if u > surf[SURFACE.height, j]:
                surf[SURFACE.height, j] = u
            surf[SURFACE.angle, j] = target
            surf[SURFACE.time, j] = t0 + s * h
            surf[SURFACE.residual, j] = res
            written += 1
    return written


@kernel_jit(inline='always')
def read_surface(surf, geom, phi, offset, out):
    """The rock ahead of the blade at ``offset`` when the bit angle is ``phi``.

    Writes into ``out`` (:data:`~drill_twin.physics.layout.READ`) the surface height S
    (d*), the time at which the preceding blade left it (so the delay is τ minus it) and
    the largest |residual| of the crossings used (rad).
    """
    spacing = geom[GEOM.spacing]
    half_gap = 0.5 * geom[GEOM.min_gap]
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
        if surf[SURFACE.angle, j] > phi - half_gap:
            height += w * surf[SURFACE.previous, j]
            time += w * surf[SURFACE.previous_time, j]
        else:
            height += w * surf[SURFACE.height, j]
            time += w * surf[SURFACE.time, j]
        r = abs(surf[SURFACE.residual, j])
        if r > res:
            res = r
    out[READ.height] = height
    out[READ.time] = time
    out[READ.residual] = res
