"""Which request drives the top drive, and when a silent source has timed out (no ROS).

Precedence (README "Which speed wins"): while a controller keeps sending speed
commands (each within ``timeout_s`` of the previous), the commands drive the
motor; a new operator set-point applies at once and the controller picks it up;
when the controller falls silent the operator set-point applies again.
"""
from __future__ import annotations

import math

__all__ = ['Watchdog', 'SpeedArbiter']


class Watchdog:
    """A source that must keep feeding within ``timeout_s``.

    ``expired(now)`` is True once, at the first call after the timeout, so that
    the caller acts (and logs) once per silence, not at every tick.
    """

    def __init__(self, timeout_s: float):
        self.timeout_s = float(timeout_s)
        self.last_s = None
        self.silent = True

    def feed(self, now_s: float):
        self.last_s = float(now_s)
        self.silent = False

    def stop(self):
        """Forget the source (it is not expected any more)."""
        self.last_s = None
        self.silent = True

    @property
    def alive(self) -> bool:
        return not self.silent

    def expired(self, now_s: float) -> bool:
        """True exactly once when the source has been silent for longer than the timeout."""
        if self.silent or self.last_s is None:
            return False
        if now_s - self.last_s > self.timeout_s:
            self.silent = True
            return True
        return False


class SpeedArbiter:
    """Operator set-point vs controller command (see module docstring).

    Values are assumed valid (the twin validates them before they get here).
    """

    def __init__(self, operator_speed_rad_s: float, timeout_s: float):
        if not math.isfinite(operator_speed_rad_s):
            raise ValueError('operator speed must be finite')
        self.operator_speed = float(operator_speed_rad_s)
        self.command = None
        self.watchdog = Watchdog(timeout_s)

    @property
    def source(self) -> str:
        """``'controller'`` while commands arrive, else ``'operator'``."""
        return 'controller' if self.watchdog.alive else 'operator'

    def on_operator(self, value: float, now_s: float) -> float:
        """A new operator set-point: it applies at once (the controller re-joins with its
        next command).  Returns the speed to apply."""
        self.operator_speed = float(value)
        self.watchdog.stop()
        return self.operator_speed

    def on_command(self, value: float, now_s: float) -> float:
        """A controller command; returns the speed to apply."""
        self.command = float(value)
        self.watchdog.feed(now_s)
        return self.command

    def check(self, now_s: float) -> float | None:
        """The operator speed to return to when the controller just fell silent, else None."""
        return self.operator_speed if self.watchdog.expired(now_s) else None
