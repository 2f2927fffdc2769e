"""The top-drive controller node's policy, without ROS: which inputs it takes, when it falls
back to the operator set-point, and how healthy its output is.

A controller over topics closes a loop on a measured surface torque.  One corrupt sample
(a word read as 1e30 N·m) fed to its virtual drive moves the drive's state by the gain
times the glitch and pins the command at a speed limit for as long as the state takes to
forget it — in the Soft-Torque drive, for good (its reference torque is a low-pass of the
measurement).  So every input passes a gate first:

* :class:`ChannelGate`: a measurement must be a finite number within what the sensor can
  report, and a jump from the last accepted value larger than ``max_jump`` must be
  confirmed by the next sample (a level that really changed), else it is refused;
* :class:`ControllerSupervisor`: the set-point must lie in ``[0, max speed]``; the torque
  goes through its gate; silence of the torque for longer than the timeout holds the
  operator set-point (fallback), which is a WARN, as is a command held at a speed bound
  while the set-point lies inside them, and any refused input in the last 10 s.

The node (:mod:`drill_twin.ros.soft_torque_node`) only moves messages.
"""
from __future__ import annotations

import math

from .arbitration import Watchdog
from .health import OK, WARN, EventWindow, worst

__all__ = ['ChannelGate', 'ControllerSupervisor', 'DEFAULT_MAX_TORQUE_NM',
           'DEFAULT_MAX_TORQUE_JUMP_NM']

#: largest surface torque a rig's sensor reports either way [N·m] (the largest top drives
#: make ~100 kN·m; the estimator's gate uses the same bound)
DEFAULT_MAX_TORQUE_NM = 2.0e5
#: largest change of the surface torque between two samples that needs no confirmation
#: [N·m]: the drive's torque limit (rig_fem: 50 kN·m); the string's top can change the
#: torque by its torsional impedance times the speed change, ~0.3 kN·m per rad/s for 5"
#: pipe, so stick-slip moves it by a few kN·m per 10 ms sample
DEFAULT_MAX_TORQUE_JUMP_NM = 5.0e4
#: how far back refusals make the status WARN [s]
WINDOW_S = 10.0


class ChannelGate:
    """The accepted values of one measured channel (see module docstring).

    Parameters
    ----------
    name, unit : str
        For the reasons given.
    low, high : float
        Range a measurement can have [unit].
    max_jump : float or None
        Largest change from the last accepted value taken without confirmation [unit].
    """

    def __init__(self, name: str, low: float, high: float, unit: str,
                 max_jump: float | None = None):
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise ValueError(f'{name}: need finite low < high, got {low!r}, {high!r}')
        if max_jump is not None and not (math.isfinite(max_jump) and max_jump > 0):
            raise ValueError(f'{name}: max_jump must be finite and > 0, got {max_jump!r}')
        self.name, self.low, self.high, self.unit = name, float(low), float(high), unit
        self.max_jump = max_jump
        self.latest: float | None = None
        self.refused = 0
        self._pending: float | None = None

    def reason(self, value) -> str | None:
        """Why ``value`` cannot be a measurement of this channel at all (None if it can)."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return f'{self.name} {value!r} is not a number'
        if not math.isfinite(value):
            return f'{self.name} {value} is not finite'
        if not self.low <= value <= self.high:
            return (f'{self.name} {value:g} {self.unit} outside [{self.low:g}, '
                    f'{self.high:g}] {self.unit}')
        return None

    def offer(self, value) -> str | None:
        """Take ``value`` as the latest measurement, or refuse it (the last accepted value
        stays) and say why."""
        why = self.reason(value)
        if why is None and self.max_jump is not None and self.latest is not None \
                and abs(value - self.latest) > self.max_jump:
            pending, self._pending = self._pending, float(value)
            if pending is None or abs(value - pending) > self.max_jump:
                why = (f'{self.name} jumped {value - self.latest:+g} {self.unit} in one '
                       f'sample (more than {self.max_jump:g} {self.unit}); taken if the next '
                       'sample confirms it')
        if why is not None:
            self.refused += 1
            return why
        self._pending = None
        self.latest = float(value)
        return None


class ControllerSupervisor:
    """Inputs, fallback and status of a top-drive controller over topics.

    Parameters
    ----------
    controller : SoftTorqueController
        The mode's virtual drive (:func:`drill_twin.control.external.external_controller`).
    setpoint_rad_s : float
        The set-point tracked until an operator set-point arrives [rad/s] (the twin's
        configured operating point).
    measurement_timeout_s : float
        Torque silence that holds the operator set-point [s].
    max_torque_Nm, max_torque_jump_Nm : float
        The torque gate's range (either way) and unconfirmed jump [N·m].
    """

    def __init__(self, controller, setpoint_rad_s: float, measurement_timeout_s: float,
                 max_torque_Nm: float = DEFAULT_MAX_TORQUE_NM,
                 max_torque_jump_Nm: float = DEFAULT_MAX_TORQUE_JUMP_NM):
        self.ctrl = controller
        self.setpoint = float(setpoint_rad_s)
        self.operator_setpoint = False
        self.torque = ChannelGate('surface torque', -max_torque_Nm, max_torque_Nm, 'N·m',
                                  max_torque_jump_Nm)
        self.watch = Watchdog(measurement_timeout_s)
        self.events = EventWindow(WINDOW_S)
        self.rejected_setpoints = 0
        self.fallbacks = 0
        self.in_fallback = False
        self.command_rad_s: float | None = None

    # --- inputs ----------------------------------------------------------------------
    def on_setpoint(self, value, now_s: float) -> str | None:
        """An operator set-point [rad/s]; the reason if refused (the last one stays)."""
        limit = self.ctrl.max_speed
        ok = not isinstance(value, bool) and isinstance(value, (int, float)) and \
            math.isfinite(value) and 0.0 <= value <= limit
        if not ok:
            self.rejected_setpoints += 1
            self.events.add('refused', now_s)
            return (f'set-point {value!r} rad/s outside [0, {limit:g}] rad/s; keeping '
                    f'{self.setpoint:g} rad/s')
        self.setpoint = float(value)
        self.operator_setpoint = True
        return None

    def on_torque(self, value, now_s: float) -> str | None:
        """A surface torque measurement [N·m]; the reason if refused."""
        why = self.torque.offer(value)
        if why is not None:
            self.events.add('refused', now_s)
            return why
        self.watch.feed(now_s)
        return None

    # --- output ----------------------------------------------------------------------
    def command(self, dt_s: float, now_s: float) -> tuple[float, str | None]:
        """The speed command [rad/s] after ``dt_s`` [s], and a line to log when the
        fallback starts or ends (else None)."""
        note = None
        if self.watch.expired(now_s):
            self.fallbacks += 1
            note = 'surface torque not arriving: holding the operator set-point'
        if self.watch.silent:
            self.in_fallback = True
            self.ctrl.reset(self.setpoint, torque=self.torque.latest)
            command = self.setpoint
        else:
            if self.in_fallback:
                note = 'surface torque back: the controller resumes'
                self.in_fallback = False
            command = self.ctrl.update(dt_s, self.setpoint, self.torque.latest)
        self.command_rad_s = float(command)
        return self.command_rad_s, note

    @property
    def saturated(self) -> bool:
        """The command sits at a speed bound (0 or the maximum) while the set-point lies
        strictly inside them."""
        c, limit = self.command_rad_s, self.ctrl.max_speed
        if c is None or not (0.0 < self.setpoint < limit):
            return False
        return c <= 0.0 or c >= limit

    def status(self, now_s: float) -> tuple[int, str]:
        """``(level, message)`` of ``diagnostic_msgs`` (0 OK, 1 WARN)."""
        refused = self.events.recent('refused', now_s)
        source = 'operator' if self.operator_setpoint else 'configured'
        fallback = None
        if self.in_fallback:
            fallback = (WARN, 'surface torque stopped: holding the set-point'
                        if self.watch.last_s is not None else
                        'no surface torque yet: holding the set-point')
        return worst(
            fallback,
            (WARN, f'command held at a speed limit ({self.command_rad_s:g} rad/s) while the '
                   f'set-point is {self.setpoint:g} rad/s') if self.saturated else None,
            (WARN, f'{refused} corrupt or out-of-range inputs refused in the last '
                   f'{WINDOW_S:g} s') if refused else None,
        ) if (fallback or self.saturated or refused) else (OK, (
            f'enabled, tracking the {source} set-point {self.setpoint:g} rad/s'
            if self.ctrl.enabled else f'passing the {source} set-point {self.setpoint:g} '
            'rad/s'))
