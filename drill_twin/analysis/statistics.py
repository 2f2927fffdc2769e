"""Stick-slip statistics of a recorded run, and conversion to SI output units."""
from __future__ import annotations

import numpy as np

from ..config.scenario import Scenario
from ..errors import ParameterError
from ..physics.simulation import Trajectory

__all__ = ['output_series', 'stick_slip_summary', 'SERIES_UNITS']

#: channel -> (SI unit, dimensionless unit, scale attribute of :class:`Scales`)
SERIES_UNITS = {
    'time': ('s', 't*', 'time_s'),
    'bit_axial_speed': ('m/s', 'd*/t*', 'speed_m_s'),
    'bit_angular_speed': ('rad/s', '1/t*', 'inv_time'),
    'weight_on_bit': ('N', 'W*', 'force_N'),
    'torque_on_bit': ('N*m', 'C', 'torque_Nm'),
    'depth_of_cut': ('m', 'd*', 'depth_m'),
    'delay': ('s', 't*', 'time_s'),
    'delay_residual': ('rad', 'rad', None),
    'surface_torque': ('N*m', 'C', 'torque_Nm'),
    'motor_torque': ('N*m', 'C', 'torque_Nm'),
    'surface_speed': ('rad/s', '1/t*', 'inv_time'),
    'top_drive_speed': ('rad/s', '1/t*', 'inv_time'),
    'top_axial_speed': ('m/s', 'd*/t*', 'speed_m_s'),
    'bit_axial_perturbation': ('m', 'd*', 'depth_m'),
    'bit_angle_perturbation': ('rad', 'rad', None),
    'angular_stick': ('1', '1', None),
    'axial_mode': ('1', '1', None),
    'contact': ('1', '1', None),
    'stick_time': ('s', 't*', 'time_s'),
}


def output_series(scenario: Scenario, traj: Trajectory) -> dict:
    """Recorded channels in the configuration's units (SI, or dimensionless)."""
    out = {}
    s = scenario.scales
    for name, (_, _, attr) in SERIES_UNITS.items():
        src = traj.tau if name == 'time' else getattr(traj, name)
        factor = 1.0
        if s is not None and attr is not None:
            factor = 1.0 / s.time_s if attr == 'inv_time' else getattr(s, attr)
        out[name] = np.asarray(src) * factor
    return out


def stick_slip_summary(series: dict, stats_from: float = 0.0) -> dict:
    """Statistics over ``time >= stats_from`` (same units as ``series``).

    Returns ``first_angular_stick`` (time of the first recorded angular stick
    in the window, None if none), ``stick_fraction`` (fraction of the window
    with the bit stuck angularly, from the exact accumulated stick time),
    ``bit_speed_max/min/mean``, ``severity``
    = (max - min)/(2 mean) of the bit angular speed, ``rop_mean`` (mean bit
    axial speed) and ``delay_residual_max`` (max |residual of eq. 2.4.14|).
    """
    t = series['time']
    w = t >= stats_from
    if not np.any(w):
        raise ParameterError(f'no recorded samples after stats_from = {stats_from}')
    om = series['bit_angular_speed'][w]
    stick = series['angular_stick'][w] > 0.5
    first = float(t[w][np.argmax(stick)]) if stick.any() else None
    # exact stick time from the kernel's event-located accumulator
    i0 = np.argmax(w)
    cum = series['stick_time']
    span = t[-1] - (t[i0 - 1] if i0 > 0 else 0.0)
    stuck = cum[-1] - (cum[i0 - 1] if i0 > 0 else 0.0)
    mean = float(om.mean())
    return {
        'first_angular_stick': first,
        'stick_fraction': float(stuck / span) if span > 0 else 0.0,
        'bit_speed_max': float(om.max()),
        'bit_speed_min': float(om.min()),
        'bit_speed_mean': mean,
        'severity': float((om.max() - om.min()) / (2.0 * mean)) if mean > 0 else float('inf'),
        'rop_mean': float(series['bit_axial_speed'][w].mean()),
        'delay_residual_max': float(np.abs(series['delay_residual'][w]).max()),
        'samples': int(w.sum()),
    }
