"""The twin as a ROS engineer drives a simulator: reset and pause services, the
ros2_control vocabulary (joint_states, forward-command-style commands), stamped surface
measurements.  Over DDS, in-process; spin until a condition or a deadline."""
import math

import pytest

rclpy = pytest.importorskip('rclpy')
from geometry_msgs.msg import TwistStamped, WrenchStamped  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64, Float64MultiArray  # noqa: E402
from std_srvs.srv import SetBool, Trigger  # noqa: E402

from drill_twin import topics as T  # noqa: E402
from drill_twin.io.mcap_reader import open_recording  # noqa: E402
from drill_twin.ros.twin_node import SETPOINT_QOS  # noqa: E402


def test_reset_returns_to_the_configured_initial_state(rig):
    node = rig.twin()
    initial = node.twin.measurements()
    rig.publisher('surface_speed_setpoint').publish(Float64(data=15.0))
    assert rig.spin_until(lambda: node.twin.time_s > 1.0
                          and node.twin.surface_speed_setpoint == 15.0, 30)
    # paused, so that no tick runs between the reset and the look at the new twin
    assert rig.call(SetBool, '/drill_twin/pause', SetBool.Request(data=True)).success
    result = rig.call(Trigger, '/drill_twin/reset', Trigger.Request())
    assert result.success, result.message
    after = node.twin.measurements()
    assert after.keys() == initial.keys()
    for key, value in initial.items():
        assert after[key] == value or (isinstance(value, float) and math.isnan(value)
                                       and math.isnan(after[key])), key
    assert rig.call(SetBool, '/drill_twin/pause', SetBool.Request(data=False)).success
    assert rig.spin_until(lambda: node.twin.time_s > 0.2, 30)   # and runs on from there


def test_reset_is_refused_while_recording(rig, tmp_path):
    node = rig.twin(record_path=str(tmp_path / 'run.mcap'))
    assert rig.spin_until(lambda: node.twin.time_s > 0.2, 30)
    result = rig.call(Trigger, '/drill_twin/reset', Trigger.Request())
    assert not result.success and 'recording' in result.message
    assert node.twin.time_s > 0.2


def test_pause_holds_simulated_time_and_resume_continues(rig):
    node = rig.twin()
    assert rig.spin_until(lambda: node.twin.time_s > 0.3, 30)
    assert rig.call(SetBool, '/drill_twin/pause', SetBool.Request(data=True)).success
    held = node.twin.time_s
    rig.listen('surface/torque', Float64, lambda m: m.data)
    # spin to a deadline: 50 publish periods pass on the wall clock, nothing may happen
    assert not rig.spin_until(lambda: node.twin.time_s != held, 0.5)
    assert rig.data['surface/torque'] == []
    assert rig.call(SetBool, '/drill_twin/pause', SetBool.Request(data=False)).success
    assert rig.spin_until(lambda: node.twin.time_s > held + 0.2, 30)
    # resumed from where it held: no jump of simulated time
    assert rig.spin_until(lambda: len(rig.data['surface/torque']) > 0, 10)


def test_joint_states_equal_the_measurement_topics(rig):
    rig.twin()
    stamp = lambda m: (m.header.stamp.sec, m.header.stamp.nanosec)  # noqa: E731
    rig.listen('joint_states', JointState, lambda m: (stamp(m), m))
    rig.listen('bit/wrench', WrenchStamped, lambda m: (stamp(m), m))
    rig.listen('bit/velocity', TwistStamped, lambda m: (stamp(m), m))
    rig.listen('surface/wrench', WrenchStamped, lambda m: (stamp(m), m))
    rig.listen('surface/twist', TwistStamped, lambda m: (stamp(m), m))

    def matched():
        tables = [dict(rig.data[t]) for t in ('bit/wrench', 'bit/velocity', 'surface/wrench',
                                              'surface/twist')]
        return [(js, *[tb[st] for tb in tables]) for st, js in rig.data['joint_states']
                if all(st in tb for tb in tables)]
    assert rig.spin_until(lambda: len(matched()) >= 20, 30)
    for js, bw, bv, sw, st in matched():
        assert list(js.name) == list(T.JOINTS)
        assert list(js.velocity) == [st.twist.angular.x, bv.twist.angular.x,
                                     st.twist.linear.x, bv.twist.linear.x]
        assert list(js.effort) == [sw.wrench.torque.x, bw.wrench.torque.x, sw.wrench.force.x,
                                   bw.wrench.force.x]
        assert all(math.isfinite(p) for p in js.position)


def test_forward_command_style_commands_set_the_speed(rig):
    node = rig.twin()
    pub = rig.probe.create_publisher(Float64MultiArray, T.COMMANDS_TOPIC, SETPOINT_QOS)
    pub.publish(Float64MultiArray(data=[14.0]))
    assert rig.spin_until(lambda: node.twin.surface_speed_setpoint == 14.0, 10)
    pub.publish(Float64MultiArray(data=[1.0, 2.0, 3.0]))   # wrong length: rejected, kept
    pub.publish(Float64MultiArray(data=[float('nan')]))   # not finite: rejected, kept
    assert not rig.spin_until(lambda: node.twin.surface_speed_setpoint != 14.0, 0.5)


def test_stamped_bit_scalars_equal_the_float64_topics_of_the_same_tick(rig, tmp_path):
    """Every measurement has a stamped form: the recording (one log time per tick) holds
    bit/penetration and bit/stick_slip beside the Float64 / Bool topics they restate."""
    path = tmp_path / 'run.mcap'
    node = rig.twin(record_path=str(path))
    rig.publisher('surface_speed_setpoint').publish(Float64(data=4.0))  # slow: sticks
    assert rig.spin_until(lambda: node.twin.time_s > 15.0, 60)
    rig.nodes.remove(node)
    rig.ex.remove_node(node)
    node.destroy_node()
    ticks = {}
    for topic, t, msg in open_recording(path).decoded():
        ticks.setdefault(t, {})[topic] = msg
    compared = 0
    for tick in ticks.values():
        if '/bit/penetration' not in tick:
            continue
        pen, ss = tick['/bit/penetration'], tick['/bit/stick_slip']
        assert pen.header.frame_id == ss.header.frame_id == 'bit'
        assert (pen.vector.x, pen.vector.y, pen.vector.z) == (
            tick['/bit/depth_of_cut'].data, tick['/bit/height_above_bottom'].data,
            tick['/bit/rate_of_penetration'].data)
        assert (ss.vector.x, ss.vector.y) == (tick['/bit/stick_slip_severity'].data,
                                              float(tick['/bit/stuck'].data))
        stamps = [(m.header.stamp.sec, m.header.stamp.nanosec)
                  for m in (pen, ss, tick['/bit/velocity'])]
        assert stamps[0] == stamps[1] == stamps[2]
        compared += 1
    assert compared > 100
    assert any(t['/bit/stick_slip'].vector.y == 1.0 for t in ticks.values()
               if '/bit/stick_slip' in t)   # the stuck flag is carried
