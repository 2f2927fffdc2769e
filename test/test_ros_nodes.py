"""The ROS 2 nodes, in-process: one context, one executor, spin until a condition or a
deadline (no sleeps as synchronisation)."""
import math

import numpy as np
import pytest

rclpy = pytest.importorskip('rclpy')
from geometry_msgs.msg import WrenchStamped  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402

from drill_twin.config.scenario import load_scenario  # noqa: E402
from drill_twin.ros.soft_torque_node import SoftTorqueNode  # noqa: E402
from drill_twin.ros.twin_node import COMMAND_QOS, SETPOINT_QOS  # noqa: E402
from drill_twin.stability.spectrum import rightmost_roots  # noqa: E402


def twin(rig, **params):
    return rig.twin(**{'real_time_factor': 20.0, **params})


def test_speed_step_follows_the_drive_lag(rig, tmp_path):
    """The drive answers a set-point step as a first-order lag, on the twin's own simulated
    time: the twin's recording gives each sample's instant and the instant the set-point was
    applied exactly (no wall-clock guess)."""
    from drill_twin.io.mcap_reader import open_recording
    path = tmp_path / 'step.mcap'
    node = twin(rig, config='benchmark_fem', drive_time_constant_s=0.5, record_path=str(path))
    initial = node.twin.surface_speed_setpoint
    assert rig.spin_until(lambda: node.twin.time_s > 0.5, 20)
    rig.publisher('surface_speed_setpoint').publish(Float64(data=15.0))
    assert rig.spin_until(lambda: node.twin.surface_speed_setpoint == 15.0, 10)
    t_step = node.twin.time_s
    assert rig.spin_until(lambda: node.twin.time_s > t_step + 4.0, 30)
    rig.ex.remove_node(node)
    rig.nodes.remove(node)
    node.destroy_node()                     # closes the recording
    rec = open_recording(path)
    applied = [t * 1e-9 for topic, t, m in rec.decoded(['/surface_speed_setpoint'])
               if m.data == 15.0]
    assert applied == [pytest.approx(t_step, abs=1e-9)]
    drive = np.array([(t * 1e-9, m.data) for _, t, m in
                      rec.decoded(['/surface/top_drive_speed'])])
    after = drive[drive[:, 0] > t_step]
    # first-order drive: ω(t) = 15 + (ω_0 - 15) e^{-(t - t_step)/T}, T = 0.5 s
    model = 15 + (initial - 15) * np.exp(-(after[:, 0] - t_step) / 0.5)
    assert np.abs(after[:, 1] - model).max() < 2e-3 * abs(15 - initial)
    assert after[-1, 1] == pytest.approx(15.0, abs=0.01)
    # the bit follows through the string: its mean speed moves to the new set-point
    bit = np.array([(t * 1e-9, m.twist.angular.x) for _, t, m in
                    rec.decoded(['/bit/velocity'])])
    assert bit[bit[:, 0] > t_step + 1.5, 1].mean() == pytest.approx(15.0, rel=0.1)


def test_hook_load_change_changes_wob_in_the_mean(rig):
    node = twin(rig)
    rig.listen('bit/wrench', WrenchStamped, lambda m: (node.twin.time_s, m.wrench.force.x))
    assert rig.spin_until(lambda: node.twin.time_s > 1.0, 20)
    H0 = node.twin.hook_load_N
    rig.publisher('hook_load_setpoint').publish(Float64(data=H0 - 10e3))
    assert rig.spin_until(lambda: node.twin.time_s > 40.0, 60)
    w = np.array(rig.data['bit/wrench'])
    late = w[w[:, 0] > 10.0, 1]
    # momentum balance: the mean WOB equals buoyed weight minus hook load
    assert late.mean() == pytest.approx(node.twin.string_weight_N - (H0 - 10e3), rel=0.05)


@pytest.mark.parametrize('bad', [float('nan'), float('inf'), -1.0, 1e6])
def test_bad_setpoints_are_rejected_and_the_twin_keeps_running(rig, bad):
    node = twin(rig)
    assert rig.spin_until(lambda: node.twin.time_s > 0.5, 20)
    speed = node.twin.surface_speed_setpoint
    rig.publisher('surface_speed_setpoint').publish(Float64(data=bad))
    rig.publisher('hook_load_setpoint').publish(Float64(data=bad))
    assert rig.spin_until(lambda: node.twin.rejected >= 2, 10)
    t = node.twin.time_s
    assert rig.spin_until(lambda: node.twin.time_s > t + 1.0, 10)
    assert node.twin.surface_speed_setpoint == speed


def test_runtime_parameters_apply_or_are_rejected(rig):
    node = twin(rig)
    res = node.set_parameters([Parameter('real_time_factor', value=5.0)])[0]
    assert res.successful
    res = node.set_parameters([Parameter('config', value='rgd_stick_slip')])[0]
    assert not res.successful and "read-only" in res.reason


def test_stability_advisory_matches_the_stability_module(rig):
    twin(rig, stability_period_s=3600.0)
    rig.listen('stability/spectral_abscissa', Float64, lambda m: m.data,
               qos=SETPOINT_QOS)
    assert rig.spin_until(lambda: rig.data['stability/spectral_abscissa'], 60)
    sc = load_scenario('rig_fem')       # the twin's default: the motor drive, closed loop
    ref = rightmost_roots(sc.model, sc.groups).abscissa / sc.scales.time_s
    assert rig.data['stability/spectral_abscissa'][0] == pytest.approx(ref, rel=1e-6)


def test_soft_torque_holds_setpoint_without_measurements(rig):
    st = rig.add(SoftTorqueNode(context=rig.ctx))
    rig.listen('surface_speed_command', Float64, lambda m: m.data)
    rig.publisher('surface_speed_setpoint').publish(Float64(data=11.0))
    assert rig.spin_until(lambda: len(rig.data['surface_speed_command']) > 5, 10)
    assert all(c == 11.0 for c in rig.data['surface_speed_command'])
    assert st.fallbacks == 0 and st.in_fallback   # never had torque: waiting, not a fallback
    torque = rig.probe.create_publisher(Float64, 'surface/torque', 10)
    assert rig.spin_until(lambda: torque.publish(Float64(data=8000.0)) or not st.in_fallback,
                          10)
    assert rig.spin_until(lambda: st.in_fallback, 10)   # torque stops: a fallback
    assert st.fallbacks == 1
    assert all(c == 11.0 for c in rig.data['surface_speed_command'][-3:])


def test_soft_torque_in_the_loop_commands_the_twin(rig):
    node = twin(rig, real_time_factor=5.0)
    st = rig.add(SoftTorqueNode(context=rig.ctx))
    rig.listen('surface_speed_command', Float64, lambda m: m.data, qos=COMMAND_QOS)
    rig.publisher('surface_speed_setpoint').publish(Float64(data=12.57))
    assert rig.spin_until(lambda: len(rig.data['surface_speed_command']) > 50, 30)
    assert not st.in_fallback
    cmds = np.array(rig.data['surface_speed_command'])
    assert np.all(np.isfinite(cmds)) and np.all(cmds >= 0)
    assert node.arbiter.source == 'controller'   # the twin follows the controller
    assert math.isclose(np.median(cmds), 12.57, rel_tol=0.05)


@pytest.mark.slow
def test_stick_slip_at_the_benchmark_point_as_fast_as_possible_with_clock(rig):
    """Thesis §3.3 without Soft-Torque: stick-slip develops (offline: first stick ~178 s)."""
    from rosgraph_msgs.msg import Clock
    from std_msgs.msg import Bool
    node = twin(rig, as_fast_as_possible=True, publish_rate_hz=20.0)
    rig.listen('bit/stuck', Bool, lambda m: m.data)
    rig.listen('/clock', Clock, lambda m: m.clock.sec + 1e-9 * m.clock.nanosec, qos=10)
    assert rig.spin_until(lambda: any(rig.data['bit/stuck']), 120)
    assert 100.0 < node.twin.time_s < 300.0
    clock = rig.data['/clock']
    assert clock and all(b >= a for a, b in zip(clock, clock[1:]))
