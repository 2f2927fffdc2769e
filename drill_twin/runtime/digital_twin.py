"""The digital twin in SI units: set-points in, rig and bit measurements out (no ROS here).

:class:`DigitalTwin` wraps a :class:`~drill_twin.physics.simulation.Simulation`
of an SI scenario with what a rig has: a surface speed set-point [rad/s], a
hook load [N] (H = buoyed string weight − WOB, thesis §2.1), and the
measurements of the bit and the surface in SI.  Invalid set-points raise
:class:`SetpointError` with the reason and leave the twin untouched.
"""
from __future__ import annotations

import math
from collections import deque

import numpy as np

from ..config.scenario import Scenario
from ..config.well import string_weight_N
from ..errors import ParameterError
from ..physics.simulation import Simulation

__all__ = ['DigitalTwin', 'SetpointError', 'aligned_step']


def aligned_step(step_s: float, period_s: float) -> float:
    """The largest step <= ``step_s`` that divides ``period_s`` (of simulated time) into a
    whole number of steps, so that samples taken every period land exactly on it."""
    if not (step_s > 0 and period_s > 0):
        raise ParameterError(f'need step_s > 0 and period_s > 0, got {step_s}, {period_s}')
    return period_s / math.ceil(period_s / step_s - 1e-9)


class SetpointError(ValueError):
    """A rejected set-point; the message says why."""


class DigitalTwin:
    """Real-time-capable twin of an SI scenario.

    Parameters
    ----------
    scenario : Scenario
        An SI scenario (``units: si``).
    mud_density_kg_m3 : float, optional
        Mud density for the buoyed string weight (hook load ↔ WOB); default the
        configuration's ``drill_string.mud_density_kg_m3``.
    drive_time_constant_s : float
        First-order lag of the speed drive [s]; 0 = stiff speed drive.
    max_surface_speed_rad_s : float
        Set-points above are rejected as absurd.
    severity_window_s : float
        Sliding window of the stick-slip severity [s].
    start_above_bottom_m : float, optional
        Start at rest, string untwisted, the bit this far above a flat bottom, the rotary
        stopped and the hook carrying the whole string (:func:`drill_twin.physics.statics.
        rest_state`); default: steady drilling with the configuration's perturbation.
    time_step_s : float, optional
        Integration step [s]; default the scenario's.  The twin node passes a step
        slightly shorter than the configured one so that a publish period is a whole
        number of steps (:func:`aligned_step`).
    """

    def __init__(self, scenario: Scenario, mud_density_kg_m3: float | None = None,
                 drive_time_constant_s: float = 0.0, max_surface_speed_rad_s: float = 40.0,
                 severity_window_s: float = 10.0, time_step_s: float | None = None,
                 start_above_bottom_m: float | None = None):
        if not scenario.is_si:
            raise ParameterError('the digital twin needs an SI configuration (units: si)')
        self.scenario = scenario
        self.scales = scenario.scales
        if mud_density_kg_m3 is None:
            mud_density_kg_m3 = scenario.system.mud_density_kg_m3
        self._settings = {'mud_density_kg_m3': float(mud_density_kg_m3),
                          'drive_time_constant_s': float(drive_time_constant_s),
                          'max_surface_speed_rad_s': float(max_surface_speed_rad_s),
                          'severity_window_s': float(severity_window_s)}
        if time_step_s is not None:
            self._settings['time_step_s'] = float(time_step_s)
        if start_above_bottom_m is not None:
            self._settings['start_above_bottom_m'] = float(start_above_bottom_m)
        # with the configuration's initial perturbation, as in the offline run (a real rig
        # is never exactly at the steady state)
        self.sim = Simulation.from_scenario(
            scenario, drive_time_constant=drive_time_constant_s / scenario.scales.time_s,
            time_step=None if time_step_s is None else time_step_s / scenario.scales.time_s)
        #: what the string weighs on the hook rotating off bottom [N]: the buoyed weight in
        #: a vertical well, its axial part ∫ w cos I ds on a deviated path (soft string)
        self.string_weight_N = string_weight_N(scenario, mud_density_kg_m3)
        self.max_surface_speed = float(max_surface_speed_rad_s)
        self.nominal_wob_N = scenario.groups.W_o * self.scales.force_N
        self.hook_load_N = self.string_weight_N - self.nominal_wob_N
        self.surface_speed_setpoint = scenario.groups.omega_o / self.scales.time_s
        self.block_velocity_setpoint = scenario.groups.upsilon_o * self.scales.speed_m_s
        self.torque_limit_setpoint = self.rated_torque_Nm
        self.axial_top = scenario.raw['model'].get('axial_top') or 'hook_load'
        self.rejected = 0
        self._window = deque()
        self._window_s = float(severity_window_s)
        if start_above_bottom_m is not None:
            self._start_at_rest(start_above_bottom_m)

    def _start_at_rest(self, gap_m: float):
        from ..physics.statics import rest_state
        if not (math.isfinite(gap_m) and 0.0 < gap_m <= 1000.0):
            raise ParameterError(f'start_above_bottom_m {gap_m!r} m outside (0, 1000] m')
        if self.scenario.wall is not None:   # off bottom: the wall's contact without WOB
            self.sim.set_wall(self.scenario.wall_at(0.0))
        rest_state(self.sim, gap_m / self.scales.depth_m)
        self.surface_speed_setpoint = 0.0
        self.block_velocity_setpoint = 0.0
        self.hook_load_N = self.string_weight_N

    def warm_up(self):
        """Compile and run the kernels once (on a copy) before a real-time loop starts."""
        self.sim.warm_up()

    def settings(self) -> dict:
        """The constructor's keyword arguments (to rebuild an identical twin)."""
        return dict(self._settings)

    # --- set-points ------------------------------------------------------------
    #: set-point topic (:mod:`drill_twin.topics`) -> the method that applies it
    SETPOINTS = {'surface_speed_setpoint': 'set_surface_speed',
                 'surface_speed_command': 'set_surface_speed',
                 'hook_load_setpoint': 'set_hook_load',
                 'block_velocity_setpoint': 'set_block_velocity',
                 'torque_limit_setpoint': 'set_torque_limit'}

    def apply(self, name: str, value: float):
        """Apply the set-point of topic ``name`` (a key of :data:`SETPOINTS`); a value the
        twin cannot take raises :class:`SetpointError` and the last valid one stays."""
        try:
            method = self.SETPOINTS[name]
        except KeyError:
            raise SetpointError(f'{name} is not a set-point of the twin (set-points: '
                                f'{", ".join(self.SETPOINTS)})') from None
        getattr(self, method)(value)

    def set_surface_speed(self, omega_rad_s: float):
        """Surface (motor) speed command [rad/s]; rejected if non-finite, < 0 or absurd."""
        value = self._checked('surface speed', omega_rad_s, 0.0, self.max_surface_speed, 'rad/s')
        self.sim.set_surface_speed(value * self.scales.time_s)
        self.surface_speed_setpoint = value

    def set_hook_load(self, hook_load_N: float):
        """Hook load [N] of a constant-hook-load top; must lie in [0, buoyed string weight]
        (WOB >= 0).  A hoist's hook load follows from the block: use an autodriller
        (:class:`drill_twin.operations.driller.Autodriller`)."""
        if self.has_block:
            self.rejected += 1
            raise SetpointError(f'this string hangs on a {self.axial_top} top: its hook load '
                                'follows the block (set the block velocity)')
        value = self._checked('hook load', hook_load_N, 0.0, self.string_weight_N, 'N')
        self.sim.set_axial_top_force((self.string_weight_N - self.nominal_wob_N - value)
                                     / self.scales.force_N)
        self.hook_load_N = value

    @property
    def rated_torque_Nm(self) -> float | None:
        """The motor drive's rated torque limit [N·m] (``drive.torque_limit_Nm``); None
        without a PI motor drive (model.top_drive not motor)."""
        drive = getattr(self.sim.model, 'top_drive', None) or \
            getattr(self.scenario.model, 'top_drive', None)
        return None if drive is None else float(drive.torque_limit_Nm)

    def set_torque_limit(self, torque_Nm: float):
        """The motor drive's torque limit in force [N·m], in [0, the rated limit]: the
        drive's PI demand is clipped to it (a rig's VFD torque limit, e.g. for a
        start-up or a stuck pipe)."""
        rated = self.rated_torque_Nm
        if rated is None:
            self.rejected += 1
            raise SetpointError('a torque limit needs a motor top drive (model.top_drive: '
                                'motor); this string turns at a prescribed speed')
        value = self._checked('torque limit', torque_Nm, 0.0, rated, 'N m')
        self.sim.set_torque_limit(value / self.scales.torque_Nm)
        self.torque_limit_setpoint = value

    @property
    def has_block(self) -> bool:
        """True when the top of the string hangs on a hoist or moves with an imposed block
        velocity (block velocity set-points), False for a constant hook load."""
        return self.axial_top in ('hoist', 'velocity')

    def set_block_velocity(self, velocity_m_s: float):
        """Block (drum) velocity [m/s, down-hole positive]; for a hoist or imposed-velocity
        top only."""
        if not self.has_block:
            self.rejected += 1
            raise SetpointError('block velocity needs model.axial_top hoist or velocity (this '
                                'string hangs on a constant hook load: set the hook load)')
        value = self._checked('block velocity', velocity_m_s, -10.0, 10.0, 'm/s')
        self.sim.set_block_velocity(value / self.scales.speed_m_s)
        self.block_velocity_setpoint = value

    def _checked(self, name, value, lo, hi, unit):
        try:
            value = float(value)
        except (TypeError, ValueError):
            self.rejected += 1
            raise SetpointError(f'{name} {value!r} is not a number') from None
        if not math.isfinite(value):
            self.rejected += 1
            raise SetpointError(f'{name} {value} is not finite')
        if not lo <= value <= hi:
            self.rejected += 1
            raise SetpointError(f'{name} {value:g} {unit} outside [{lo:g}, {hi:g}] {unit}')
        return value

    # --- time ----------------------------------------------------------------------
    @property
    def time_s(self) -> float:
        return self.sim.time * self.scales.time_s

    @property
    def step_s(self) -> float:
        return self.sim.h * self.scales.time_s

    def advance_steps(self, steps: int):
        """Advance by ``steps`` time steps."""
        if steps > 0:
            self.sim.advance(int(steps))

    def advance_to(self, time_s: float, max_steps: int | None = None) -> int:
        """Advance to the step that ends at or before ``time_s`` [s]; returns the steps taken
        (capped by ``max_steps``)."""
        # whole steps; a millionth of a step of round-off in the accumulated time must not
        # cost a step
        steps = int(math.floor((time_s - self.time_s) / self.step_s + 1e-6))
        if max_steps is not None:
            steps = min(steps, max_steps)
        if steps > 0:
            self.sim.advance(steps)
        return max(steps, 0)

    # --- outputs -------------------------------------------------------------------
    def measurements(self) -> dict:
        """Bit and surface measurements in SI at the current time: the sample of a tick (it
        enters the sliding window of the stick-slip severity, once per simulated instant)."""
        return self._measure(feed_window=True)

    def peek(self) -> dict:
        """The same measurements without counting them as a tick's sample (for a controller
        or a driller that looks between ticks)."""
        return self._measure(feed_window=False)

    def _measure(self, feed_window: bool) -> dict:
        snap = self.sim.snapshot()
        s = self.scales
        omega = snap['bit_angular_speed'] / s.time_s
        now = self.time_s
        window = self._window
        if feed_window and (not window or window[-1][0] != now):
            window.append((now, omega))
            while window and window[0][0] < now - self._window_s:
                window.popleft()
        speeds = np.array([w for _, w in window] if window else [omega])
        mean = speeds.mean()
        # (max - min)/(2 mean); a bit that has not turned over the window has none
        severity = float((speeds.max() - speeds.min()) / (2 * mean)) if mean > 0 else 0.0
        hook = self.string_weight_N - self.nominal_wob_N + snap['hook_load_change'] * s.force_N
        return {
            'time_s': now,
            'bit_axial_speed_m_s': snap['bit_axial_speed'] * s.speed_m_s,
            'bit_angular_speed_rad_s': omega,
            'weight_on_bit_N': snap['weight_on_bit'] * s.force_N,
            'torque_on_bit_Nm': snap['torque_on_bit'] * s.torque_Nm,
            'depth_of_cut_m': snap['depth_of_cut'] * s.depth_m,
            'rate_of_penetration_m_s': snap['bit_axial_speed'] * s.speed_m_s,
            'surface_speed_rad_s': snap['surface_speed'] / s.time_s,
            'top_drive_speed_rad_s': snap['top_drive_speed'] / s.time_s,
            'surface_torque_Nm': snap['surface_torque'] * s.torque_Nm,
            'motor_torque_Nm': snap['motor_torque'] * s.torque_Nm,
            'hook_load_N': hook,
            'block_velocity_m_s': snap['top_axial_speed'] * s.speed_m_s,
            'stuck': snap['angular_stick'] > 0.5,
            'stick_slip_severity': severity,
            'delay_residual_rad': snap['delay_residual'],
            'bit_depth_m': snap['bit_position'] * s.depth_m,
            'bit_angle_rad': snap['bit_angle'],
            'top_drive_angle_rad': snap['top_drive_angle'],
            'bit_above_bottom_m': max(0.0, -snap['depth_of_cut'] * s.depth_m)
            if snap['contact'] < 0.5 else 0.0,
            'block_position_m': snap['block_position'] * s.depth_m,
            'block_velocity_setpoint_m_s': self.block_velocity_setpoint,
        }

    def health(self) -> dict:
        return {'rejected_setpoints': self.rejected,
                'history_overflows': self.sim.history_overflows,
                'events': self.sim.event_count, 'impulses': self.sim.impulse_count}

    def operating_point(self):
        """Groups at the current set-points (for the stability advisory)."""
        g = self.scenario.groups
        wob = self.string_weight_N - self.hook_load_N
        return g.replace(omega_o=max(self.surface_speed_setpoint, 1e-6) * self.scales.time_s,
                         W_o=wob / self.scales.force_N)
