"""The OPC UA bridge beside a running twin (issue 34): processes over DDS (the session's
own ROS domain, test/conftest.py) and asyncua's Client over loopback.

No sleeps as synchronisation: every wait polls a condition against a deadline.
"""
import asyncio
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

#: the twin and the bridge run as processes: not the numerics make test-fast is for
pytestmark = pytest.mark.process

pytest.importorskip('asyncua')
pytest.importorskip('rclpy')

from asyncua import Client, ua  # noqa: E402

from drill_twin.opcua.address_space import NAMESPACE_URI, ROOT  # noqa: E402

BIN = Path(sys.executable).parent
BRIDGE = [sys.executable, '-c', 'from drill_twin.ros.entry import opcua_bridge; '
          'raise SystemExit(opcua_bridge())']


def free_port() -> int:
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def _start(args, *params):
    cmd = list(args) + ['--ros-args'] + [x for p in params for x in ('-p', p)]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _listening(port) -> bool:
    with socket.socket() as s:
        s.settimeout(0.2)
        return s.connect_ex(('127.0.0.1', port)) == 0


def _wait_listening(proc, port, timeout_s=90.0):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            pytest.fail(f'bridge exited {proc.returncode}: {proc.stdout.read()}')
        if _listening(port):
            return
        time.sleep(0.05)   # polling a condition against a deadline
    pytest.fail('bridge did not listen in time')


def _stop(proc):
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


@pytest.fixture(scope='module')
def plant():
    """A twin at real time (100 Hz) and the bridge on a free loopback port."""
    twin = _start([str(BIN / 'twin_node')], 'record_path:=none', 'stability_period_s:=0.0',
                  'real_time_factor:=1.0')
    port = free_port()
    url = f'opc.tcp://127.0.0.1:{port}/drill_twin/'
    bridge = _start(BRIDGE, f'endpoint:={url}', 'max_refresh_delay_s:=1.0')
    try:
        _wait_listening(bridge, port)
        yield url
    finally:
        _stop(bridge)
        _stop(twin)


async def _nodes(client, *keys):
    idx = await client.get_namespace_index(NAMESPACE_URI)
    paths = []
    for key in keys:
        names = [ROOT] + ([] if key == '' else key.split('.'))
        paths.append(ua.BrowsePath(
            StartingNode=ua.NodeId(ua.ObjectIds.ObjectsFolder),
            RelativePath=ua.RelativePath(Elements=[ua.RelativePathElement(
                ReferenceTypeId=ua.NodeId(ua.ObjectIds.HierarchicalReferences),
                IsInverse=False, IncludeSubtypes=True, TargetName=ua.QualifiedName(n, idx))
                for n in names])))
    results = await client.uaclient.translate_browsepaths_to_nodeids(paths)
    out = []
    for result in results:
        assert result.StatusCode.is_good()
        t = result.Targets[0].TargetId
        out.append(client.get_node(ua.NodeId(t.Identifier, t.NamespaceIndex)))
    return idx, out


class _Samples:
    def __init__(self):
        self.values = []

    def datachange_notification(self, node, value, data):
        self.values.append((time.monotonic(), value,
                            data.monitored_item.Value.SourceTimestamp))


def test_a_pi_speed_controller_closes_the_loop_through_opcua(plant):
    """A PI controller in the test reads Rotation.Measured (subscribed at 10 ms) and writes
    Rotation.Setpoint and the heartbeat; the top drive settles on the reference."""
    reference, kp, ki = 8.0, 0.5, 2.0

    async def main():
        async with Client(plant, timeout=10) as client:
            idx, (root, measured, setpoint, beat, granted, level) = await _nodes(
                client, '', 'Rotation.Measured', 'Rotation.Setpoint', 'Rotation.Heartbeat',
                'Rotation.ControlGranted', 'Diagnostics.Level')
            deadline = time.monotonic() + 30
            while (await measured.read_value()) == 0.0 and time.monotonic() < deadline:
                await asyncio.sleep(0.01)
            ok, message = await root.call_method(f'{idx}:RequestControl', 'rotation', 'pi')
            assert ok, message
            samples = _Samples()
            sub = await client.create_subscription(10, samples)
            await sub.subscribe_data_change(measured)
            integral, count, start = 0.0, 0, time.monotonic()
            u = await setpoint.read_value()
            seen = 0
            while time.monotonic() - start < 6.0:
                if len(samples.values) > seen:
                    seen = len(samples.values)
                    y = samples.values[-1][1]
                    error = reference - y
                    integral += error * 0.01
                    u = min(max(reference + kp * error + ki * integral, 0.0), 40.0)
                    await setpoint.write_value(ua.DataValue(ua.Variant(u, ua.VariantType.Double)))
                    count += 1
                    await beat.write_value(ua.DataValue(ua.Variant(count % 2 ** 32,
                                                                   ua.VariantType.UInt32)))
                await asyncio.sleep(0.002)
            assert await granted.read_value()
            await root.call_method(f'{idx}:ReleaseControl', 'rotation')
            await sub.delete()
            return samples.values, count
    values, writes = asyncio.run(asyncio.wait_for(main(), 120))
    last = [v for t, v, _ in values if t >= values[-1][0] - 1.0]
    mean = sum(last) / len(last)
    assert abs(mean - reference) < 0.1, mean
    # the twin's stamps as source timestamps: increasing, 10 ms apart (simulated time)
    stamps = [s.timestamp() for _, _, s in values]
    assert all(b > a for a, b in zip(stamps, stamps[1:]))
    span = stamps[-1] - stamps[0]
    rate = len(values) / span
    print(f'PI over OPC UA: {writes} writes, {len(values)} samples in {span:.2f} s '
          f'({rate:.0f} Hz), mean speed over the last second {mean:.4f} rad/s')
    assert rate > 50


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
            ok, message = await root.call_method(f'{idx}:RequestControl', 'rotation', 'pi')
            assert ok, message
            samples = _Samples()
            sub = await client.create_subscription(10, samples)
            await sub.subscribe_data_change(measured)
            seen, count, start, out = 0, 0, None, []
            while start is None or time.monotonic() - start < seconds:
                if len(samples.values) > seen:
                    seen = len(samples.values)
                    t, y, _ = samples.values[-1]
                    start = t if start is None else start
                    out.append((t - start, y))
                    await setpoint.write_value(ua.DataValue(ua.Variant(controller(y),
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
                seen = len(samples)
                t, y = samples[-1]
                start = t if start is None else start
                out.append((t - start, y))
                pub.publish(Float64(data=controller(y)))
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


def test_sigterm_ends_the_bridge_within_a_second():
    port = free_port()
    proc = _start(BRIDGE, f'endpoint:=opc.tcp://127.0.0.1:{port}/drill_twin/')
    try:
        _wait_listening(proc, port)
        start = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        code = proc.wait(10)
        elapsed = time.monotonic() - start
    finally:
        _stop(proc)
    output = proc.stdout.read()
    assert code == 0, output
    assert 'Traceback' not in output
    print(f'bridge ended {elapsed * 1000:.0f} ms after SIGTERM')
    assert elapsed < 1.0


@pytest.mark.parametrize('param, message', [
    ('endpoint:=http://nowhere', 'expected opc.tcp://'),
    ('endpoint:=opc.tcp://127.0.0.3:4840/x/', 'drill-twin opcua cert'),
    ('max_refresh_delay_s:=0.0', 'max_refresh_delay_s'),
])
def test_bad_bridge_parameters_give_one_line_and_exit_2(param, message, tmp_path):
    env = dict(os.environ, ROS_HOME=str(tmp_path))
    proc = subprocess.run(BRIDGE + ['--ros-args', '-p', param], capture_output=True,
                          text=True, timeout=120, env=env)
    assert proc.returncode == 2, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if 'error' in line]
    assert len(lines) == 1 and message in lines[0], proc.stderr
    assert 'Traceback' not in proc.stderr
