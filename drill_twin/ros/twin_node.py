"""``twin_node``: the drilling digital twin as a ROS 2 node (thin adapter over
:class:`drill_twin.runtime.digital_twin.DigitalTwin` and the real-time policy of
:mod:`drill_twin.runtime`).

Lifecycle: a managed node (configure = load the model and warm the kernels,
open the recording, create the topics; activate = run and publish; deactivate =
hold; cleanup / shutdown = close the recording and drop the model), which
configures and activates itself unless ``autostart`` is false.

Time: a wall-clock timer advances the model to where the steady clock says it
should be (:class:`~drill_twin.runtime.pacing.Pacer`: no drift, bounded catch-up,
overruns and slips counted).  With ``as_fast_as_possible`` it runs unthrottled
and publishes ``/clock`` so that other nodes can follow simulated time.  The
numba kernels are compiled and run once before the timer starts.

Speed precedence (:class:`~drill_twin.runtime.arbitration.SpeedArbiter`): a
``surface_speed_command`` (from the Soft-Torque controller) drives the motor while
such commands keep arriving (within ``command_timeout_s``); otherwise the
operator's ``surface_speed_setpoint`` does.

Stability advisory: computed in a worker process of its own
(:class:`~drill_twin.runtime.advisor.StabilityAdvisor`) every
``stability_period_s`` and at once after a set-point change; the loop never
waits for it.  ``stability_period_s: 0`` stops the worker.

Parameters: validated when set (rclpy checks type, range and read-only from the
descriptors; the on-set callback checks the rest), applied after success (the
post-set callback), as in ros2/demos.  Read-only parameters act at start-up only.

Recording: with ``record_path`` the twin writes its own run to MCAP
(:class:`drill_twin.io.run_recorder.TwinRecorder`: simulated log time, set-points
and run-time parameter changes at the simulated time they were applied), which
``drill-twin replay --resimulate`` reproduces exactly.
Topics, units, frames and QoS: see the README (the table is
:data:`drill_twin.topics.TOPICS`).

3-D view: ``/tf`` and ``string/markers`` at a few Hz, ``/tf_static`` and ``well/markers``
latched (:class:`drill_twin.runtime.scene.StringScene`); without ``tf2_msgs`` installed
(the PyPI ROS wheels lack it) the tf topics are recorded and served live, not published.

Live view: ``foxglove_port`` > 0 serves every published topic (and the set-points as
applied) on ``ws://localhost:PORT`` for the Foxglove app
(:class:`drill_twin.live.server.LiveView`; it never blocks the tick).
"""
from __future__ import annotations

import time
from pathlib import Path

from rcl_interfaces.msg import SetParametersResult
from rclpy.exceptions import ParameterException
from rclpy.lifecycle import LifecycleNode, LifecyclePublisher, TransitionCallbackReturn
from rclpy.publisher import Publisher
from rclpy.subscription import Subscription
from std_msgs.msg import Float64, Float64MultiArray
from std_srvs.srv import SetBool, Trigger

from .. import topics as T
from ..config.scenario import load_scenario
from ..console import LogProgress, prepare_kernels
from ..errors import ParameterError
from ..io.run_recorder import TwinRecorder
from ..operations.timeline import load_timeline
from ..physics.simulation import SimulationDiverged
from ..runtime.advisor import StabilityAdvisor
from ..runtime.arbitration import SpeedArbiter
from ..runtime.digital_twin import DigitalTwin, aligned_step
from ..runtime.health import ERROR, WARN, EventWindow, human, worst
from ..runtime.pacing import Pacer
from ..runtime.scene import StringScene
from ..runtime.session import TickSession
from ..runtime.settings import TWIN_SETTINGS
from .common import answer_every_transition, declare_settings, run_node, warn_unknown_overrides
from .entry import interruptible
from .messages import available, message_class, qos_profile, to_message

__all__ = ['TwinNode', 'main', 'SETPOINT_QOS', 'LATCHED_QOS']

#: set-points the twin must not miss (REP-2003: reliable, transient local)
SETPOINT_QOS = qos_profile(T.SETPOINT)
#: low-rate advisories a late joiner should still get
LATCHED_QOS = SETPOINT_QOS
#: controller commands: reliable, volatile (a stale command must not be replayed)
COMMAND_QOS = qos_profile(T.COMMAND)

#: how far back /diagnostics levels look [s]
HEALTH_WINDOW_S = 10.0
#: values of ``record_path`` that switch recording off ('' cannot be written in a shell:
#: ``record_path:=''`` reaches ROS as nothing)
RECORDING_OFF = ('', 'none', 'off')
#: why the twin refuses use_sim_time: it is the source of simulated time, not a follower
USE_SIM_TIME_REFUSED = ('use_sim_time cannot be true for the twin: it is the clock (with '
                        'as_fast_as_possible it publishes /clock for the other nodes); its '
                        'timers would wait for a /clock nobody publishes')


def _reply(response, success: bool, message: str, logger=None):
    """Fill a Trigger/SetBool response (and log its message if ``logger`` is given)."""
    response.success, response.message = success, message
    if logger is not None:
        logger.info(message)
    return response


class TwinNode(LifecycleNode):
    """The twin node (see module docstring).

    A managed (lifecycle) node: *configure* loads the model and compiles and warms the
    kernels, opens the recording and creates the topics; *activate* starts simulated time
    and publishing; *deactivate* holds them; *cleanup* releases what configure made (the
    recording is closed); *shutdown* does so from any state.  With ``autostart`` (the
    default) the node configures and activates itself at start-up, so ``ros2 run`` just
    works; a configuration error then ends the process with one line and exit code 2.
    """

    def __init__(self, **kwargs):
        super().__init__('drill_twin', **kwargs)
        declare_settings(self, TWIN_SETTINGS)
        warn_unknown_overrides(self)
        answer_every_transition(self)
        if self.get_parameter('use_sim_time').value:
            raise ParameterError(USE_SIM_TIME_REFUSED)
        self.twin = None
        self.recorder = None
        self.advisor = None
        self.session = None
        self.live = None
        self.paused = False
        self.active = False
        self._entities = []        # what a configuration created and cleanup destroys
        self._configurations = 0
        self._recordings = 0       # recording files opened (a failed configure's included)
        self._failure = None
        self._autostarting = False
        self._failure_said = False
        self.create_service(Trigger, '~/start_scenario', self._on_start_scenario)
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.create_service(SetBool, '~/pause', self._on_pause)
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        if self._param('autostart'):   # a failure is the process's one error line
            self._autostarting = True
            if self.trigger_configure() != TransitionCallbackReturn.SUCCESS:
                raise self._failure or ParameterError('configure failed (see the log)')
            self._autostarting = False
            self.trigger_activate()

    # --- lifecycle ----------------------------------------------------------------------
    def on_configure(self, state):
        """Load the model (compiling the kernels on a cold cache), open the recording,
        create the topics and timers; FAILURE with one logged line on bad configuration."""
        try:
            self._build_twin()
            self._open_recording()
            self._create_interface()
        except (ParameterError, ParameterException, ValueError, OSError) as exc:
            self._failure = exc
            self._release()
            if not self._autostarting:
                self.get_logger().error(f'configure failed: {" ".join(str(exc).split())}')
            return TransitionCallbackReturn.FAILURE
        except Exception as exc:  # a bug: rclpy would swallow it, so keep it to re-raise
            self._failure = exc
            self._release()
            self.get_logger().error(f'configure failed (internal error): {exc!r}')
            return TransitionCallbackReturn.ERROR
        self._configurations += 1
        self.get_logger().info(
            f'twin of {self.twin.scenario.model.name} configured, step {self.twin.step_s:.2e} '
            f's, hook load {self.twin.hook_load_N:.0f} N, surface speed '
            f'{self.twin.surface_speed_setpoint:.2f} rad/s')
        return super().on_configure(state)

    def on_activate(self, state):
        """Simulated time runs from where it was held (pacing re-anchored to now)."""
        self._resume_pacing()
        self.active = True
        self._hold_recording()
        self._timer.reset()
        self.get_logger().info(f'active at t = {self.twin.time_s:.3f} s')
        return super().on_activate(state)

    def on_deactivate(self, state):
        """Hold: simulated time stops, nothing is published but /diagnostics."""
        self.active = False
        self._hold_recording()
        self._timer.cancel()
        self.get_logger().info(f'inactive: held at t = {self.twin.time_s:.3f} s')
        return super().on_deactivate(state)

    def on_cleanup(self, state):
        self._release()
        self.get_logger().info('cleaned up: unconfigured')
        return super().on_cleanup(state)

    def on_shutdown(self, state):
        recording = self.recorder.path if self.recorder is not None else None
        self._release()
        self.get_logger().info('shut down' + (f': {recording} closed' if recording else ''))
        return super().on_shutdown(state)

    def _build_twin(self):
        g = self._param
        overrides = [o for o in g('overrides') if o]
        self.timeline = None
        if g('scenario'):
            explicit = set(getattr(self, '_parameter_overrides', {})) & {'config', 'overrides'}
            if explicit:
                raise ParameterError('give the scenario parameter or config/overrides, not '
                                     'both: a scenario file names its configuration')
            self.timeline = load_timeline(g('scenario'))
            config, overrides = self.timeline.configuration, list(self.timeline.overrides)
        else:
            config = g('config')
        self._source = (config, overrides)
        with interruptible():  # a signal while compiling ends the process at once
            log = self.get_logger().info
            log(f"loading {g('scenario') or config}")
            prepare_kernels(say=log, progress=LogProgress(log, 'compiling the physics kernels'))
            scenario = load_scenario(config, overrides, label='parameter overrides:')
            self.fast = g('as_fast_as_possible')
            # a publish period of simulated time is a whole number of integration steps, so that
            # samples (and their stamps) are evenly spaced
            sample_s = (1.0 if self.fast else g('real_time_factor')) / g('publish_rate_hz')
            self._twin_args = dict(
                drive_time_constant_s=g('drive_time_constant_s'),
                max_surface_speed_rad_s=g('max_surface_speed_rad_s'),
                time_step_s=aligned_step(scenario.time_step * scenario.time_unit_s, sample_s),
                start_above_bottom_m=self.timeline.bit_above_bottom_m
                if self.timeline is not None and self.timeline.start == 'rest' else None)
            self.twin = DigitalTwin(scenario, **self._twin_args)
            self.twin.warm_up()  # compile/run the kernels now, not in the first tick
        self._start_run()
        self.paused = False
        self.health = EventWindow(HEALTH_WINDOW_S)
        self.advisory = None
        self._advice_due = 0.0
        self._overflows_seen = 0

    def _open_recording(self):
        """The run's recording; a configuration after a cleanup records to a numbered
        sibling (``run_2.mcap``), so that nothing recorded before is overwritten."""
        path = self._param('record_path')
        if path.strip().lower() in RECORDING_OFF:
            return
        if self._recordings:       # after a cleanup or a failed configure: a new file
            path = Path(path)
            path = path.with_name(f'{path.stem}_{self._recordings + 1}{path.suffix}')
        self._recordings += 1
        config, overrides = self._source
        self.recorder = TwinRecorder(
            str(path), self.twin, config, overrides,
            namespace=self.get_namespace(), node=self.get_fully_qualified_name(),
            chunk_period_s=self._param('record_chunk_period_s'),
            settings={'publish_rate_hz': self._param('publish_rate_hz'),
                      'real_time_factor': self._param('real_time_factor'),
                      'as_fast_as_possible': self.fast, 'source': 'twin_node'})
        self.session.recorder = self.recorder
        self.get_logger().info(f'recording to {path}')
        self._hold_recording()

    def _create_interface(self):
        """Subscriptions, publishers (lifecycle publishers: silent unless active; /diagnostics
        always) and timers of this configuration."""
        add = self._entities.append
        for name, cls, callback, qos in (
                ('surface_speed_setpoint', Float64, self._on_speed, SETPOINT_QOS),
                ('hook_load_setpoint', Float64, self._on_hook_load, SETPOINT_QOS),
                ('surface_speed_command', Float64, self._on_command, COMMAND_QOS),
                ('block_velocity_setpoint', Float64, self._on_block, SETPOINT_QOS),
                ('torque_limit_setpoint', Float64, self._on_torque_limit, SETPOINT_QOS),
                (T.COMMANDS_TOPIC, Float64MultiArray, self._on_commands, SETPOINT_QOS)):
            add(self.create_subscription(cls, name, callback, qos))
        roles = ('measurement', 'advisory', 'scene') + (('clock',) if self.fast else ())
        self.pub = {}
        for t in T.TOPICS:
            if t.role in roles + ('diagnostics', 'geometry') and available(t.type):
                cls = message_class(t.type)
                create = (self.create_lifecycle_publisher if t.role in roles
                          else self.create_publisher)
                self.pub[t.name] = (cls, create(cls, t.name, qos_profile(t.qos)))
                add(self.pub[t.name][1])
        if self.recorder is not None:
            add(self.create_timer(self._param('record_chunk_period_s'), self.recorder.flush))
        self._set_advisory_period(self._param('stability_period_s'))
        add(self.create_timer(0.1, self._advise))
        add(self.create_timer(1.0, self._publish_diagnostics))
        self._timer = self.create_timer(self._tick_period(), self._tick, autostart=False)
        self._open_live()
        for name, fields in self.scene.static_messages(
                T.stamp_fields(ns=self._stamp_ns(self.twin.time_s))):
            self._send(name, fields)
        if self.timeline is not None:
            self._start_scenario()

    def _release(self):
        """Undo a configuration: topics and timers destroyed, advisor stopped, recording
        closed (complete), the model dropped."""
        self.active = False
        if self.recorder is not None:
            self.recorder.close()
            self.recorder = None
        if self.live is not None:
            self.live.close()
            self.live = None
        if self.twin is None:
            return
        timer, self._timer = getattr(self, '_timer', None), None
        for entity in self._entities + ([timer] if timer is not None else []):
            if isinstance(entity, LifecyclePublisher):
                self.destroy_lifecycle_publisher(entity)
            elif isinstance(entity, Publisher):
                self.destroy_publisher(entity)
            elif isinstance(entity, Subscription):
                self.destroy_subscription(entity)
            else:
                self.destroy_timer(entity)
        self._entities = []
        self._set_advisory_period(0.0)
        self.twin = self.session = None

    def _open_live(self):
        """The Foxglove WebSocket server of this configuration (``foxglove_port`` > 0)."""
        port = self._param('foxglove_port')
        if port == 0:
            return
        if not 0 < port < 65536:
            raise ParameterError(f'parameter foxglove_port = {port}: must be 1-65535, or 0 = off')
        from ..live.server import LiveView
        roles = set(T.LIVE_ROLES) - (set() if self.fast else {'clock'})
        self.live = LiveView([t for t in T.TOPICS if t.role in roles], port,
                             namespace=self.get_namespace())
        self.get_logger().info(f'live view on {self.live.url} (Foxglove: open connection)')

    def _hold_recording(self):
        """Set-points are recorded when simulated time runs; while it is held (inactive,
        paused) the recorder keeps the last of each (:meth:`TwinRecorder.hold`)."""
        if self.recorder is not None:
            if self.active and not self.paused:
                self.recorder.release()
            else:
                self.recorder.hold()

    def _resume_pacing(self):
        """Re-anchor the pacing to now: simulated time goes on from where it was held."""
        if self.pacer.started:
            self.pacer.anchor(time.monotonic(), self.twin.time_s, self._ros_now())

    def _param(self, name):
        return self.get_parameter(name).value

    def _start_run(self):
        """Speed arbitration and pacing of a run of ``self.twin`` from its start (at
        start-up and on ``~/reset``)."""
        g = self._param
        self.arbiter = SpeedArbiter(self.twin.surface_speed_setpoint, g('command_timeout_s'))
        self.pacer = Pacer(g('real_time_factor'), 1.0 / g('publish_rate_hz'), self.twin.step_s)
        # the node records measurements itself (with the stamps it publishes)
        self.session = TickSession(self.twin, g('publish_rate_hz'), self.recorder,
                                   records_measurements=False)
        self.session.listeners.append(self._on_applied)
        self.session.on_step = self.get_logger().info
        self.session.on_scenario_error = lambda exc: self.get_logger().error(
            f'scenario stopped: {exc}')
        self.scene = StringScene(self.twin)
        self.blow_up = ''
        self._last_measurements = None

    def _tick_period(self) -> float:
        return 0.0 if self.fast else 1.0 / self._param('publish_rate_hz')

    # --- inputs ----------------------------------------------------------------------
    def _send(self, name, fields, time_s=None):
        """Publish on a topic of the interface table, record it and serve it live."""
        if self.recorder is not None:
            self.recorder.event(name, fields, time_s)
        if self.live is not None:
            self.live.publish(name, fields, self._stamp_ns(self.twin.time_s if time_s is None
                                                           else time_s))
        if name in self.pub:     # not a message type this machine has (tf2_msgs)
            cls, pub = self.pub[name]
            pub.publish(to_message(cls, fields))

    @property
    def driller(self):
        return self.session.driller if self.session is not None else None

    def _apply_speed(self, value, source) -> bool:
        """Apply a speed set-point or command; ``source`` is its topic (recorded as such;
        the return to the operator set-point is recorded as ``surface_speed_setpoint``)."""
        return self.session.apply(source, value) is None

    def _on_applied(self, name, value, error):
        """After every set-point the session applied: arbitration, the advisory, and one
        warning for a rejection (the twin keeps its last valid value)."""
        now = time.monotonic()
        if self.live is not None:
            self.live.setpoint(name, value, self._stamp_ns(self.twin.time_s))
        if error is not None:
            self.health.add('rejected', now)
            kept = ''
            if name == 'surface_speed_setpoint':
                kept = f'; keeping the operator set-point {self.arbiter.operator_speed:g} rad/s'
            elif name == 'surface_speed_command':
                kept = f'; keeping {self.twin.surface_speed_setpoint:.3f} rad/s'
            self.get_logger().warning(f'rejected {name}: {error}{kept}')
        elif name == 'surface_speed_setpoint':
            self.arbiter.on_operator(value, now)
            self._advice_due = 0.0  # the advisory follows the new set-point at once
        elif name == 'surface_speed_command':
            self.arbiter.on_command(value, now)
        elif name == 'hook_load_setpoint':
            self._advice_due = 0.0

    def _on_speed(self, msg):
        self._operator_takes_over('surface_speed_setpoint')
        self._operator_speed(msg.data)

    def _operator_speed(self, value):
        self._apply_speed(value, 'surface_speed_setpoint')

    def _on_block(self, msg):
        self._operator_takes_over('block_velocity_setpoint')
        self._apply_block(msg.data)

    def _apply_block(self, value):
        self.session.apply('block_velocity_setpoint', value)

    def _on_commands(self, msg):
        """Forward-command-controller style: ``data = [top-drive speed rad/s]`` or
        ``[top-drive speed rad/s, block velocity m/s]`` (operator set-points)."""
        data = list(msg.data)
        if len(data) not in (1, 2):
            self.health.add('rejected', time.monotonic())
            self.get_logger().warning(f'rejected {T.COMMANDS_TOPIC}: {len(data)} values, '
                                      'expected [top_drive speed] or [top_drive speed, '
                                      'block velocity]')
            return
        self._operator_takes_over(T.COMMANDS_TOPIC)
        self._operator_speed(data[0])
        if len(data) == 2:
            self._apply_block(data[1])

    # --- services: reset, pause -----------------------------------------------------------
    def _on_reset(self, request, response):
        """Back to the configured initial state (a new twin from the same scenario)."""
        if self.twin is None:
            return self._unconfigured(response)
        if self.recorder is not None:
            return _reply(response, False, 'reset refused while recording: the recording\'s '
                          'simulated log time would restart; stop the node to end the file')
        self.twin = DigitalTwin(self.twin.scenario, **self._twin_args)
        self._start_run()
        if self.timeline is not None:
            self._start_scenario()
        return _reply(response, True, f'reset to t = 0 s, surface speed '
                      f'{self.twin.surface_speed_setpoint:g} rad/s', self.get_logger())

    def _on_pause(self, request, response):
        """``data: true`` holds simulated time (nothing is published); ``false`` resumes from
        where it held, the pacing re-anchored to now."""
        if self.twin is None:
            return self._unconfigured(response)
        if request.data == self.paused:
            return _reply(response, True, f"already {'paused' if self.paused else 'running'}")
        self.paused = bool(request.data)
        if not self.paused:
            self._resume_pacing()
        self._hold_recording()
        return _reply(response, True, f"{'paused' if self.paused else 'running'} at t = "
                      f'{self.twin.time_s:.3f} s', self.get_logger())

    @staticmethod
    def _unconfigured(response):
        return _reply(response, False, 'not configured: configure the node first (ros2 '
                      'lifecycle set)')

    # --- operations scenarios ----------------------------------------------------------
    def _start_scenario(self):
        self.session.start_scenario(self.timeline)
        self.get_logger().info(f'scenario {self.timeline.path.name}: '
                               f'{len(self.timeline.steps)} steps')
        if self.driller.step is not None:       # the first step starts with the driller
            self.get_logger().info(self.driller.step.label)

    def _on_start_scenario(self, request, response):
        if self.twin is None:
            return self._unconfigured(response)
        if self.timeline is None:
            return _reply(response, False, 'no scenario: start the node with -p scenario:=FILE')
        self._start_scenario()
        return _reply(response, True, f'scenario {self.timeline.path.name} started')

    def _operator_takes_over(self, topic):
        label = self.session.stop_scenario() if self.session is not None else None
        if label is not None:
            self.get_logger().warning(f'{topic} from the operator: scenario stopped at '
                                      f'{label}')

    def _on_command(self, msg):
        if self._apply_speed(msg.data, 'surface_speed_command'):
            self.arbiter.on_command(msg.data, time.monotonic())

    def _on_torque_limit(self, msg):
        self.session.apply('torque_limit_setpoint', msg.data)

    def _on_hook_load(self, msg):
        self._operator_takes_over('hook_load_setpoint')
        self._apply_hook_load(msg.data)

    def _apply_hook_load(self, value):
        self.session.apply('hook_load_setpoint', value)

    # --- parameters: validate on set, apply after ------------------------------------
    def _validate_parameters(self, params):
        for prm in params:
            if prm.name == 'use_sim_time' and prm.value:
                return SetParametersResult(successful=False, reason=USE_SIM_TIME_REFUSED)
        if self.twin is None:  # unconfigured: the values act at the next configure
            return SetParametersResult(successful=True)
        for prm in params:
            if prm.name == 'max_surface_speed_rad_s' and prm.value < self.arbiter.operator_speed:
                return SetParametersResult(successful=False, reason=(
                    f'max_surface_speed_rad_s {prm.value:g} rad/s is below the operator '
                    f'set-point {self.arbiter.operator_speed:g} rad/s; lower the set-point '
                    'first'))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params):
        if self.twin is None:
            return
        wall, sim = time.monotonic(), self.twin.time_s
        # the pacer re-anchors at the current instant: stamps stay continuous
        for prm in params:
            if prm.name == 'real_time_factor':
                self.pacer.retime(wall, sim, real_time_factor=prm.value)
            elif prm.name == 'publish_rate_hz' and self.fast:
                self.session.period_s = 1.0 / prm.value
            elif prm.name == 'publish_rate_hz':
                self.pacer.retime(wall, sim, period_s=1.0 / prm.value)
                self._timer.cancel()
                self.destroy_timer(self._timer)
                self._timer = self.create_timer(1.0 / prm.value, self._tick,
                                                autostart=self.active)
            elif prm.name == 'max_surface_speed_rad_s':
                self.twin.max_surface_speed = float(prm.value)
            elif prm.name == 'command_timeout_s':
                self.arbiter.watchdog.timeout_s = float(prm.value)
            elif prm.name == 'stability_period_s':
                self._set_advisory_period(prm.value)
        if self.recorder is not None:
            self.recorder.parameters(params)

    # --- real-time loop ------------------------------------------------------------------
    def _tick(self):
        if self.blow_up or self.paused or not self.active:
            return
        wall = time.monotonic()
        back = self.arbiter.check(wall)
        if back is not None:
            self.health.add('controller_timeout', wall)
            self.get_logger().warning('controller commands stopped: back to the operator '
                                      'set-point')
            self._apply_speed(back, 'surface_speed_setpoint')
        if self.fast:  # one period (exactly: as drill-twin scenario run ticks)
            target, budget = None, None
        else:
            plan = self.pacer.plan(self._scheduled(wall), self.twin.time_s, self._ros_now())
            target, budget = plan.target_s, plan.max_steps
        try:
            m = self.session.tick(target, budget)
            if m is None:                     # no grid instant due yet: nothing new to say
                return
        except SimulationDiverged as exc:  # model blow-up: report, keep the node up
            self.blow_up = str(exc)
            self.get_logger().error(f'model stopped: {exc}')
            return
        if not self.fast:
            outcome = self.pacer.settle(time.monotonic(), self.twin.time_s, plan,
                                        self._ros_now())
            if outcome is not None:
                self.health.add(outcome, wall)
        self._last_measurements = m
        self._publish(m)

    def _scheduled(self, wall: float) -> float:
        """The steady-clock time this tick was scheduled for: the timer keeps a fixed grid
        (a late call does not shift the next ones), so the tick is due one period before
        the next call."""
        until_ns = self._timer.time_until_next_call()
        if until_ns is None:
            return wall
        return wall + until_ns * 1e-9 - self._timer.timer_period_ns * 1e-9

    def _ros_now(self) -> int:
        return self.get_clock().now().nanoseconds

    def _stamp_ns(self, time_s) -> int:
        """ROS time of a simulated instant: the simulated time itself as fast as possible
        (what /clock says), else its real-time mapping (:meth:`Pacer.stamp_ns`)."""
        if self.fast:
            return int(round(time_s * 1e9))
        stamp = self.pacer.stamp_ns(time_s)
        return self._ros_now() if stamp is None else stamp

    def _publish(self, m):
        stamp_ns = self._stamp_ns(m['time_s'])
        stamp = T.stamp_fields(ns=stamp_ns)
        messages = T.measurement_messages(m, stamp)
        if self.recorder is not None:  # first: whatever a subscriber got is in the file
            self.recorder.measurements(m, messages=messages)
        if self.live is not None:
            self.live.publish_all(messages, stamp_ns)
        for topic, fields in messages:
            cls, pub = self.pub[topic.name]
            pub.publish(to_message(cls, fields))
        for name, fields in self.scene.messages(m, stamp):   # a few Hz
            self._send(name, fields, m['time_s'])
        if self.fast:
            self._send('/clock', T.clock_fields(m['time_s']), m['time_s'])

    # --- stability advisory (worker process) -----------------------------------------
    def _set_advisory_period(self, period_s):
        if period_s > 0 and self.advisor is None:
            self.advisor = StabilityAdvisor(self.twin.scenario.raw)
            self._advice_due = 0.0
        elif period_s == 0 and self.advisor is not None:
            self.advisor.close()
            self.advisor = None

    def _advise(self):
        if self.advisor is None:
            return
        answer = self.advisor.poll()
        if answer is not None:
            if 'error' in answer:
                self.get_logger().info(f"stability advisory skipped: {answer['error']}")
            else:
                self.advisory = (answer['spectral_abscissa_1_s'],
                                 answer['critical_surface_speed_rad_s'])
                self._send('stability/spectral_abscissa', {'data': self.advisory[0]})
                self._send('stability/critical_surface_speed', {'data': self.advisory[1]})
        now = time.monotonic()
        if self.active and now >= self._advice_due and not self.advisor.busy and self.advisor.alive:
            wob = self.twin.string_weight_N - self.twin.hook_load_N
            if self.advisor.request(self.arbiter.operator_speed, wob):
                self._advice_due = now + self._param('stability_period_s')

    def _status(self, now):
        recent = {k: self.health.recent(k, now) for k in ('overrun', 'slip', 'rejected',
                                                          'delay_overflow', 'controller_timeout')}
        window = f'in the last {HEALTH_WINDOW_S:g} s'
        advisor_down = self.advisor is not None and not self.advisor.alive
        failure = self._recording_failure()
        return worst(
            (ERROR, f'model stopped: {self.blow_up}') if self.blow_up else None,
            (ERROR, f'recording stopped: {failure}; the twin keeps running (drill-twin mcap '
                    'recover reads what was written)') if failure else None,
            (WARN, f"{recent['overrun']} overruns {window}") if recent['overrun'] else None,
            (WARN, f"real time slipped {recent['slip']} times {window}") if recent['slip']
            else None,
            (WARN, f"{recent['rejected']} set-points rejected {window}") if recent['rejected']
            else None,
            (WARN, f"{recent['delay_overflow']} delay-history overflows {window}")
            if recent['delay_overflow'] else None,
            (WARN, f"controller commands stopped {recent['controller_timeout']} times {window}")
            if recent['controller_timeout'] else None,
            (WARN, f'stability advisor stopped: {self.advisor.failure}') if advisor_down
            else None), recent

    def _recording_failure(self) -> str | None:
        """Why the recording stopped (None while it runs, or without one); said once in the
        log, and in every /diagnostics after."""
        failure = self.recorder.failure if self.recorder is not None else None
        if failure and not self._failure_said:
            self._failure_said = True
            self.get_logger().error(f'recording stopped: {failure}; the twin keeps running')
        return failure

    def _publish_diagnostics(self):
        m = self._last_measurements
        if m is None:
            return  # nothing simulated yet
        now = time.monotonic()
        health = self.twin.health()
        self.health.add('delay_overflow', now, health['history_overflows'] - self._overflows_seen)
        self._overflows_seen = health['history_overflows']
        (level, message), recent = self._status(now)
        values = {'simulated_time_s': round(m['time_s'], 3),
                  'lifecycle': 'active' if self.active else 'inactive',
                  'speed_source': self.arbiter.source,
                  'scenario': self._scenario_state(),
                  'delay_residual_rad': m['delay_residual_rad'],
                  'overruns': self.health.total('overrun'),
                  'overruns_last_10s': recent['overrun'],
                  'real_time_slips': self.health.total('slip'),
                  'controller_timeouts': self.health.total('controller_timeout'),
                  'rejected_setpoints': health['rejected_setpoints'],
                  'delay_history_overflows': health['history_overflows'],
                  'stick_slip_events': health['events']}
        if self.advisory:
            values['spectral_abscissa_1_s'], values['critical_surface_speed_rad_s'] = \
                self.advisory
        stamp = T.stamp_fields(ns=self.get_clock().now().nanoseconds)
        self._send('/diagnostics', T.diagnostics_fields(
            stamp, level, message, {k: human(v) for k, v in values.items()}))

    def _scenario_state(self) -> str:
        if self.driller is None:
            return 'none'
        if self.driller.done:
            return 'done'
        return f'{self.driller.index + 1}/{len(self.driller.steps)} {self.driller.step.action}'

    def destroy_node(self):
        self._release()
        result = super().destroy_node()
        # rclpy's LifecycleNode (Jazzy) does not destroy its state machine, which holds the
        # node's handle: the node, and so the context and its DDS participant, were never
        # freed before the process left, and discovery listed /drill_twin for the 20 s of
        # its lease after the twin had exited
        machine = getattr(self, '_state_machine', None)
        if machine is not None:
            machine.destroy_when_not_in_use()
        return result


def main(args=None):
    return run_node(TwinNode, 'twin_node', args)


if __name__ == '__main__':
    raise SystemExit(main())
