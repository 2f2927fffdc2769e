"""Real-time pacing of a simulation against a steady wall clock (no ROS).

The loop of the twin node samples the simulation on a fixed grid, like a rig's
data acquisition: one sample every ``period`` of wall time, i.e. every
``r * period`` of simulated time (``r`` the real-time factor).  At each tick
:class:`Pacer` says which grid instant is due, from an anchor
``(wall_0, sim_0)``: the grid instant nearest to ``sim_0 + r (wall - wall_0)``,
where ``wall`` is the time the tick was scheduled for (the node passes its
timer's schedule; a tick that runs a few milliseconds late still samples its
own instant).  Simulated time never drifts however the ticks jitter.

Stamps
    :meth:`Pacer.stamp_ns` maps a simulated instant to the node's ROS clock
    through the same anchor: a measurement is stamped with the ROS time at which
    its simulated instant happens (acquisition time, as a rig's sensors stamp),
    not with the moment the publishing code happened to run.  Stamps are
    therefore exactly one period apart while the loop keeps its rate; the
    latency from stamp to delivery is what the scheduler adds.

Degrading gracefully
    A tick that has to advance more than one grid interval (it came more than a
    period late: a sample is skipped) or that cannot reach its instant within its
    budget of ``catch_up`` nominal ticks' worth of steps is an **overrun**; the
    next ticks catch up, at most ``catch_up - 1`` periods of lag per tick.  When
    the lag exceeds ``max_lag_s`` of wall time (a long stall: the process was
    descheduled, the machine suspended) the pacer **slips**: it re-anchors at the
    current state, so the lost wall time is given up instead of being replayed at
    ``catch_up`` times real time.  Catching up after any stall therefore takes at
    most ``max_lag_s / ((catch_up - 1) period)`` ticks.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ['Pacer', 'TickPlan', 'SamplePacing']


@dataclass(frozen=True)
class TickPlan:
    """What one tick should do: reach ``target_s`` of simulated time in at most
    ``max_steps`` integration steps, starting from ``start_s``."""

    start_s: float
    target_s: float
    max_steps: int


class Pacer:
    """Maps a steady wall clock to simulated time (see module docstring).

    Parameters
    ----------
    real_time_factor : float
        Simulated seconds per wall second (> 0).
    period_s : float
        Wall time between samples (ticks) [s] (> 0).
    step_s : float
        Integration step of the simulation [s of simulated time] (> 0).
    catch_up : int
        A tick advances at most ``catch_up`` nominal ticks' worth of steps.
    max_lag_s : float
        Wall-time lag beyond which the pacer slips (re-anchors) [s].
    """

    def __init__(self, real_time_factor: float, period_s: float, step_s: float,
                 catch_up: int = 4, max_lag_s: float = 0.5):
        for name, value in (('real_time_factor', real_time_factor), ('period_s', period_s),
                            ('step_s', step_s), ('max_lag_s', max_lag_s)):
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f'{name} must be finite and > 0, got {value!r}')
        if catch_up < 2:
            raise ValueError(f'catch_up must be >= 2, got {catch_up}')
        self.real_time_factor = float(real_time_factor)
        self.period_s = float(period_s)
        self.step_s = float(step_s)
        self.catch_up = int(catch_up)
        self.max_lag_s = float(max_lag_s)
        self._wall0 = None
        self._sim0 = 0.0
        self._ros0_ns = None
        self._last_wall = None

    @property
    def started(self) -> bool:
        return self._wall0 is not None

    @property
    def sample_s(self) -> float:
        """Simulated time between samples: ``real_time_factor * period_s``."""
        return self.real_time_factor * self.period_s

    def anchor(self, wall_s: float, sim_s: float, ros_ns: int | None = None):
        """Start (or restart) pacing: simulated time ``sim_s`` corresponds to the steady
        clock's ``wall_s`` and to the ROS clock's ``ros_ns`` (for stamps)."""
        self._wall0, self._sim0 = float(wall_s), float(sim_s)
        self._last_wall = float(wall_s)     # the simulation stands at sim_s at wall_s
        if ros_ns is not None:
            self._ros0_ns = int(ros_ns)

    def retime(self, wall_s: float, sim_s: float, real_time_factor: float | None = None,
               period_s: float | None = None, ros_ns: int | None = None):
        """Change the rate and/or the period; simulated time and stamps stay continuous.

        The new grid is anchored at the instant the last tick was scheduled for (when the
        simulation stood at ``sim_s``), not at ``wall_s``: the next tick is then one new
        period later and samples a new instant (anchored at ``wall_s``, a tick within half
        a period would find its instant reached already and sample ``sim_s`` again)."""
        ros = ros_ns if ros_ns is not None else self.stamp_ns(sim_s)  # at the old rate
        if real_time_factor is not None:
            self.real_time_factor = float(real_time_factor)
        if period_s is not None:
            self.period_s = float(period_s)
        anchor = self._last_wall if self._last_wall is not None else wall_s
        self.anchor(min(anchor, wall_s), sim_s, ros)

    def stamp_ns(self, sim_s: float) -> int | None:
        """ROS time [ns] at which the simulated instant ``sim_s`` happens (None before the
        first anchor with a ROS time)."""
        if self._ros0_ns is None:
            return None
        return self._ros0_ns + int(round((sim_s - self._sim0) / self.real_time_factor * 1e9))

    @property
    def nominal_steps(self) -> int:
        """Integration steps in one sample interval."""
        return max(1, int(round(self.sample_s / self.step_s)))

    def plan(self, wall_s: float, sim_s: float, ros_ns: int | None = None) -> TickPlan:
        """The grid instant due at ``wall_s`` and the step budget to reach it (anchors on
        first use: the first tick samples one period later; ``ros_ns`` is the ROS time now)."""
        if self._wall0 is None:
            self.anchor(wall_s - self.period_s, sim_s,
                        None if ros_ns is None else ros_ns - int(self.period_s * 1e9))
        self._last_wall = float(wall_s)
        due = (wall_s - self._wall0) * self.real_time_factor
        target = self._sim0 + round(due / self.sample_s) * self.sample_s
        # a whole number of samples' steps: a tick that runs out of budget still ends on
        # the sample grid (the twin's step divides the sample interval)
        return TickPlan(sim_s, target, self.catch_up * self.nominal_steps)

    def settle(self, wall_s: float, sim_s: float, plan: TickPlan,
               ros_ns: int | None = None) -> str | None:
        """After a tick that reached ``sim_s``: ``None`` (on time), ``'overrun'`` (a sample
        skipped, or behind and catching up) or ``'slip'`` (too far behind: re-anchored at
        ``(wall_s, sim_s, ros_ns)``)."""
        half_step = 0.5 * self.step_s
        behind_s = plan.target_s - sim_s
        if behind_s / self.real_time_factor > self.max_lag_s:
            self.anchor(wall_s, sim_s, ros_ns)
            return 'slip'
        if behind_s > half_step or sim_s - plan.start_s > self.sample_s + half_step:
            return 'overrun'
        return None


class SamplePacing:
    """How many sample periods of the sampler's clock passed since its last sample.

    A sampler (the downhole estimator) updates a filter whose model takes one sample
    period between updates.  Its timer runs on the node clock — wall time, or the
    simulated ``/clock`` under ``use_sim_time`` — and can fall behind it: a late
    callback, or a simulated clock running faster than the node can follow.  The filter
    must then predict over the periods that had no sample, not take the late sample as
    the next one.  :meth:`periods` rounds the clock's advance to whole periods (timer
    jitter of less than half a period is no skip).

    Parameters
    ----------
    rate_hz : float
        Sample rate [Hz] of the filter.
    memory_s : float
        How long [s of wall time] :meth:`recently_behind` remembers a skip.
    """

    def __init__(self, rate_hz: float, memory_s: float = 10.0):
        self.period_ns = 1e9 / float(rate_hz)
        self.memory_s = float(memory_s)
        self.last_ns: int | None = None
        self.skipped = 0
        self._last_skip_s: float | None = None

    def restart(self):
        """Forget the last sample (the data stopped: the next one starts afresh)."""
        self.last_ns = None

    def periods(self, now_ns: int, wall_s: float) -> int:
        """Whole periods since the last sample at ``now_ns`` (1 for the first sample; 0
        if the clock advanced less than half a period or went back — no sample then).
        ``wall_s``: the monotonic time [s], for :meth:`recently_behind`."""
        if self.last_ns is None:
            self.last_ns = now_ns
            return 1
        n = round((now_ns - self.last_ns) / self.period_ns)
        if n <= 0:
            if now_ns < self.last_ns:       # the clock went back (a new simulation)
                self.last_ns = now_ns
            return 0
        self.last_ns = now_ns
        if n > 1:
            self.skipped += n - 1
            self._last_skip_s = wall_s
        return n

    def recently_behind(self, wall_s: float) -> bool:
        """A period was skipped within the last ``memory_s`` of wall time."""
        return self._last_skip_s is not None and wall_s - self._last_skip_s < self.memory_s
