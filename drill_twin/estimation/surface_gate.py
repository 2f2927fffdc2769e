"""Which surface measurements the estimator takes (docs/estimation.md §3, "Bad samples").

A rig's sensors glitch: a NaN, an infinity, a word read as 1e30.  One such sample fed to
a Kalman filter moves its state by the gain times the glitch and stays in the
self-tuning window for its whole length.  :class:`SurfaceGate` keeps, per channel, the
last value that was finite and physically possible, and says why it refused the others;
the estimator goes on with the held value (zero-order hold, as between samples).

The limits are what no drilling rig produces — a top drive turning faster than
:attr:`SurfaceLimits.speed_rad_s` either way, a surface torque beyond
:attr:`SurfaceLimits.torque_Nm` either way (the largest top drives make ~100 kN·m), a
hook load below 0 (the hook only pulls) or above :attr:`SurfaceLimits.hook_load_N`, a
block faster than :attr:`SurfaceLimits.block_speed_m_s`.  They catch corrupt data, not
surprising data: a possible but unexpected value is taken, and if the string model does
not explain it the innovation statistics and the mismatch warning say so.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

from .estimator import SurfaceSample

__all__ = ['SurfaceLimits', 'SurfaceGate', 'CHANNELS']

#: the measured channels: the fields of :class:`SurfaceSample`
CHANNELS = tuple(f.name for f in fields(SurfaceSample))


@dataclass(frozen=True)
class SurfaceLimits:
    """Largest magnitudes [SI] a rig's surface sensors can truly report."""

    speed_rad_s: float = 40.0
    torque_Nm: float = 2.0e5
    hook_load_N: float = 2.0e7
    block_speed_m_s: float = 10.0

    def __post_init__(self):
        for name in ('speed_rad_s', 'torque_Nm', 'hook_load_N', 'block_speed_m_s'):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f'surface limit {name} must be a finite number > 0, '
                                 f'got {value!r}')

    def ranges(self) -> dict[str, tuple[float, float, str]]:
        """``channel: (low, high, unit)``."""
        return {'surface_speed_rad_s': (-self.speed_rad_s, self.speed_rad_s, 'rad/s'),
                'surface_torque_Nm': (-self.torque_Nm, self.torque_Nm, 'N·m'),
                'hook_load_N': (0.0, self.hook_load_N, 'N'),
                'block_velocity_m_s': (-self.block_speed_m_s, self.block_speed_m_s, 'm/s')}


@dataclass
class SurfaceGate:
    """The last acceptable value of each channel, and the count of refused ones.

    >>> gate = SurfaceGate()
    >>> gate.offer('surface_torque_Nm', float('nan'))
    'surface_torque_Nm nan is not finite'
    """

    limits: SurfaceLimits = field(default_factory=SurfaceLimits)
    latest: dict = field(default_factory=lambda: dict.fromkeys(CHANNELS))
    rejected: dict = field(default_factory=lambda: dict.fromkeys(CHANNELS, 0))

    def __post_init__(self):
        self._ranges = self.limits.ranges()      # the limits are frozen

    def reason(self, channel: str, value) -> str | None:
        """Why ``value`` cannot be a measurement of ``channel`` (None if it can)."""
        low, high, unit = self._ranges[channel]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return f'{channel} {value!r} is not a number'
        if not math.isfinite(value):
            return f'{channel} {value} is not finite'
        if not low <= value <= high:
            return f'{channel} {value:g} {unit} outside [{low:g}, {high:g}] {unit}'
        return None

    def offer(self, channel: str, value) -> str | None:
        """Take ``value`` as the channel's latest measurement, or refuse it (the held
        value stays) and say why."""
        why = self.reason(channel, value)
        if why is None:
            self.latest[channel] = float(value)
        else:
            self.rejected[channel] += 1
        return why

    def sample(self) -> SurfaceSample | None:
        """The held values as one sample (the axial pair NaN until measured); None until
        both the top-drive speed and the surface torque have had an acceptable value."""
        speed, torque = self.latest['surface_speed_rad_s'], self.latest['surface_torque_Nm']
        if speed is None or torque is None:
            return None
        hook, block = self.latest['hook_load_N'], self.latest['block_velocity_m_s']
        return SurfaceSample(speed, torque, math.nan if hook is None else hook,
                             math.nan if block is None else block)

    @property
    def rejected_total(self) -> int:
        return sum(self.rejected.values())
