"""Each controller mode over DDS with the twin: the node runs the mode's gains (those the
physics library computes for the configuration), commands the twin, and the twin follows
it; the command obeys the mode's law (pass-through for stiff PI, the virtual drive of the
mode otherwise, replayed offline from the node's own inputs)."""
import math

import numpy as np
import pytest

rclpy = pytest.importorskip('rclpy')
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402

from drill_twin.control.external import mode_drive  # noqa: E402
from drill_twin.ros.soft_torque_node import TopDriveControllerNode  # noqa: E402
from drill_twin.ros.twin_node import COMMAND_QOS, TwinNode  # noqa: E402


def _diag_values(msg):
    for st in msg.status:
        if 'top_drive_controller' in st.name:
            return {kv.key: kv.value for kv in st.values}
    return None


@pytest.mark.timeout(600)
@pytest.mark.parametrize('mode', ['stiff_pi', 'soft_torque', 'z_torque', 'stability_tuned'])
def test_controller_mode_drives_the_twin_over_dds(rig, mode):
    twin = rig.add(TwinNode(context=rig.ctx, parameter_overrides=[
        Parameter('real_time_factor', value=5.0), Parameter('stability_period_s', value=0.0)]))
    ctrl = rig.add(TopDriveControllerNode(context=rig.ctx, parameter_overrides=[
        Parameter('mode', value=mode)]))
    expected = mode_drive(mode, 'rig_fem').gains
    rig.listen('surface_speed_command', Float64, lambda m: m.data, qos=COMMAND_QOS)
    rig.listen('/diagnostics', DiagnosticArray, _diag_values, qos=10)
    rig.publisher('surface_speed_setpoint').publish(Float64(data=12.57))
    assert rig.spin_until(lambda: len(rig.data['surface_speed_command']) > 100
                          and any(rig.data['/diagnostics']), 60)
    assert twin.arbiter.source == 'controller'
    diag = next(d for d in rig.data['/diagnostics'] if d)
    assert diag['mode'] == mode
    assert float(diag['proportional_gain_Nms_rad']) == pytest.approx(
        expected.proportional_Nms_rad, rel=1e-5)
    assert float(diag['torque_feedback_rad_s_Nm']) == pytest.approx(
        expected.torque_feedback_rad_s_Nm, rel=1e-5, abs=1e-12)
    cmds = np.array(rig.data['surface_speed_command'])
    assert np.all(np.isfinite(cmds)) and np.all(cmds >= 0)
    if mode == 'stiff_pi':
        assert np.all(cmds == 12.57)
    else:
        # the virtual drive answers the torque swing: the command moves, around the set-point
        assert np.ptp(cmds) > 0 and math.isclose(np.median(cmds), 12.57, rel_tol=0.05)
    assert not ctrl.in_fallback


def _controller_status(msg):
    for st in msg.status:
        if 'top_drive_controller' in st.name:
            level = ord(st.level) if isinstance(st.level, bytes) else int(st.level)
            return level, {kv.key: kv.value for kv in st.values}, st.message
    return None


GLITCHES = [(1e30, 1), (-1e30, 1), (1e7, 1), (math.nan, 1), (1e30, 20), (-1e7, 20),
            (math.nan, 20)]


@pytest.mark.timeout(600)
def test_glitches_on_every_controller_input_leave_the_top_drive_at_the_set_point(rig):
    """Beside a running twin at real time, single samples and bursts of 20 (0.2 s at
    100 Hz) of ±1e30, ±1e7 and NaN on the controller's torque input, and the same values on
    its set-point topic: the top drive stays within 10 % of the operator's set-point, the
    glitches are counted and the controller's diagnostics warn (before: one 1e30 sample
    pinned the command, and the rig, at 40 rad/s with diagnostics OK)."""
    twin = rig.add(TwinNode(context=rig.ctx, parameter_overrides=[
        Parameter('real_time_factor', value=1.0), Parameter('stability_period_s', value=0.0)]))
    ctrl = rig.add(TopDriveControllerNode(context=rig.ctx))
    rig.listen('surface/top_drive_speed', Float64, lambda m: m.data)
    rig.listen('/diagnostics', DiagnosticArray, _controller_status, qos=10)
    setpoint = rig.publisher('surface_speed_setpoint')
    setpoint.publish(Float64(data=10.0))
    torque = rig.probe.create_publisher(Float64, 'surface/torque', 10)
    assert rig.spin_until(lambda: twin.arbiter.source == 'controller'
                          and twin.twin.time_s > 8.0, 60)        # settled at 10 rad/s
    start = len(rig.data['surface/top_drive_speed'])
    sent = 0
    for value, burst in GLITCHES:
        for _ in range(burst):
            torque.publish(Float64(data=value))
            sent += 1
            rig.spin_until(lambda: False, 0.01)                    # 100 Hz
        rig.spin_until(lambda: False, 0.3)
    for value in (1e30, -1e30, 1e7, math.nan, -1.0):
        setpoint.publish(Float64(data=value))
        rig.spin_until(lambda: False, 0.05)
    t_end = twin.twin.time_s + 3.0
    assert rig.spin_until(lambda: twin.twin.time_s > t_end, 30)
    speeds = np.array(rig.data['surface/top_drive_speed'][start:])
    assert speeds.size > 300 and np.all(np.abs(speeds - 10.0) < 1.0), (speeds.min(),
                                                                       speeds.max())
    # best-effort delivery (sensor QoS, depth 5) may drop some of a burst: each glitch that
    # arrived is refused, and every glitch sent arrived at least once
    assert len(GLITCHES) <= ctrl.policy.torque.refused <= sent and ctrl.rejected == 5
    assert ctrl.setpoint == 10.0
    assert rig.spin_until(lambda: any(d and d[0] == 1 and 'refused' in d[2]
                                      for d in rig.data['/diagnostics'][-3:]), 5)
    level, values, _ = next(d for d in reversed(rig.data['/diagnostics']) if d)
    assert int(values['refused_torque_samples']) == ctrl.policy.torque.refused
