"""One PI speed controller closing the loop on a fresh twin through the OPC UA bridge and
over the twin's ROS topics (issue 34): the same plant, the same response.

Its own module: the OPC UA module's twin (a module fixture) must not share the ROS domain
with these twins (two twins and a latched set-point from the other bridge would mix).
No sleeps as synchronisation: every wait polls a condition against a deadline.
"""
import asyncio
import time

import pytest

pytestmark = pytest.mark.process

pytest.importorskip('asyncua')
pytest.importorskip('rclpy')

from asyncua import Client, ua  # noqa: E402
from test_opcua_ros import (  # noqa: E402
    BIN,
    BRIDGE,
    _nodes,
    _Samples,
    _start,
    _stop,
    _wait_listening,
    free_port,
)


def _pi_step(reference, kp, ki):
    """The test's PI speed controller: each new measured speed y [rad/s] (10 ms samples)
    gives the next set-point [rad/s]."""
    state = {'integral': 0.0}

    def step(y):
        error = reference - y
        state['integral'] += error * 0.01
        return min(max(reference + kp * error + ki * state['integral'], 0.0), 40.0)
    return step


def _loop_over_opcua(url, controller, seconds):
    """Close the loop through the bridge; the measured speed against the time since the
    first write [(s, rad/s)]."""
    async def main():
        async with Client(url, timeout=10) as client:
            idx, (root, measured, setpoint, beat) = await _nodes(
                client, '', 'Rotation.Measured', 'Rotation.Setpoint', 'Rotation.Heartbeat')
            deadline = time.monotonic() + 30
            while (await measured.read_value()) == 0.0 and time.monotonic() < deadline:
                await asyncio.sleep(0.01)
            # before anyone writes, the set-point reads what the twin runs at: the
            # configuration's 12.57 rad/s (rig_fem), not 0
            assert await setpoint.read_value() == pytest.approx(12.57)
            ok, message = await root.call_method(f'{idx}:RequestControl', 'rotation', 'pi')
            assert ok, message
            samples = _Samples()
            sub = await client.create_subscription(10, samples)
            await sub.subscribe_data_change(measured)
            seen, count, start, out = 0, 0, None, []
            while start is None or time.monotonic() - start < seconds:
                if len(samples.values) > seen:
                    # every sample steps the controller (its integral advances 10 ms each),
                    # however many arrived since the last pass; the last command is sent
                    for t, y, _ in samples.values[seen:]:
                        start = t if start is None else start
                        out.append((t - start, y))
                        u = controller(y)
                    seen = len(samples.values)
                    await setpoint.write_value(ua.DataValue(ua.Variant(u,
                                                                       ua.VariantType.Double)))
                    count += 1
                    await beat.write_value(ua.DataValue(ua.Variant(count % 2 ** 32,
                                                                   ua.VariantType.UInt32)))
                await asyncio.sleep(0.002)
            await root.call_method(f'{idx}:ReleaseControl', 'rotation')
            await sub.delete()
            return out
    return asyncio.run(asyncio.wait_for(main(), 120))


def _loop_over_ros(controller, seconds):
    """The same loop over the twin's own topics (surface/top_drive_speed in,
    surface_speed_setpoint out) from a node in this process."""
    from rclpy.qos import qos_profile_sensor_data
    from ros_rig import Rig
    from std_msgs.msg import Float64
    rig = Rig()
    try:
        rig.listen('surface/top_drive_speed', Float64,
                   lambda m: (time.monotonic(), m.data), qos_profile_sensor_data)
        pub = rig.publisher('surface_speed_setpoint')
        samples = rig.data['surface/top_drive_speed']
        assert rig.spin_until(lambda: samples and samples[-1][1] != 0.0, 30)
        seen, start, out = len(samples), None, []
        while start is None or time.monotonic() - start < seconds:
            rig.ex.spin_once(timeout_sec=0.002)
            if len(samples) > seen:
                for t, y in samples[seen:]:         # as over OPC UA: every sample steps it
                    start = t if start is None else start
                    out.append((t - start, y))
                    u = controller(y)
                seen = len(samples)
                pub.publish(Float64(data=u))
        return out
    finally:
        rig.close()


def _twin_process():
    return _start([str(BIN / 'twin_node')], 'record_path:=none', 'stability_period_s:=0.0',
                  'real_time_factor:=1.0')


def test_the_same_pi_loop_responds_the_same_over_opcua_and_over_ros():
    """One PI speed controller (written here) closes the loop on a fresh twin twice: through
    the OPC UA bridge and over the twin's ROS topics.  The plant is the same and both loops
    sample at the twin's 10 ms; what differs is the transport's latency and the wall-clock
    jitter of two real-time runs: the step's half-way crossing within 5 samples (50 ms) and
    the last second's mean speed within 0.05 rad/s (1 % of the 4.57 rad/s step)."""
    reference, kp, ki, seconds = 8.0, 0.5, 2.0, 5.0
    runs = {}
    for transport in ('opcua', 'ros'):
        twin = _twin_process()
        bridge = None
        try:
            if transport == 'opcua':
                port = free_port()
                url = f'opc.tcp://127.0.0.1:{port}/drill_twin/'
                bridge = _start(BRIDGE, f'endpoint:={url}', 'max_refresh_delay_s:=1.0')
                _wait_listening(bridge, port)
                runs[transport] = _loop_over_opcua(url, _pi_step(reference, kp, ki), seconds)
            else:
                runs[transport] = _loop_over_ros(_pi_step(reference, kp, ki), seconds)
        finally:
            if bridge is not None:
                _stop(bridge)
            _stop(twin)
    summary = {}
    for transport, samples in runs.items():
        t, y = (list(v) for v in zip(*samples))
        start = y[0]
        half = 0.5 * (start + reference)
        crossing = next(tt for tt, yy in zip(t, y) if yy <= half)
        last = [yy for tt, yy in zip(t, y) if tt >= t[-1] - 1.0]
        summary[transport] = (crossing, sum(last) / len(last), len(y) / t[-1])
    print('closed loop (half-way crossing s, last-second mean rad/s, sample rate Hz):',
          summary)
    (c_opc, m_opc, rate_opc), (c_ros, m_ros, rate_ros) = summary['opcua'], summary['ros']
    assert rate_opc > 50 and rate_ros > 50
    assert abs(c_opc - c_ros) < 0.05
    assert abs(m_opc - m_ros) < 0.05
