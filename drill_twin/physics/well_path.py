"""Well path from a directional survey by the minimum-curvature method.

A survey is a list of stations: measured depth s_k [m] along the hole, inclination
I_k [rad] from the vertical and azimuth A_k [rad] from north, clockwise seen from
above.  Positions are (north, east, TVD) [m], TVD positive downwards (a right-handed
frame), with the first station at the surface, MD 0, position (0, 0, 0).

Minimum curvature (docs/torque_drag.md §2) joins consecutive stations by the circular
arc tangent to both station tangents:

* unit tangent (eq. 1)   t = (sin I cos A, sin I sin A, cos I);
* dogleg (eq. 2)         β = arccos(cos(I2 - I1) - sin I1 sin I2 (1 - cos(A2 - A1))),
  evaluated as β = atan2(|t1 × t2|, t1 · t2) (eq. 2', the same angle, accurate at
  every β);
* ratio factor (eq. 3)   RF = (2/β) tan(β/2), RF → 1 + β²/12 as β → 0;
* station step (eq. 4)   Δr = (Δs/2) RF (t1 + t2);
* on the arc (eq. 5), φ = β (s - s1)/Δs, u the unit normal at the start of the arc:
  t(s) = cos φ t1 + sin φ u,  n(s) = -sin φ t1 + cos φ u,
  r(s) = r1 + R (sin φ t1 + (1 - cos φ) u),  R = Δs/β;
* curvature (eq. 6)      κ = β/Δs [1/m], constant on each leg (the dogleg severity);
  at a station it jumps: a leg is [s_k, s_k+1), the last one closed.

Pure numerics: numpy only.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import ParameterError

__all__ = ['WellPath', 'unit_tangent', 'dogleg_rad', 'ratio_factor',
           'piecewise_linear_inclination_path', 'well_b_path']


def unit_tangent(inclination_rad, azimuth_rad) -> np.ndarray:
    """Unit tangent (north, east, TVD) of the hole, eq. 1; shape ``(..., 3)``."""
    inc = np.asarray(inclination_rad, dtype=float)
    azi = np.asarray(azimuth_rad, dtype=float)
    return np.stack([np.sin(inc) * np.cos(azi), np.sin(inc) * np.sin(azi), np.cos(inc)],
                    axis=-1)


def _angle_between(t1: np.ndarray, t2: np.ndarray) -> np.ndarray:
    """Angle between unit vectors (eq. 2'): atan2(|t1 × t2|, t1·t2) [rad]."""
    cross = np.linalg.norm(np.cross(t1, t2), axis=-1)
    return np.arctan2(cross, np.sum(t1 * t2, axis=-1))


def dogleg_rad(inclination1_rad, azimuth1_rad, inclination2_rad, azimuth2_rad) -> np.ndarray:
    """Dogleg β [rad] between two survey stations (eq. 2, evaluated as eq. 2')."""
    return _angle_between(unit_tangent(inclination1_rad, azimuth1_rad),
                          unit_tangent(inclination2_rad, azimuth2_rad))


def ratio_factor(dogleg_rad) -> np.ndarray:
    """Minimum-curvature ratio factor RF = (2/β) tan(β/2) (eq. 3), its series
    1 + β²/12 + β⁴/120 below β = 1e-4 (truncation < 1e-27); ``inf`` at β = π."""
    beta = np.asarray(dogleg_rad, dtype=float)
    half = 0.5 * beta
    small = np.abs(beta) < 1e-4
    with np.errstate(divide='ignore', invalid='ignore'):
        exact = np.tan(half) / np.where(small, 1.0, half)
    series = 1.0 + beta ** 2 / 12.0 + beta ** 4 / 120.0
    return np.where(small, series, np.where(beta >= math.pi, np.inf, exact))


def _arc_coefficients(phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """sin φ / φ and (1 - cos φ)/φ, exact at φ = 0 (np.sinc(x) = sin πx / πx)."""
    sin_over = np.sinc(phi / math.pi)
    one_minus_cos_over = 0.5 * phi * np.sinc(phi / (2 * math.pi)) ** 2
    return sin_over, one_minus_cos_over


def _as_vector(name: str, value) -> np.ndarray:
    arr = np.array(value, dtype=float, ndmin=1)
    if arr.ndim != 1:
        raise ParameterError(f'{name} must be a 1-D array, got shape {arr.shape}')
    if not np.all(np.isfinite(arr)):
        raise ParameterError(f'{name} must be finite, got {arr[~np.isfinite(arr)][0]!r}')
    return arr


def _check_survey(md: np.ndarray, inc: np.ndarray, azi: np.ndarray) -> None:
    if not md.size == inc.size == azi.size:
        raise ParameterError(f'survey arrays differ in length: {md.size} measured depths, '
                             f'{inc.size} inclinations, {azi.size} azimuths')
    if md.size < 2:
        raise ParameterError(f'a survey needs at least 2 stations, got {md.size}')
    if md[0] != 0.0:
        raise ParameterError(f'the first station must be the surface, MD 0 m, got {md[0]:g} m '
                             '(prepend a station (0, 0, 0))')
    if np.any(np.diff(md) <= 0.0):
        k = int(np.argmax(np.diff(md) <= 0.0))
        raise ParameterError(f'measured depths must increase strictly: station {k + 1} at '
                             f'{md[k + 1]:g} m follows {md[k]:g} m')
    bad = (inc < 0.0) | (inc > math.pi)
    if np.any(bad):
        raise ParameterError(f'inclination must lie in [0, pi] rad, got {inc[bad][0]:g} rad '
                             f'at MD {md[bad][0]:g} m')


@dataclass(frozen=True, eq=False)
class WellPath:
    """Trajectory of a well from its survey by minimum curvature (eqs 1-6).

    Parameters
    ----------
    measured_depth_m : array_like
        Station measured depths s_k [m], strictly increasing, the first one 0 (surface).
    inclination_rad : array_like
        Station inclinations I_k [rad] from the vertical, 0 ≤ I ≤ π.
    azimuth_rad : array_like
        Station azimuths A_k [rad] from north, clockwise seen from above (any finite
        value; irrelevant where the hole is vertical).

    Raises
    ------
    ParameterError
        On non-finite values, arrays of different length, fewer than two stations, a
        first station not at MD 0, measured depths not strictly increasing, an
        inclination outside [0, π] or a leg between opposite tangents (β = π).

    Notes
    -----
    The derived station data are attributes: ``north_m``, ``east_m``, ``tvd_m`` [m],
    ``tangent_stations`` (k, 3), ``dogleg_rad`` and ``curvature_per_m`` per leg.
    Evaluation methods take measured depths (scalar or array) in [0, ``total_depth_m``]
    and return arrays of the same shape (vectors: one trailing axis of 3).
    """

    measured_depth_m: np.ndarray
    inclination_rad: np.ndarray
    azimuth_rad: np.ndarray
    north_m: np.ndarray = field(init=False, repr=False)
    east_m: np.ndarray = field(init=False, repr=False)
    tvd_m: np.ndarray = field(init=False, repr=False)
    tangent_stations: np.ndarray = field(init=False, repr=False)
    dogleg_rad: np.ndarray = field(init=False, repr=False)
    curvature_per_m: np.ndarray = field(init=False, repr=False)
    _start_normal: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        md = _as_vector('measured_depth_m', self.measured_depth_m)
        inc = _as_vector('inclination_rad', self.inclination_rad)
        azi = _as_vector('azimuth_rad', self.azimuth_rad)
        _check_survey(md, inc, azi)
        t = unit_tangent(inc, azi)
        beta, u = self._legs(md, t)
        ds = np.diff(md)
        steps = 0.5 * ds[:, None] * ratio_factor(beta)[:, None] * (t[:-1] + t[1:])  # eq. 4
        pos = np.vstack([np.zeros(3), np.cumsum(steps, axis=0)])
        values = {'measured_depth_m': md, 'inclination_rad': inc, 'azimuth_rad': azi,
                  'north_m': pos[:, 0], 'east_m': pos[:, 1], 'tvd_m': pos[:, 2],
                  'tangent_stations': t, 'dogleg_rad': beta, 'curvature_per_m': beta / ds,
                  '_start_normal': u}
        for name, value in values.items():
            value = np.array(value)
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    @staticmethod
    def _legs(md: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Dogleg β (eq. 2') and start normal u = unit(t2 - (t1·t2) t1) of every leg."""
        t1, t2 = t[:-1], t[1:]
        beta = _angle_between(t1, t2)
        cross = np.linalg.norm(np.cross(t1, t2), axis=-1)
        opposite = (cross < 1e-12) & (np.sum(t1 * t2, axis=-1) < 0.0)
        if np.any(opposite):
            k = int(np.argmax(opposite))
            raise ParameterError(f'the leg from MD {md[k]:g} m to {md[k + 1]:g} m joins '
                                 'opposite tangents (dogleg pi): its arc is undefined')
        d = t2 - t1
        u = d - np.sum(d * t1, axis=-1, keepdims=True) * t1
        norm = np.linalg.norm(u, axis=-1, keepdims=True)
        u = np.divide(u, norm, out=np.zeros_like(u), where=norm > 0.0)
        return np.where(norm[:, 0] > 0.0, beta, 0.0), u

    # --- construction --------------------------------------------------------------
    @classmethod
    def vertical(cls, depth_m: float) -> WellPath:
        """A vertical well of measured depth ``depth_m`` [m] (the default well)."""
        depth = float(depth_m)
        if not math.isfinite(depth) or depth <= 0.0:
            raise ParameterError(f'depth_m must be a positive finite number, got {depth_m!r}')
        return cls(np.array([0.0, depth]), np.zeros(2), np.zeros(2))

    def resample(self, measured_depth_m) -> WellPath:
        """The same trajectory with stations added at ``measured_depth_m`` [m] (on the
        arcs, eq. 5): positions, tangents and curvature are unchanged."""
        extra = self._check_md(measured_depth_m).ravel()
        md = np.union1d(self.measured_depth_m, extra)
        return WellPath(md, self.inclination(md), self.azimuth(md))

    # --- evaluation ----------------------------------------------------------------
    @property
    def total_depth_m(self) -> float:
        """Measured depth of the last station [m]."""
        return float(self.measured_depth_m[-1])

    @property
    def station_position_m(self) -> np.ndarray:
        """Station positions (north, east, TVD) [m], shape (k, 3)."""
        return np.stack([self.north_m, self.east_m, self.tvd_m], axis=-1)

    def _check_md(self, measured_depth_m) -> np.ndarray:
        md = np.asarray(measured_depth_m, dtype=float)
        if not np.all(np.isfinite(md)):
            raise ParameterError('measured depths must be finite')
        if np.any((md < 0.0) | (md > self.total_depth_m)):
            raise ParameterError(f'measured depths must lie in [0, {self.total_depth_m:g}] m, '
                                 f'got {md.min():g} to {md.max():g} m')
        return md

    def leg_index(self, measured_depth_m) -> np.ndarray:
        """Index of the leg holding each depth: leg k is [s_k, s_k+1), the last closed."""
        md = self._check_md(measured_depth_m)
        j = np.searchsorted(self.measured_depth_m, md, side='right') - 1
        return np.clip(j, 0, self.measured_depth_m.size - 2)

    def _arc(self, measured_depth_m, leg=None):
        md = self._check_md(measured_depth_m)
        j = self.leg_index(md) if leg is None else np.broadcast_to(np.asarray(leg), md.shape)
        s0 = self.measured_depth_m[j]
        phi = self.curvature_per_m[j] * (md - s0)
        return md, j, s0, phi

    def frame(self, measured_depth_m, leg=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Tangent t, principal normal n (zero on a straight leg) and curvature κ [1/m]
        at ``measured_depth_m`` (eqs 5, 6).

        ``leg`` (optional, integer array broadcast to the depths): evaluate on that leg's
        arc instead of the one holding the depth — the one-sided value at a station.
        """
        _, j, _, phi = self._arc(measured_depth_m, leg)
        t1, u = self.tangent_stations[j], self._start_normal[j]
        c, s = np.cos(phi)[..., None], np.sin(phi)[..., None]
        return c * t1 + s * u, c * u - s * t1, self.curvature_per_m[j]

    def tangent(self, measured_depth_m) -> np.ndarray:
        """Unit tangent (north, east, TVD) at the depths, shape (..., 3) (eq. 5)."""
        return self.frame(measured_depth_m)[0]

    def normal(self, measured_depth_m) -> np.ndarray:
        """Principal unit normal n = (dt/ds)/κ, zero on straight legs (eq. 5)."""
        return self.frame(measured_depth_m)[1]

    def curvature(self, measured_depth_m) -> np.ndarray:
        """Curvature κ = β/Δs [1/m] of the leg holding each depth (dogleg severity, eq. 6)."""
        return self.curvature_per_m[self.leg_index(measured_depth_m)]

    def position(self, measured_depth_m) -> np.ndarray:
        """Position (north, east, TVD) [m] on the minimum-curvature arcs, shape (..., 3)
        (eq. 5; at the stations the positions of eq. 4)."""
        md, j, s0, phi = self._arc(measured_depth_m)
        sin_over, cos_over = _arc_coefficients(phi)
        arc = (md - s0)[..., None]
        t1, u = self.tangent_stations[j], self._start_normal[j]
        return self.station_position_m[j] + arc * (sin_over[..., None] * t1
                                                   + cos_over[..., None] * u)

    def inclination(self, measured_depth_m) -> np.ndarray:
        """Inclination I = atan2(√(t_N² + t_E²), t_V) [rad] of the arc at the depths."""
        t = self.tangent(measured_depth_m)
        return np.arctan2(np.hypot(t[..., 0], t[..., 1]), t[..., 2])

    def azimuth(self, measured_depth_m) -> np.ndarray:
        """Azimuth A = atan2(t_E, t_N) in [0, 2π) [rad] of the arc (0 where vertical)."""
        t = self.tangent(measured_depth_m)
        horizontal = np.hypot(t[..., 0], t[..., 1]) > 0.0
        azi = np.mod(np.arctan2(t[..., 1], t[..., 0]), 2 * math.pi)
        return np.where(horizontal, azi, 0.0)


def piecewise_linear_inclination_path(knot_measured_depth_m, knot_inclination_rad,
                                      total_depth_m: float, station_spacing_m: float = 10.0,
                                      azimuth_rad: float = 0.0) -> WellPath:
    """A planar well whose inclination is piecewise linear in measured depth.

    Parameters
    ----------
    knot_measured_depth_m, knot_inclination_rad : array_like
        Knots of I(s) [m], [rad]: linear between knots, constant before the first and
        after the last.
    total_depth_m : float
        Measured depth of the last station [m].
    station_spacing_m : float
        Station interval [m]; the knots are stations too, so every leg has constant
        build rate and minimum curvature reproduces the profile exactly.
    azimuth_rad : float
        Constant azimuth [rad].
    """
    knots = _as_vector('knot_measured_depth_m', knot_measured_depth_m)
    incs = _as_vector('knot_inclination_rad', knot_inclination_rad)
    if knots.size != incs.size or np.any(np.diff(knots) <= 0.0):
        raise ParameterError('inclination knots: equal lengths and strictly increasing MD')
    td, spacing = float(total_depth_m), float(station_spacing_m)
    if not (math.isfinite(td) and td > 0.0 and math.isfinite(spacing) and spacing > 0.0):
        raise ParameterError('total_depth_m and station_spacing_m must be positive and finite')
    grid = np.linspace(0.0, td, max(2, math.ceil(td / spacing) + 1))
    md = np.union1d(grid, knots[(knots > 0.0) & (knots < td)])
    return WellPath(md, np.interp(md, knots, incs), np.full(md.size, float(azimuth_rad)))


def well_b_path(station_spacing_m: float = 10.0) -> WellPath:
    """The issue-33 case (Aarsnes & Shor's Well B): vertical to 500 m, inclination
    linear to 60° at 1,600 m, 60° below, MD 2,500 m, azimuth 0 (north)."""
    return piecewise_linear_inclination_path(
        [0.0, 500.0, 1600.0], [0.0, 0.0, math.radians(60.0)], 2500.0, station_spacing_m)
