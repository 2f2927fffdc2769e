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
