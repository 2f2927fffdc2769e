"""Soft-string torque and drag (Johancsik, Friesen & Dawson 1984, SPE-11380-PA).

Derivation: docs/torque_drag.md §3-§6; equation numbers below refer to it.  The string
lies on the low or high side of the hole along the well path (a
:class:`~drill_twin.physics.well_path.WellPath`) with no bending stiffness.  With s the
measured depth [m] (downwards), t, n the tangent and principal normal of the path, κ its
curvature, w the buoyed weight per unit length [N/m], T the effective tension [N] and
M the torque [N·m], the force balance of an element (eq. 8) gives

* normal contact force per unit length (eq. 11)
  N = |T κ n + w (e_V - cos I t)| = hypot(T κ + w n_V, w b_V),   b = t × n,
  equal to Johancsik's sqrt((T A' sin I)² + (T I' - w sin I)²) (eq. 11'),
* tension and torque (eqs 13, 14)
  dT/ds = -(w cos I + μ a N),   dM/ds = -μ b r N,

where the friction μN acts against the sliding velocity of the contact point (eq. 12):
axial speed v (positive up-hole, pick-up) and rim speed ω r, a = v/|V|, b = ω r/|V|,
|V| = hypot(v, ω r).  Pick-up a = 1, slack-off a = -1, pure rotation a = 0, b = 1; any
combination splits the friction along the velocity.  No velocity threshold: at rest
the friction is set-valued and no direction is given, so a motion at rest is refused.
Boundary at the bit (eq. 15): T = -WOB, M = TOB; the hook load is T at MD 0 (without
the travelling block), the surface torque M at MD 0.

Numerical method (§6): classical fourth-order Runge-Kutta on eq. 13 from the bit up,
on a grid whose nodes include every survey station, section joint and requested node
(so the right-hand side is analytic on every step, eq. 5), steps ≤ ``max_step_m``;
global error O(h⁴), except for the steps where the contact force passes through zero
(its kink, |·| in eq. 11), which are O(h²) locally.  The torque (eq. 14) is integrated
with the same stages (Simpson's weights).  Pure numerics: numpy and scipy.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from ..errors import ParameterError
from .parameters import GRAVITY_M_S2, checked_number
from .well_path import WellPath

__all__ = ['Motion', 'PICK_UP', 'SLACK_OFF', 'ROTATING', 'TorqueDragResult',
           'BroomstickChart', 'buoyed_weight_N_m', 'torque_drag', 'wob_for_hook_load',
           'broomstick', 'DEFAULT_STEP_M']

#: default largest integration step [m]
DEFAULT_STEP_M = 2.0


def _finite(name: str, value, minimum: float | None = None) -> float:
    return checked_number(name, value, minimum)


@dataclass(frozen=True)
class Motion:
    """Motion of the string against the wall (eq. 12).

    Parameters
    ----------
    axial_speed_m_s : float
        Axial speed [m/s], positive up-hole (pulling out, pick-up), negative down-hole
        (running in, slack-off, drilling).
    rotary_speed_rad_s : float
        Rotary speed ω [rad/s]; the torque has its sign.
    """

    axial_speed_m_s: float
    rotary_speed_rad_s: float

    def __post_init__(self):
        v = _finite('axial_speed_m_s', self.axial_speed_m_s)
        w = _finite('rotary_speed_rad_s', self.rotary_speed_rad_s)
        if v == 0.0 and w == 0.0:
            raise ParameterError('a string at rest has set-valued wall friction: give an axial '
                                 'or a rotary speed (the direction of sliding)')

    def friction_split(self, outer_radius_m) -> tuple[np.ndarray, np.ndarray]:
        """Axial and tangential fractions a = v/|V|, b = ω r/|V| of μN (eq. 12) at pipe
        radius ``outer_radius_m`` [m]."""
        r = np.asarray(outer_radius_m, dtype=float)
        rim = self.rotary_speed_rad_s * r
        speed = np.hypot(self.axial_speed_m_s, rim)
        return self.axial_speed_m_s / speed, rim / speed


#: tripping out without rotation, tripping in without rotation, rotating in place
PICK_UP = Motion(1.0, 0.0)
SLACK_OFF = Motion(-1.0, 0.0)
ROTATING = Motion(0.0, 1.0)
_NAMED = {'pick_up': PICK_UP, 'slack_off': SLACK_OFF, 'rotating': ROTATING}


def _motion(motion) -> Motion:
    if isinstance(motion, Motion):
        return motion
    if isinstance(motion, str) and motion in _NAMED:
        return _NAMED[motion]
    raise ParameterError(f'motion must be a Motion or one of {sorted(_NAMED)}, got {motion!r}')


def buoyed_weight_N_m(section, mud_density_kg_m3: float,
                      gravity_m_s2: float = GRAVITY_M_S2) -> float:
    """Buoyed weight per unit length w = ρ g A (1 - ρ_mud/ρ) [N/m] of a section (eq. 7).

    ``section``: any object with ``outer_diameter_m``, ``inner_diameter_m`` and
    ``density_kg_m3`` (e.g. :class:`~drill_twin.physics.parameters.StringSection`).
    """
    od = _finite('outer_diameter_m', section.outer_diameter_m, 0.0)
    inner = _finite('inner_diameter_m', section.inner_diameter_m, 0.0)
    rho = _finite('density_kg_m3', section.density_kg_m3, 0.0)
    mud = _finite('mud_density_kg_m3', mud_density_kg_m3, 0.0)
    if inner >= od:
        raise ParameterError(f'inner_diameter_m {inner:g} m must be below outer_diameter_m '
                             f'{od:g} m')
    if rho <= 0.0:
        raise ParameterError(f'density_kg_m3 must be positive, got {rho:g}')
    if mud > rho:
        raise ParameterError(f'mud density {mud:g} kg/m^3 exceeds the section density '
                             f'{rho:g} kg/m^3 (the string would float)')
    area = math.pi / 4.0 * (od * od - inner * inner)
    return rho * gravity_m_s2 * area * (1.0 - mud / rho)


@dataclass(frozen=True, eq=False)
class TorqueDragResult:
    """Soft-string profile from the surface (index 0) to the bit (index -1).

    Attributes
    ----------
    measured_depth_m : ndarray
        Nodes s [m], increasing.
    tension_N : ndarray
        Effective tension T [N] (eq. 13), positive in tension.
    normal_force_N_m : ndarray
        Wall contact force per unit length N [N/m] (eq. 11); at a station or joint the
        value on its down-hole side (at the bit: the up-hole side).
    torque_Nm : ndarray
        Torque M [N·m] (eq. 14).
    """

    measured_depth_m: np.ndarray
    tension_N: np.ndarray
    normal_force_N_m: np.ndarray
    torque_Nm: np.ndarray

    @property
    def hook_load_N(self) -> float:
        """Tension at MD 0 [N] (the travelling block's own weight not included)."""
        return float(self.tension_N[0])

    @property
    def surface_torque_Nm(self) -> float:
        """Torque at MD 0 [N·m]."""
        return float(self.torque_Nm[0])


@dataclass(frozen=True, eq=False)
class BroomstickChart:
    """Hook load [N] and off-bottom rotating surface torque [N·m] against bit depth.

    Arrays are (friction factor, bit depth); ``rotating_N`` does not depend on μ in the
    pure-rotation soft-string model (eq. 13 with a = 0) and is repeated for each.
    """

    bit_depth_m: np.ndarray
    friction_factor: np.ndarray
    pick_up_N: np.ndarray
    slack_off_N: np.ndarray
    rotating_N: np.ndarray
    rotating_torque_Nm: np.ndarray


# --- the string along the hole --------------------------------------------------------
def _layout(sections: Sequence, bit_depth_m: float, mud: float, gravity: float):
    """Section tops [m] (MD, clipped at 0), w [N/m], r [m] of the sections below MD 0,
    top to bottom; the string hangs from the bit, the part above the surface is cut."""
    if len(sections) == 0:
        raise ParameterError('the string needs at least one section')
    lengths = np.array([_finite('section length_m', sec.length_m, 0.0) for sec in sections])
    if np.any(lengths <= 0.0):
        raise ParameterError('section lengths must be positive')
    if lengths.sum() < bit_depth_m:
        raise ParameterError(f'the string ({lengths.sum():g} m) is shorter than the bit depth '
                             f'({bit_depth_m:g} m)')
    bottoms = bit_depth_m - (lengths.sum() - np.cumsum(lengths))
    keep = bottoms > 0.0
    tops = np.maximum(bottoms - lengths, 0.0)[keep]
    w = np.array([buoyed_weight_N_m(sec, mud, gravity) for sec in sections])[keep]
    r = np.array([0.5 * sec.outer_diameter_m for sec in sections])[keep]
    return tops, w, r


def _grid(path: WellPath, tops: np.ndarray, bit_depth_m: float, max_step_m: float, nodes):
    """Nodes from MD 0 to the bit: breakpoints (stations, joints, requested nodes)
    subdivided into equal steps ≤ max_step_m."""
    extra = np.asarray(nodes, dtype=float).ravel()
    if not np.all(np.isfinite(extra)):
        raise ParameterError('nodes_m must be finite measured depths')
    marks = np.concatenate([path.measured_depth_m, tops, extra])
    marks = np.union1d([0.0, bit_depth_m], marks[(marks > 0.0) & (marks < bit_depth_m)])
    counts = np.maximum(np.ceil(np.diff(marks) / max_step_m).astype(int), 1)
    first = np.repeat(np.cumsum(counts) - counts, counts)
    within = np.arange(counts.sum()) - first
    s = np.repeat(marks[:-1], counts) + within * np.repeat(np.diff(marks) / counts, counts)
    return np.append(s, bit_depth_m)


def _geometry(path: WellPath, s: np.ndarray, leg: np.ndarray) -> np.ndarray:
    """(cos I, κ, n_V, b_V) at depths s on the given legs (eq. 11: on a straight leg
    n = 0 and b_V stands for sin I, the whole normal weight)."""
    t, n, kappa = path.frame(s, leg)
    b_v = t[..., 0] * n[..., 1] - t[..., 1] * n[..., 0]
    sin_i = np.hypot(t[..., 0], t[..., 1])
    return np.stack([t[..., 2], kappa, n[..., 2], np.where(kappa > 0.0, b_v, sin_i)])


def _normal_force(T, g, w):
    """Eq. 11: N = hypot(T κ + w n_V, w b_V) [N/m]."""
    return np.hypot(T * g[1] + w * g[2], w * g[3])


def _march(s, geo, w, mu_a, T_bit):
    """RK4 on eq. 13 from the bit (node -1) to the surface (node 0); returns T at the
    nodes (K+1, B) and N at the four stages of every step (K, 4, B)."""
    K, B = s.size - 1, T_bit.size
    T = np.empty((K + 1, B))
    stages = np.empty((K, 4, B))
    h = np.diff(s).tolist()
    rows = np.concatenate([geo[0].T, geo[1].T, geo[2].T, w[:, None]], axis=1).tolist()
    for b in range(B):
        T[:, b], stages[:, :, b] = _march_one(h, rows, mu_a[:, b].tolist(), float(T_bit[b]))
    return T, stages


def _march_one(h, rows, mu_a, tension):
    """One solution of eq. 13, scalar arithmetic (the loop is sequential in s).  ``rows``:
    per step (cos I, κ, n_V, b_V) at its bottom, middle and top, then w; ``h`` > 0."""
    hypot = math.hypot
    K = len(h)
    T = [0.0] * (K + 1)
    stages = [None] * K
    T[K] = tension
    for k in range(K - 1, -1, -1):
        cb, kb, pb, qb, cm, km, pm, qm, ct, kt, pt, qt, wk = rows[k]
        hk, ma, t = h[k], mu_a[k], T[k + 1]
        n1 = hypot(t * kb + wk * pb, wk * qb)
        t2 = t + 0.5 * hk * (wk * cb + ma * n1)
        n2 = hypot(t2 * km + wk * pm, wk * qm)
        t3 = t + 0.5 * hk * (wk * cm + ma * n2)
        n3 = hypot(t3 * km + wk * pm, wk * qm)
        t4 = t + hk * (wk * cm + ma * n3)
        n4 = hypot(t4 * kt + wk * pt, wk * qt)
        T[k] = t + hk / 6.0 * (wk * (cb + 4.0 * cm + ct) + ma * (n1 + 2.0 * (n2 + n3) + n4))
        stages[k] = (n1, n2, n3, n4)
    return T, stages


def _check_grid_inputs(path, bit_depth_m, max_step_m) -> tuple[float, float]:
    if not isinstance(path, WellPath):
        raise ParameterError('path must be a WellPath')
    D = _finite('bit_depth_m', bit_depth_m)
    if not 0.0 < D <= path.total_depth_m:
        raise ParameterError(f'bit_depth_m must lie in (0, {path.total_depth_m:g}] m, got {D:g}')
    step = _finite('max_step_m', max_step_m)
    if step <= 0.0:
        raise ParameterError(f'max_step_m must be positive, got {step:g}')
    return D, step


def _solve(path, sections, bit_depth_m, mus, motions, mud, wob, tob, gravity, max_step_m,
           nodes=()):
    """Batch of soft-string solutions, one per (μ, motion), on one grid: nodes s (K+1,)
    and T, N, M at the nodes (K+1, B)."""
    D, step = _check_grid_inputs(path, bit_depth_m, max_step_m)
    tops, w_sec, r_sec = _layout(sections, D, _finite('mud_density_kg_m3', mud, 0.0),
                                 _finite('gravity_m_s2', gravity, 0.0))
    s = _grid(path, tops, D, step, nodes)
    mid = 0.5 * (s[:-1] + s[1:])
    leg, sec = path.leg_index(mid), np.searchsorted(tops, mid, side='right') - 1
    geo = [_geometry(path, x, leg) for x in (s[1:], mid, s[:-1])]
    split = np.array([m.friction_split(r_sec[sec]) for m in motions])   # (B, 2, K)
    mu = np.asarray(mus, float)[:, None]
    w = w_sec[sec]
    T, stages = _march(s, geo, w, (mu * split[:, 0]).T,
                       np.full(mu.size, -_finite('weight_on_bit_N', wob)))
    M = _torque(s, stages, (mu * split[:, 1]).T * r_sec[sec][:, None],
                _finite('torque_on_bit_Nm', tob))
    w = w[:, None]
    N = np.vstack([_normal_force(T[:-1], geo[2][..., None], w),
                   _normal_force(T[-1:], geo[0][:, -1:, None], w[-1:])])
    return s, T, N, M


def _torque(s, stages, mu_b_r, tob):
    """Eq. 14 on the RK stages (Simpson's weights), from M(bit) = TOB up."""
    simpson = (stages[:, 0] + 2 * stages[:, 1] + 2 * stages[:, 2] + stages[:, 3]) / 6.0
    dM = np.diff(s)[:, None] * mu_b_r * simpson
    return tob + np.vstack([np.cumsum(dM[::-1], axis=0)[::-1], np.zeros((1, dM.shape[1]))])


def torque_drag(path: WellPath, sections: Sequence, bit_depth_m: float,
                friction_factor: float, motion, mud_density_kg_m3: float,
                weight_on_bit_N: float = 0.0, torque_on_bit_Nm: float = 0.0, *,
                gravity_m_s2: float = GRAVITY_M_S2, max_step_m: float = DEFAULT_STEP_M,
                nodes_m=()) -> TorqueDragResult:
    """Soft-string tension, contact force and torque along the string (eqs 11-15).

    Parameters
    ----------
    path : WellPath
        The well trajectory.
    sections : sequence of StringSection
        The string top to bottom (``length_m``, ``outer_diameter_m``, ``inner_diameter_m``,
        ``density_kg_m3``); it hangs from the bit and the part that would stand above MD 0
        is left out, so a long top section serves every bit depth.
    bit_depth_m : float
        Measured depth of the bit [m], in (0, path.total_depth_m].
    friction_factor : float
        Coulomb friction factor μ ≥ 0 between string and wall.
    motion : Motion or {'pick_up', 'slack_off', 'rotating'}
        Direction of sliding (eq. 12).
    mud_density_kg_m3 : float
        Mud density for the buoyed weight [kg/m³] (eq. 7).
    weight_on_bit_N, torque_on_bit_Nm : float
        Bit boundary (eq. 15): T(bit) = -WOB [N] (negative WOB: a pull at the bit),
        M(bit) = TOB [N·m]; 0 off bottom.
    gravity_m_s2 : float
        Gravitational acceleration [m/s²] (0: a weightless string, the capstan limit).
    max_step_m : float
        Largest Runge-Kutta step [m] (method: module docstring, §6).
    nodes_m : array_like
        Extra measured depths [m] to place nodes at (all stations and joints are nodes).

    Returns
    -------
    TorqueDragResult
        Profiles from MD 0 to the bit, ``hook_load_N`` and ``surface_torque_Nm``.
    """
    mu = _finite('friction_factor', friction_factor, 0.0)
    s, T, N, M = _solve(path, sections, bit_depth_m, [mu], [_motion(motion)],
                        mud_density_kg_m3, weight_on_bit_N, torque_on_bit_Nm, gravity_m_s2,
                        max_step_m, nodes_m)
    return TorqueDragResult(s, T[:, 0], N[:, 0], M[:, 0])


def wob_for_hook_load(path: WellPath, sections: Sequence, bit_depth_m: float,
                      hook_load_N: float, friction_factor: float, motion,
                      mud_density_kg_m3: float, **options) -> float:
    """Weight on bit [N] delivered at a given hook load [N] (inverse of eq. 15 → 13).

    The hook load decreases strictly with the WOB (the solutions of the scalar eq. 13
    do not cross, §5), so the root is bracketed between WOB = 0 (the off-bottom hook
    load H_0) and a WOB doubled from H_0 - H until the hook load falls below the target,
    and found by Brent's method (``scipy.optimize.brentq``, to 1e-9 N + 1e-12 relative).
    ``options``: the keywords of :func:`torque_drag` (``torque_on_bit_Nm``,
    ``gravity_m_s2``, ``max_step_m``).  Drilling: ``motion`` = Motion(-ROP, ω), or ROTATING /
    SLACK_OFF for rotary and slide drilling.

    Raises
    ------
    ParameterError
        If the hook load exceeds the off-bottom one (the bit would be off bottom) or
        60 doublings of the WOB do not reach it.
    """
    target = _finite('hook_load_N', hook_load_N)

    def excess(wob):
        return torque_drag(path, sections, bit_depth_m, friction_factor, motion,
                           mud_density_kg_m3, wob, **options).hook_load_N - target

    free = excess(0.0)
    if free <= 0.0:
        if free == 0.0:
            return 0.0
        raise ParameterError(f'hook load {target:g} N exceeds the off-bottom hook load '
                             f'{target + free:g} N: the bit is off bottom')
    hi = max(free, 1.0)
    for _ in range(60):
        if excess(hi) < 0.0:
            return brentq(excess, 0.0, hi, xtol=1e-9, rtol=1e-12)
        hi *= 2.0
    raise ParameterError(f'no weight on bit brings the hook load down to {target:g} N')


def broomstick(path: WellPath, sections: Sequence, bit_depths_m, mud_density_kg_m3: float,
               friction_factors=(0.1, 0.2, 0.3, 0.4), *, gravity_m_s2: float = GRAVITY_M_S2,
               max_step_m: float = DEFAULT_STEP_M) -> BroomstickChart:
    """The hook-load "broomstick" chart: pick-up, slack-off and rotating hook load off
    bottom (WOB = TOB = 0) against bit depth, one curve per friction factor, and the
    rotating off-bottom surface torque.

    Parameters
    ----------
    path, sections, mud_density_kg_m3, gravity_m_s2, max_step_m
        As for :func:`torque_drag`.
    bit_depths_m : array_like
        Bit depths [m], each in (0, path.total_depth_m].
    friction_factors : array_like
        Friction factors μ ≥ 0.
    """
    depths = np.array(bit_depths_m, dtype=float, ndmin=1)
    mus = np.array([_finite('friction factor', m, 0.0) for m in np.ravel(friction_factors)])
    if depths.ndim != 1 or depths.size == 0 or mus.size == 0:
        raise ParameterError('bit_depths_m and friction_factors must be non-empty 1-D lists')
    motions = [PICK_UP] * mus.size + [SLACK_OFF] * mus.size + [ROTATING] * mus.size
    batch = np.tile(mus, 3)
    hook = np.empty((3 * mus.size, depths.size))
    torque = np.empty((mus.size, depths.size))
    for i, depth in enumerate(depths):
        _, T, _, M = _solve(path, sections, depth, batch, motions, mud_density_kg_m3, 0.0,
                            0.0, gravity_m_s2, max_step_m)
        hook[:, i] = T[0]
        torque[:, i] = M[0, 2 * mus.size:]
    m = mus.size
    return BroomstickChart(depths, mus, hook[:m], hook[m:2 * m], hook[2 * m:], torque)
