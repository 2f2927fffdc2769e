"""One run of the twin, tick by tick: the loop every driver of the twin shares.

A tick is: the scenario's driller (if any) sets its set-points for the coming period,
the twin advances to the next instant of the sample grid (the integration step divides
the period: :func:`~drill_twin.runtime.digital_twin.aligned_step`), its measurements
are taken and recorded.  Set-points go through :meth:`TickSession.apply`, which records
each as applied (rejected ones included: a resimulation rejects them again) and says
why one was rejected.

Drivers add only their I/O and their clock: the ROS node (:mod:`drill_twin.ros.
twin_node`) paces ticks against the wall clock and publishes; ``drill-twin scenario
run`` (:func:`drill_twin.operations.runner.run_timeline`) and ``drill-twin simulate
--out run.mcap`` (:func:`drill_twin.io.run_recorder.record_run`) tick as fast as they
can; the closed loop without ROS (:func:`drill_twin.runtime.closed_loop.
run_closed_loop`) puts a controller between two ticks; a resimulation
(:func:`drill_twin.io.resimulation.resimulate`) replays recorded set-points through
:meth:`TickSession.apply`.  Node and offline runs are therefore the same run.
"""
from __future__ import annotations

from ..operations.driller import Driller, ScenarioError
from ..topics import stamp_fields
from .digital_twin import DigitalTwin, SetpointError, aligned_step

__all__ = ['TickSession', 'ScenarioError']


class TickSession:
    """A :class:`DigitalTwin` ticked at ``rate_hz`` [Hz], with an optional recorder
    (:class:`~drill_twin.io.run_recorder.TwinRecorder`) and scenario driller.

    Parameters
    ----------
    twin : DigitalTwin
        The twin, its integration step a divisor of the tick period (see
        :meth:`for_scenario`).
    rate_hz : float
        Ticks per second of simulated time [Hz].
    recorder : TwinRecorder, optional
        Records every applied set-point and (``records_measurements``) every tick's
        measurements; the node records these itself, with the stamps it published.
    """

    def __init__(self, twin: DigitalTwin, rate_hz: float, recorder=None,
                 records_measurements: bool = True):
        self.twin = twin
        self.period_s = 1.0 / float(rate_hz)
        self.recorder = recorder
        self.records_measurements = records_measurements
        self.driller: Driller | None = None
        #: ``on_step(label)`` when the scenario moves to a step ('scenario done' at its
        #: end); ``on_scenario_error(exc)`` when a step cannot be done (the scenario
        #: stops; without a handler the :class:`ScenarioError` propagates)
        self.on_step = None
        self.on_scenario_error = None
        #: ``listener(name, value, error)`` after every :meth:`apply` (error: None or the
        #: reason of a rejection); the node logs and arbitrates there
        self.listeners = []
        #: ``tick_listener(m)`` after every tick with its measurements (the live view)
        self.tick_listeners = []
        #: a :class:`~drill_twin.runtime.scene.StringScene` recorded with the measurements
        #: (:meth:`record_scene`)
        self.scene = None
        self._last = {}            # the last value applied of each set-point

    @staticmethod
    def aligned_twin(scenario, rate_hz: float, **twin_options) -> DigitalTwin:
        """A twin of ``scenario`` whose integration step divides the tick ``1/rate_hz``
        (a tick is a whole number of steps: samples on an exact grid)."""
        step_s = aligned_step(scenario.time_step * scenario.time_unit_s, 1.0 / rate_hz)
        return DigitalTwin(scenario, time_step_s=step_s, **twin_options)

    # --- set-points -----------------------------------------------------------------
    def apply(self, name: str, value: float) -> str | None:
        """Apply set-point ``name`` (a set-point topic of :mod:`drill_twin.topics`) with
        ``value``; record it as applied.  Returns None, or why the twin rejected it (the
        twin then keeps its last valid value)."""
        self._last[name] = value
        if self.recorder is not None:
            self.recorder.setpoint(name, value)
        try:
            self.twin.apply(name, value)
            error = None
        except SetpointError as exc:
            error = str(exc)
        for listener in self.listeners:
            listener(name, value, error)
        return error

    def apply_initial_setpoints(self):
        """The operator set-points in force at the start, applied and recorded at t = 0
        (the start of a recording a resimulation can reproduce)."""
        self.apply('surface_speed_setpoint', self.twin.surface_speed_setpoint)
        if self.twin.has_block:
            self.apply('block_velocity_setpoint', self.twin.block_velocity_setpoint)
        else:
            self.apply('hook_load_setpoint', self.twin.hook_load_N)

    # --- the scenario ------------------------------------------------------------------
    def start_scenario(self, timeline):
        """Drive the twin by ``timeline``'s steps from the next tick on (restarts it)."""
        self.driller = Driller(self.twin, timeline, self._drive)

    def _drive(self, name, value):
        """A driller's set-point: applied when it differs from the last one applied (a ramp
        changes it every tick, a hold never)."""
        if self._last.get(name) != value:
            self.apply(name, value)

    @property
    def scenario_running(self) -> bool:
        return self.driller is not None and not self.driller.done

    def stop_scenario(self):
        """The operator takes over: returns the label of the step that was running (None
        if no scenario ran)."""
        label = self.driller.step.label if self.scenario_running else None
        self.driller = None
        return label

    # --- ticks ---------------------------------------------------------------------------
    def tick(self, target_s: float | None = None, max_steps: int | None = None):
        """One tick: the driller's set-points for the period, the twin advanced to
        ``target_s`` [s] (default: one period on), its measurements recorded.  Returns the
        measurements, or None when no grid instant was due (``max_steps`` [steps] caps the
        work of a tick that runs late)."""
        if target_s is None:
            period = self.period_s
            target = self.twin.time_s + period
        else:
            target, period = target_s, target_s - self.twin.time_s
        if period > 0.0 and self.scenario_running:
            self._tick_scenario(period)
        before = self.twin.time_s
        self.twin.advance_to(target, max_steps=max_steps)
        if self.twin.time_s <= before:
            return None
        m = self.twin.measurements()
        if self.recorder is not None and self.records_measurements:
            self.recorder.measurements(m)
            if self.scene is not None:       # a few Hz: the 3-D view
                for name, fields in self.scene.messages(m, stamp_fields(m['time_s'])):
                    self.recorder.event(name, fields, m['time_s'])
        for listener in self.tick_listeners:
            listener(m)
        return m

    def record_scene(self):
        """Record the 3-D view too (:mod:`drill_twin.runtime.scene`): its latched part now,
        ``/tf`` and ``string/markers`` with the measurements at a few Hz."""
        from .scene import StringScene
        self.scene = StringScene(self.twin)
        if self.recorder is not None:
            for name, fields in self.scene.static_messages(stamp_fields(self.twin.time_s)):
                self.recorder.event(name, fields, self.twin.time_s)

    def _tick_scenario(self, period_s: float):
        previous = self.driller.index
        try:
            self.driller.tick(period_s)
        except ScenarioError as exc:
            self.driller = None
            if self.on_scenario_error is None:
                raise
            self.on_scenario_error(exc)
            return
        if self.driller.index != previous and self.on_step is not None:
            self.on_step(self.driller.step.label if not self.driller.done else 'scenario done')

    def close(self):
        if self.recorder is not None:
            self.recorder.close()
