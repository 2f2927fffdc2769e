"""Every run-time parameter of both nodes: changed, and its effect observed (in-process rig,
spin until a condition or a deadline).  Start-up-only parameters are read-only."""
import math
import time

import numpy as np
import pytest

rclpy = pytest.importorskip('rclpy')
from geometry_msgs.msg import TwistStamped  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.qos import qos_profile_sensor_data  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402

from drill_twin.ros.soft_torque_node import SoftTorqueNode  # noqa: E402
from drill_twin.ros.twin_node import COMMAND_QOS, SETPOINT_QOS  # noqa: E402
from drill_twin.runtime.settings import CONTROLLER_SETTINGS, TWIN_SETTINGS  # noqa: E402


def controller(rig, **params):
    return rig.add(SoftTorqueNode(context=rig.ctx, parameter_overrides=[
        Parameter(k, value=v) for k, v in params.items()]))


def set_ok(node, name, value):
    res = node.set_parameters([Parameter(name, value=value)])[0]
    assert res.successful, res.reason
    assert node.get_parameter(name).value == value


@pytest.mark.parametrize('node_kind, settings', [('twin', TWIN_SETTINGS),
                                                 ('controller', CONTROLLER_SETTINGS)])
def test_start_up_parameters_are_read_only_and_refused(rig, node_kind, settings):
    node = rig.twin() if node_kind == 'twin' else controller(rig)
    for s in settings:
        desc = node.describe_parameter(s.name)
        assert desc.read_only == s.read_only, s.name
        if s.read_only:
            res = node.set_parameters([Parameter(s.name, value=s.default)])[0]
            assert not res.successful and 'read-only' in res.reason


def test_real_time_factor_changes_the_pace_of_simulated_time(rig):
    node = rig.twin(real_time_factor=2.0)
    clock = node.get_clock()

    def pace(span_s):
        assert rig.spin_until(lambda: node.twin.time_s > 0.5, 30)
        t0, s0 = clock.now().nanoseconds, node.twin.time_s
        assert rig.spin_until(lambda: clock.now().nanoseconds - t0 > span_s * 1e9, 30)
        return (node.twin.time_s - s0) / ((clock.now().nanoseconds - t0) * 1e-9)

    assert pace(1.0) == pytest.approx(2.0, rel=0.15)
    set_ok(node, 'real_time_factor', 10.0)
    assert pace(1.0) == pytest.approx(10.0, rel=0.15)


def test_publish_rate_changes_the_period_of_header_stamps(rig):
    node = rig.twin(publish_rate_hz=100.0)
    rig.listen('bit/velocity', TwistStamped,
               lambda m: m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec)
    assert rig.spin_until(lambda: len(rig.data['bit/velocity']) > 60, 30)
    assert np.median(np.diff(rig.data['bit/velocity'][10:])) == pytest.approx(0.01, rel=0.1)
    set_ok(node, 'publish_rate_hz', 25.0)
    n = len(rig.data['bit/velocity'])
    assert rig.spin_until(lambda: len(rig.data['bit/velocity']) > n + 30, 30)
    assert np.median(np.diff(rig.data['bit/velocity'][n + 5:])) == pytest.approx(0.04, rel=0.1)


def test_max_surface_speed_applies_at_once(rig):
    node = rig.twin()
    initial = node.twin.surface_speed_setpoint
    pub = rig.publisher('surface_speed_setpoint')
    set_ok(node, 'max_surface_speed_rad_s', 14.0)
    pub.publish(Float64(data=15.0))
    assert rig.spin_until(lambda: node.twin.rejected >= 1, 10)
    assert node.twin.surface_speed_setpoint == initial
    set_ok(node, 'max_surface_speed_rad_s', 20.0)
    pub.publish(Float64(data=15.0))
    assert rig.spin_until(lambda: node.twin.surface_speed_setpoint == 15.0, 10)
    # a bound below the set-point in force is refused, with the reason
    res = node.set_parameters([Parameter('max_surface_speed_rad_s', value=10.0)])[0]
    assert not res.successful and 'set-point' in res.reason
    assert node.twin.max_surface_speed == 20.0


def test_command_timeout_decides_when_the_operator_set_point_returns(rig):
    node = rig.twin(command_timeout_s=60.0)
    initial = node.twin.surface_speed_setpoint
    cmd = rig.probe.create_publisher(Float64, 'surface_speed_command', COMMAND_QOS)
    assert rig.spin_until(lambda: node.twin.time_s > 0.2, 20)
    assert rig.spin_until(lambda: (cmd.publish(Float64(data=10.0)) or
                                   node.arbiter.source == 'controller'), 10)
    t = node.twin.time_s
    assert rig.spin_until(lambda: node.twin.time_s > t + 2.0, 20)  # silence, long timeout
    assert node.arbiter.source == 'controller' and node.twin.surface_speed_setpoint == 10.0
    set_ok(node, 'command_timeout_s', 0.05)
    assert rig.spin_until(lambda: node.arbiter.source == 'operator', 10)
    assert node.twin.surface_speed_setpoint == initial


def test_stability_period_turns_the_advisor_off_and_on(rig):
    node = rig.twin(stability_period_s=30.0)
    rig.listen('stability/spectral_abscissa', Float64, lambda m: m.data, qos=SETPOINT_QOS)
    assert rig.spin_until(lambda: rig.data['stability/spectral_abscissa'], 60)
    process = node.advisor._proc
    set_ok(node, 'stability_period_s', 0.0)
    assert node.advisor is None and process.poll() is not None   # worker ended
    n = len(rig.data['stability/spectral_abscissa'])
    t = node.twin.time_s
    rig.publisher('surface_speed_setpoint').publish(Float64(data=14.0))  # would trigger one
    assert rig.spin_until(lambda: node.twin.time_s > t + 3.0, 20)
    assert len(rig.data['stability/spectral_abscissa']) == n
    set_ok(node, 'stability_period_s', 30.0)
    assert rig.spin_until(lambda: len(rig.data['stability/spectral_abscissa']) > n, 60)
    assert node.advisor is not None and node.advisor.alive


def _command_rig(rig, **params):
    st = controller(rig, **params)
    rig.listen('surface_speed_command', Float64, lambda m: m.data, qos=COMMAND_QOS)
    torque = rig.probe.create_publisher(Float64, 'surface/torque', qos_profile_sensor_data)
    rig.publisher('surface_speed_setpoint').publish(Float64(data=12.0))
    return st, torque


def _feed(rig, torque, n, value):
    """Publish ``n`` torque samples (value(k)) and spin until n more commands arrived."""
    start = len(rig.data['surface_speed_command'])
    for k in range(n):
        torque.publish(Float64(data=value(k)))
        rig.spin_until(lambda k=k: len(rig.data['surface_speed_command']) > start + k, 5)
    return np.array(rig.data['surface_speed_command'][start:])


def test_enabled_switches_between_soft_torque_and_pass_through(rig):
    st, torque = _command_rig(rig)
    wave = lambda k: 8000.0 + 3000.0 * math.sin(0.3 * k)  # noqa: E731
    on = _feed(rig, torque, 60, wave)
    assert np.ptp(on[10:]) > 0.01              # the virtual drive answers the torque
    set_ok(st, 'enabled', False)
    off = _feed(rig, torque, 30, wave)
    assert np.all(off[2:] == 12.0)              # pass-through: exactly the set-point
    set_ok(st, 'enabled', True)
    again = _feed(rig, torque, 60, wave)
    assert np.ptp(again[10:]) > 0.01


def test_controller_bounds_apply_at_once(rig):
    st, torque = _command_rig(rig)
    assert rig.spin_until(lambda: st.setpoint == 12.0, 10)
    set_ok(st, 'max_surface_speed_rad_s', 14.0)
    rig.publisher('surface_speed_setpoint').publish(Float64(data=15.0))
    assert rig.spin_until(lambda: st.rejected >= 1, 10)
    assert st.setpoint == 12.0
    res = st.set_parameters([Parameter('max_surface_speed_rad_s', value=10.0)])[0]
    assert not res.successful and st.ctrl.max_speed == 14.0
    # rate limit: consecutive commands differ by at most max_acceleration * dt
    set_ok(st, 'max_acceleration_rad_s2', 0.5)
    before = _feed(rig, torque, 5, lambda k: 8000.0)[-1]
    t0 = time.monotonic()          # the node computed ``before`` earlier than this
    rig.publisher('surface_speed_setpoint').publish(Float64(data=13.5))
    cmds = _feed(rig, torque, 40, lambda k: 8000.0)
    elapsed = time.monotonic() - t0
    dt = 1.0 / st.get_parameter('control_rate_hz').value
    steps = np.abs(np.diff(np.concatenate([[before], cmds])))
    # the limit is max_acceleration x the node's clock step: at the nominal rate a step
    # is 0.5 dt (median: a late timer makes a few steps longer, never more in total) and
    # the whole change is within 0.5 x the elapsed time (+ one period's latency)
    assert np.median(steps) == pytest.approx(0.5 * dt, rel=0.2)
    assert steps.sum() <= 0.5 * (elapsed + dt) and cmds[-1] < 13.0


def test_torque_filter_and_measurement_timeout_apply_at_once(rig):
    st, torque = _command_rig(rig, torque_filter_s=1e6)
    _feed(rig, torque, 10, lambda k: 5000.0)
    _feed(rig, torque, 50, lambda k: 9000.0)
    assert st.ctrl.torque_ref == pytest.approx(5000.0, abs=1.0)   # 1e6 s: reference stays
    set_ok(st, 'torque_filter_s', 0.1)
    _feed(rig, torque, 100, lambda k: 9000.0)                     # 1 s at 100 Hz: 10 tau
    assert st.ctrl.torque_ref == pytest.approx(9000.0, rel=1e-3)
    assert not st.in_fallback
    set_ok(st, 'measurement_timeout_s', 0.02)
    assert rig.spin_until(lambda: st.in_fallback, 10)             # no torque for > 20 ms
    set_ok(st, 'measurement_timeout_s', 60.0)
    _feed(rig, torque, 5, lambda k: 9000.0)
    assert not st.in_fallback
    n = st.fallbacks
    rig.spin_until(lambda: False, 0.3)                            # silence below 60 s
    assert not st.in_fallback and st.fallbacks == n


def test_control_rate_changes_the_command_rate(rig):
    st, torque = _command_rig(rig, control_rate_hz=50.0)
    clock = st.get_clock()

    def rate():
        n0, t0 = len(rig.data['surface_speed_command']), clock.now().nanoseconds
        assert rig.spin_until(lambda: clock.now().nanoseconds - t0 > 1e9, 10)
        return (len(rig.data['surface_speed_command']) - n0) / \
            ((clock.now().nanoseconds - t0) * 1e-9)
    assert rig.spin_until(lambda: len(rig.data['surface_speed_command']) > 5, 10)
    assert rate() == pytest.approx(50.0, rel=0.2)
    set_ok(st, 'control_rate_hz', 200.0)
    assert rate() == pytest.approx(200.0, rel=0.2)


def test_a_rejected_atomic_set_changes_nothing(rig):
    st = controller(rig)
    res = st.set_parameters_atomically([Parameter('enabled', value=False),
                                        Parameter('config', value='rgd_stick_slip')])
    assert not res.successful
    assert st.get_parameter('enabled').value is True and st.ctrl.enabled is True
    node = rig.twin()
    res = node.set_parameters_atomically([Parameter('real_time_factor', value=50.0),
                                          Parameter('max_surface_speed_rad_s', value=1.0)])
    assert not res.successful and node.pacer.real_time_factor == 5.0
