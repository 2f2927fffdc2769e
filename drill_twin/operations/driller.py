"""The driller and the autodriller: what turns a timeline into set-points, tick by tick
(plain classes, no ROS; the twin node and ``drill-twin scenario run`` both use them).

Autodriller
    Rigs infer the weight on bit from the hook load (measured at the dead-line anchor):
    ``WOB = buoyed string weight - hook load``.  The autodriller pays out the drill line
    (block velocity down) while that WOB is below its target and holds back when above:
    a PI law ``v = K_p e + K_i ∫e`` on ``e = WOB_target - WOB``, with ``K_p = 1/(k τ)``
    so that the WOB settles with the time constant τ (2 s) through the axial stiffness
    ``k`` of the drill line in series with the string, and ``K_i = K_p/(4τ)``, which feeds
    the block at the rate of penetration in steady drilling.  The block speed is
    limited to ±``v_max`` and the integral stops while the command is limited.  With a
    constant-hook-load top there is no block: the target is the hook load itself.
Driller
    Executes the steps of a :class:`~drill_twin.operations.timeline.Timeline` in order:
    speed ramps, the block for tagging bottom and picking up, the autodriller for
    slacking off, waits.  ``tick(dt)`` once per control period.  The block accelerates
    at most ``block_acceleration_m_s2`` (0.05 m/s², a drawworks brake eased on, not a
    step that sends an axial wave down the string).
"""
from __future__ import annotations

import math

from ..errors import ParameterError

__all__ = ['Autodriller', 'Driller', 'ScenarioError']


#: a first-order speed change (``rotate`` with ``time_constant_s``) lasts this many time
#: constants
FIRST_ORDER_SPAN = 5.0


class ScenarioError(ParameterError):
    """A step that cannot be done (e.g. tag bottom with no block), or timed out."""


class Autodriller:
    """PI control of the weight on bit through the block velocity (see module docstring).

    Parameters
    ----------
    stiffness_N_m : float
        Axial stiffness from the drum to the bit (drill line in series with the string).
    time_constant_s : float
        Settling time constant τ of the WOB.
    max_speed_m_s : float
        Largest block speed it commands.
    """

    def __init__(self, stiffness_N_m: float, time_constant_s: float = 2.0,
                 max_speed_m_s: float = 0.05):
        if not (stiffness_N_m > 0 and time_constant_s > 0 and max_speed_m_s > 0):
            raise ParameterError('autodriller needs positive stiffness, time constant and '
                                 'speed limit')
        self.kp = 1.0 / (stiffness_N_m * time_constant_s)
        self.ki = self.kp / (4.0 * time_constant_s)
        self.max_speed = float(max_speed_m_s)
        self.integral = 0.0

    def reset(self, block_velocity_m_s: float = 0.0):
        """Start from the block velocity in force (no bump)."""
        self.integral = block_velocity_m_s / self.ki if self.ki else 0.0

    def command(self, wob_target_N: float, wob_N: float, dt: float) -> float:
        """Block velocity [m/s, down positive] for the WOB error now."""
        error = wob_target_N - wob_N
        raw = self.kp * error + self.ki * (self.integral + error * dt)
        if abs(raw) < self.max_speed:
            self.integral += error * dt
            return raw
        return math.copysign(self.max_speed, raw)


class Driller:
    """Runs a timeline on a :class:`~drill_twin.runtime.digital_twin.DigitalTwin`.

    ``apply(name, value)`` is called for every set-point the driller sets (the node
    records and publishes through it); by default the twin's setter is called.
    """

    def __init__(self, twin, timeline, apply=None, block_acceleration_m_s2: float = 0.05):
        self.twin = twin
        self.block_acceleration = float(block_acceleration_m_s2)
        self._block_target = twin.block_velocity_setpoint if twin.has_block else 0.0
        self.steps = list(timeline.steps)
        self.apply = apply or twin.apply
        self.index = -1
        self.elapsed = 0.0
        self.wob_target = None          # autodriller engaged when not None
        self._ramp = None                # (start value, end value, duration) of a speed ramp
        self._wob_ramp = None
        self.log = []                    # (time, label) of every step started
        system = twin.scenario.system
        line = twin.scenario.raw.get('rig', {}).get('line_stiffness_N_m', 2.5e7)
        string = 1.0 / sum(sec.axial_compliance for sec in system.sections)
        k = 1.0 / (1.0 / line + 1.0 / string) if twin.axial_top == 'hoist' else string
        self.autodriller = Autodriller(k)
        self._check_steps()
        self._next()

    def _check_steps(self):
        """Refuse, before the first tick, a step this twin cannot do: one that moves the
        block on a string without one, a slack-off to more than the string weighs (the
        twin's mud may differ from the configuration's)."""
        for step in self.steps:
            if step.action in ('tag_bottom', 'pick_up') and not self.twin.has_block:
                raise ScenarioError(f'{step.label}: needs a block (model.axial_top: hoist or '
                                    'velocity); this string hangs on a constant hook load')
            wob = step.params.get('wob_N', 0.0) if step.action == 'slack_off' else 0.0
            if wob > self.twin.string_weight_N:
                raise ScenarioError(f'{step.label}: the weight on bit {wob / 1e3:g} kN is '
                                    'more than the string weighs in mud '
                                    f'({self.twin.string_weight_N / 1e3:.4g} kN)')

    # --- plumbing ----------------------------------------------------------------------
    @property
    def done(self) -> bool:
        return self.index >= len(self.steps)

    @property
    def step(self):
        return None if self.done else self.steps[self.index]

    def _next(self):
        self.index += 1
        self.elapsed = 0.0
        if self.done:
            return
        step = self.steps[self.index]
        self.log.append((self.twin.time_s, step.label))
        start = getattr(self, f'_start_{step.action}', None)
        if start is not None:
            start(step.params)

    def _block(self, velocity):
        """Aim the block at ``velocity`` (reached at the acceleration limit, tick by tick)."""
        if not self.twin.has_block:
            raise ScenarioError(f'{self.step.label}: needs a block (model.axial_top: hoist or '
                                'velocity); this string hangs on a constant hook load')
        self._block_target = float(velocity)

    def _move_block(self, dt):
        if not self.twin.has_block:
            return
        now = self.twin.block_velocity_setpoint
        step = self.block_acceleration * dt
        new = min(max(self._block_target, now - step), now + step)
        if new != now:
            self.apply('block_velocity_setpoint', new)

    def _wob(self, m):
        return self.twin.string_weight_N - m['hook_load_N']   # what the rig can infer

    # --- step starts -------------------------------------------------------------------
    def _start_rotate(self, p):
        self._ramp = (self.twin.surface_speed_setpoint, p['speed_rad_s'], p['ramp_s'],
                      p.get('time_constant_s', 0.0))

    def _start_stop_rotary(self, p):
        self._ramp = (self.twin.surface_speed_setpoint, 0.0, p['ramp_s'], 0.0)

    def _start_tag_bottom(self, p):
        self.wob_target = None
        self._block(p['speed_m_s'])

    def _start_pick_up(self, p):
        self.wob_target = None
        self._block(-p['speed_m_s'])

    def _start_hold_block(self, p):
        self.wob_target = None
        if self.twin.has_block:
            self._block(0.0)

    def _start_slack_off(self, p):
        m = self.twin.peek()
        start = self.wob_target if self.wob_target is not None else max(self._wob(m), 0.0)
        self._wob_ramp = (start, p['wob_N'], p['ramp_s'])
        if self.wob_target is None:
            self.autodriller.reset(self.twin.block_velocity_setpoint
                                   if self.twin.has_block else 0.0)
        self.wob_target = start

    # --- every tick --------------------------------------------------------------------
    def tick(self, dt: float):
        """Set the set-points for the next ``dt`` seconds; move on when a step is done."""
        if self.done:
            return
        self.elapsed += dt
        step = self.step
        p = step.params
        m = self.twin.peek()
        finished = False
        if step.action in ('rotate', 'stop_rotary'):
            a, b, dur, lag = self._ramp
            if lag > 0.0:               # first order: exp(-t/lag) of the way left
                finished = self.elapsed >= FIRST_ORDER_SPAN * lag
                frac = 1.0 if finished else 1.0 - math.exp(-self.elapsed / lag)
            else:                       # linear over dur
                frac = 1.0 if dur <= 0 else min(self.elapsed / dur, 1.0)
                finished = frac >= 1.0
            self.apply('surface_speed_setpoint', a + (b - a) * frac)
        elif step.action in ('wait', 'drill'):
            finished = self.elapsed >= p['for_s']
        elif step.action == 'tag_bottom':
            if m['bit_above_bottom_m'] <= 0.0:
                self._block(0.0)
                self._block_target = 0.0
                if self.twin.block_velocity_setpoint != 0.0:   # stop at once on contact
                    self.apply('block_velocity_setpoint', 0.0)
                finished = True
            elif self.elapsed > p['timeout_s']:
                raise ScenarioError(f'{step.label}: the bit did not reach bottom within '
                                    f"{p['timeout_s']:g} s")
        elif step.action == 'pick_up':
            if m['bit_above_bottom_m'] >= p['above_bottom_m']:
                self._block(0.0)
                finished = True
            elif self.elapsed > p['timeout_s']:
                raise ScenarioError(f'{step.label}: the bit was not {p["above_bottom_m"]:g} m '
                                    f"off bottom within {p['timeout_s']:g} s")
        elif step.action == 'slack_off':
            a, b, dur = self._wob_ramp
            frac = 1.0 if dur <= 0 else min(self.elapsed / dur, 1.0)
            self.wob_target = a + (b - a) * frac
            finished = frac >= 1.0
        else:  # hold_block
            finished = True
        self._autodrill(m, dt)
        self._move_block(dt)
        if finished:
            self._next()

    def _autodrill(self, m, dt):
        if self.wob_target is None:
            return
        if self.twin.has_block:
            self._block(self.autodriller.command(self.wob_target, self._wob(m), dt))
        else:
            self.apply('hook_load_setpoint', self.twin.string_weight_N - self.wob_target)
