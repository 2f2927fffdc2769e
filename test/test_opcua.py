"""The OPC UA server without ROS (issue 34): the policy classes, the security files, and
the asyncua server with a recording plant, driven by asyncua's own Client over loopback.

The server runs in its thread; the client in this test's event loop.  No sleeps as
synchronisation: every wait polls a condition against a deadline.
"""
import asyncio
import math
import socket
import time

import pytest

#: OPC UA servers and clients over loopback sockets: not the numerics make test-fast is for
pytestmark = pytest.mark.process

pytest.importorskip('asyncua')

from asyncua import Client, ua  # noqa: E402
from asyncua.ua.uaerrors import UaError, UaStatusCodeError  # noqa: E402

from drill_twin.errors import ParameterError  # noqa: E402
from drill_twin.opcua import security  # noqa: E402
from drill_twin.opcua.address_space import METHODS, NAMESPACE_URI, ROOT, unit_id, variables  # noqa: E402
from drill_twin.opcua.policy import BurstLog, ControlArbiter, check_write  # noqa: E402
from drill_twin.opcua.server import TwinServer  # noqa: E402


def free_port(host='127.0.0.1') -> int:
    with socket.socket() as s:
        s.bind((host, 0))
        return s.getsockname()[1]


class Plant:
    """Records what the server asks of the twin."""

    def __init__(self):
        self.sent, self.logs, self.control = [], [], []

    def setpoint(self, topic, value):
        self.sent.append((topic, value))

    async def call(self, service, argument=None):
        return True, f'{service} {argument}'

    def log(self, level, line):
        self.logs.append((level, line))

    def control_changed(self, function, client, reason):
        self.control.append((function, client, reason))


@pytest.fixture(scope='module')
def served():
    """A local (loopback) server with a recording plant; its URL."""
    plant = Plant()
    url = f'opc.tcp://127.0.0.1:{free_port()}/drill_twin/'
    server = TwinServer(url, plant, variables(), max_refresh_delay_s=0.2)
    server.start()
    yield server, plant, url
    server.stop()


def run(coro, timeout=60):
    return asyncio.run(asyncio.wait_for(coro, timeout))


async def until(condition, timeout_s, period_s=0.001):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if await condition():
            return True
        await asyncio.sleep(period_s)
    return False


async def resolve(client, names):
    """Node ids of browse paths (each a tuple of names below Objects) by
    TranslateBrowsePathsToNodeIds only."""
    idx = await client.get_namespace_index(NAMESPACE_URI)
    paths = []
    for path in names:
        elements = [ua.RelativePathElement(
            ReferenceTypeId=ua.NodeId(ua.ObjectIds.HierarchicalReferences),
            IsInverse=False, IncludeSubtypes=True,
            TargetName=ua.QualifiedName(name, 0 if name in ('EngineeringUnits', 'EURange')
                                        else idx)) for name in path]
        paths.append(ua.BrowsePath(StartingNode=ua.NodeId(ua.ObjectIds.ObjectsFolder),
                                   RelativePath=ua.RelativePath(Elements=elements)))
    results = await client.uaclient.translate_browsepaths_to_nodeids(paths)
    out = {}
    for path, result in zip(names, results):
        assert result.StatusCode.is_good(), (path, result.StatusCode)
        assert len(result.Targets) == 1, path
        out[path] = client.get_node(ua.NodeId(result.Targets[0].TargetId.Identifier,
                                                result.Targets[0].TargetId.NamespaceIndex))
    return out


# --- plain policy ------------------------------------------------------------------------
def test_writes_are_validated_like_setpoints():
    table = {v.key: v for v in variables(max_speed_rad_s=40.0)}
    speed = table['Rotation.Setpoint']
    assert check_write(speed, 'Double', 12.0) is None
    assert check_write(speed, 'Int32', 12) is None
    for value in (math.nan, math.inf, -math.inf, -1.0, 40.5, 1e308):
        assert check_write(speed, 'Double', value).status == 'BadOutOfRange'
    for kind, value in (('String', '12'), ('Boolean', True), ('ByteString', b'x'),
                        ('Null', None)):
        assert check_write(speed, kind, value).status == 'BadTypeMismatch'
    assert check_write(table['Rotation.Measured'], 'Double', 1.0).status == 'BadNotWritable'
    assert check_write(table['Rotation.Heartbeat'], 'Double', 1.0).status == 'BadTypeMismatch'
    assert check_write(table['Rotation.Heartbeat'], 'UInt32', 7) is None


def test_one_client_holds_a_function_and_its_silence_expires_once():
    arbiter = ControlArbiter(0.5)
    a, b = object(), object()
    assert arbiter.request('rotation', 'plc', a, 0.0)[0]
    granted, message = arbiter.request('rotation', 'other', b, 0.1)
    assert not granted and 'plc' in message
    assert arbiter.holds('rotation', a) and not arbiter.holds('rotation', b)
    arbiter.heartbeat('rotation', 0.4)
    assert arbiter.expired(0.85) == []
    assert arbiter.deadline() == pytest.approx(0.9)
    gone = arbiter.expired(0.95)
    assert [(f, c) for f, c, _ in gone] == [('rotation', 'plc')]
    assert arbiter.expired(2.0) == [] and not arbiter.granted('rotation')
    assert arbiter.request('rotation', 'other', b, 3.0)[0]
    assert arbiter.take_back('rotation') == 'other' and not arbiter.granted('rotation')


def test_rejections_are_logged_once_per_burst():
    log = BurstLog(1.0)
    lines = [log.add(t * 0.01, 'refused') for t in range(20)]
    assert lines[0] == 'refused' and lines[1:] == [None] * 19
    assert '19 more' in log.add(5.0, 'refused')


def test_units_are_unece_codes_and_every_variable_is_described():
    assert unit_id('C81') == 0x433831 and unit_id('2A') == 0x3241
    for var in variables():
        assert var.description
        if var.kind == 'Double':
            assert var.unit is not None, var.key
        if var.writable:
            assert var.low is not None and var.high is not None, var.key


def test_users_are_stored_as_salted_hashes(tmp_path):
    path = tmp_path / 'users.txt'
    security.add_user(path, 'driller', 'correct horse')
    security.add_user(path, 'plc', 'correct horse')
    text = path.read_text()
    assert 'correct horse' not in text
    users = security.load_users(path)
    assert users['driller'] != users['plc']             # salted
    assert security.verify_password('correct horse', users['driller'])
    assert not security.verify_password('wrong', users['driller'])
    with pytest.raises(ParameterError):
        security.add_user(path, 'bad name', 'correct horse')
    path.write_text('nonsense\n')
    with pytest.raises(ParameterError, match='users.txt:1'):
        security.load_users(path)


def test_only_the_loopback_address_is_local():
    assert security.is_local('opc.tcp://127.0.0.1:4840/drill_twin/')
    assert security.is_local('opc.tcp://localhost:4840/')
    assert not security.is_local('opc.tcp://127.0.0.2:4840/drill_twin/')
    assert not security.is_local('opc.tcp://0.0.0.0:4840/')
    with pytest.raises(ParameterError):
        security.is_local('http://127.0.0.1:4840/')


# --- the server over loopback ------------------------------------------------------------
def test_every_node_resolves_by_browse_path_with_units_and_ranges(served):
    server, _, url = served

    async def main():
        async with Client(url) as client:
            table = variables()
            nodes = await resolve(client, [v.path for v in table]
                                  + [(ROOT, m.name) for m in METHODS])
            units = await resolve(client, [v.path + ('EngineeringUnits',) for v in table
                                           if v.unit])
            ranges = await resolve(client, [v.path + ('EURange',) for v in table
                                            if v.unit and v.low is not None
                                            and v.high is not None])
            for var in table:
                description = await nodes[var.path].read_attribute(
                    ua.AttributeIds.Description)
                assert description.Value.Value.Text.startswith(var.description[:20])
                if var.unit:
                    eu = await units[var.path + ('EngineeringUnits',)].read_value()
                    assert eu.UnitId == unit_id(var.unit)
                    assert eu.NamespaceUri.endswith('un/cefact')
            rng = await ranges[(ROOT, 'Rotation', 'Setpoint', 'EURange')].read_value()
            assert (rng.Low, rng.High) == (0.0, 40.0)
            return len(nodes), len(units), len(ranges)
    counts = run(main())
    assert counts[0] == len(variables()) + len(METHODS)


def test_source_timestamps_are_the_twins_stamps(served):
    server, _, url = served
    stamp_ns = 1_234_567_890_120_000_000
    server.update({'Rotation.Measured': 3.25}, stamp_ns)

    async def main():
        async with Client(url) as client:
            node = (await resolve(client, [(ROOT, 'Rotation', 'Measured')]))[
                (ROOT, 'Rotation', 'Measured')]

            async def arrived():
                return (await node.read_value()) == 3.25
            assert await until(arrived, 5)
            return await node.read_data_value()
    dv = run(main())
    assert dv.SourceTimestamp.timestamp() == pytest.approx(stamp_ns / 1e9, abs=1e-6)


def _paths(*keys):
    return [(ROOT, *k.split('.')) for k in keys]


async def _write(node, value, kind):
    await node.write_value(ua.DataValue(ua.Variant(value, kind)))


def test_control_arbitration_hostile_writes_and_heartbeat_loss(served):
    server, plant, url = served
    keys = ('Rotation.Setpoint', 'Rotation.Heartbeat', 'Rotation.ControlGranted',
            'Rotation.Measured', 'Diagnostics.Level', 'Rotation.MaxRefreshDelay')

    async def main():
        async with Client(url) as client, Client(url) as other:
            n = {k: v for k, v in zip(keys, (await resolve(client, _paths(*keys))).values())}
            root = (await resolve(client, [(ROOT,)]))[(ROOT,)]
            idx = await client.get_namespace_index(NAMESPACE_URI)
            # without control: refused, nothing sent
            with pytest.raises(UaStatusCodeError, match='BadUserAccessDenied'):
                await _write(n['Rotation.Setpoint'], 10.0, ua.VariantType.Double)
            assert plant.sent == []
            granted, _ = await root.call_method(f'{idx}:RequestControl', 'rotation', 'test-pi')
            assert granted and await n['Rotation.ControlGranted'].read_value()
            # a second client cannot take it, nor write
            other_root = other.get_node(root.nodeid)
            granted, message = await other_root.call_method(f'{idx}:RequestControl',
                                                            'rotation', 'intruder')
            assert not granted and 'test-pi' in message
            with pytest.raises(UaStatusCodeError, match='BadUserAccessDenied'):
                await _write(other.get_node(n['Rotation.Setpoint'].nodeid), 5.0,
                             ua.VariantType.Double)
            await _write(n['Rotation.Setpoint'], 10.0, ua.VariantType.Double)
            assert plant.sent == [('surface_speed_setpoint', 10.0)]
            # 20 hostile writes: refused with the right code, the last valid value stays
            V = ua.VariantType
            hostile = [(math.nan, V.Double, 'BadOutOfRange'),
                       (math.inf, V.Double, 'BadOutOfRange'),
                       (-math.inf, V.Double, 'BadOutOfRange'),
                       (1e300, V.Double, 'BadOutOfRange'),
                       (-5.0, V.Double, 'BadOutOfRange'),
                       (41.0, V.Double, 'BadOutOfRange'),
                       (3.4e38, V.Float, 'BadOutOfRange'),
                       ('fast', V.String, 'BadTypeMismatch'),
                       ('12.0', V.String, 'BadTypeMismatch'),
                       (True, V.Boolean, 'BadTypeMismatch'),
                       (b'\x00' * 64, V.ByteString, 'BadTypeMismatch'),
                       (2 ** 63 - 1, V.Int64, 'BadOutOfRange'),
                       (-(2 ** 31), V.Int32, 'BadOutOfRange'),
                       ('x' * 10000, V.String, 'BadTypeMismatch'),
                       (ua.LocalizedText('ten'), V.LocalizedText, 'BadTypeMismatch'),
                       ]
            for value, kind, status in hostile:
                with pytest.raises(UaStatusCodeError, match=status):
                    await _write(n['Rotation.Setpoint'], value, kind)
            with pytest.raises(UaStatusCodeError, match='BadNotWritable'):   # wrong node
                await _write(n['Rotation.Measured'], 1.0, V.Double)
            with pytest.raises(UaStatusCodeError, match='BadTypeMismatch'):
                await _write(n['Rotation.Heartbeat'], 1.5, V.Double)
            with pytest.raises(UaStatusCodeError, match='BadOutOfRange'):
                await _write(n['Rotation.MaxRefreshDelay'], 0.0, V.Double)
            with pytest.raises(UaStatusCodeError, match='BadNodeIdUnknown'):
                await _write(client.get_node(ua.NodeId('DrillTwin.Nowhere', idx)), 1.0,
                             V.Double)
            with pytest.raises(UaStatusCodeError, match='BadInvalidArgument'):
                await root.call_method(f'{idx}:RequestControl', 'drilling', 'x')
            assert await n['Rotation.Setpoint'].read_value() == 10.0
            assert plant.sent == [('surface_speed_setpoint', 10.0)]
            warnings = [line for level, line in plant.logs if 'write refused' in line]
            assert 1 <= len(warnings) <= 3          # once per burst, not 20 times
            # heartbeat loss: safe state within MaxRefreshDelay + one tick (10 ms)
            for beat in range(5):
                await _write(n['Rotation.Heartbeat'], beat, V.UInt32)
            last = time.monotonic()

            async def lost():
                return not await n['Rotation.ControlGranted'].read_value()
            assert await until(lost, 2.0)
            after = time.monotonic() - last
            print(f'safe state {after * 1000:.1f} ms after the last heartbeat (MaxRefreshDelay '
                  '200 ms)')
            assert 0.2 <= after <= 0.2 + 0.010 + 0.010, after   # + client read latency
            assert await n['Diagnostics.Level'].read_value() == 1
            assert plant.sent == [('surface_speed_setpoint', 10.0)]  # speed held
            assert any('safe state' in line for _, line in plant.logs)
            with pytest.raises(UaStatusCodeError, match='BadUserAccessDenied'):
                await _write(n['Rotation.Setpoint'], 11.0, V.Double)
            return after
    run(main())


def test_a_torque_above_max_torque_is_reported(served):
    server, plant, url = served
    server.update({'Rotation.SurfaceTorque': 2.0e5}, None)

    async def main():
        async with Client(url) as client:
            nodes = await resolve(client, [(ROOT, 'Diagnostics', 'Message')])
            message = nodes[(ROOT, 'Diagnostics', 'Message')]

            async def said():
                return 'MaxTorque' in await message.read_value()
            assert await until(said, 5)
    run(main())


def test_an_operator_setpoint_on_ros_takes_control_back(served):
    server, plant, url = served

    async def main():
        async with Client(url) as client:
            idx = await client.get_namespace_index(NAMESPACE_URI)
            nodes = await resolve(client, [(ROOT,), (ROOT, 'Rotation', 'ControlGranted'),
                                           (ROOT, 'Rotation', 'Setpoint')])
            root = nodes[(ROOT,)]
            granted = nodes[(ROOT, 'Rotation', 'ControlGranted')]
            assert (await root.call_method(f'{idx}:RequestControl', 'rotation', 'pi'))[0]
            await _write(nodes[(ROOT, 'Rotation', 'Setpoint')], 9.0, ua.VariantType.Double)
            server.ros_setpoint('surface_speed_setpoint', 9.0)      # our own, echoed
            server.ros_setpoint('surface_speed_setpoint', 4.0)      # the operator's

            async def taken():
                return not await granted.read_value()
            assert await until(taken, 2.0)
            assert await nodes[(ROOT, 'Rotation', 'Setpoint')].read_value() == 4.0
            ok, message = await root.call_method(f'{idx}:Pause', True)
            assert ok and message == 'pause True'
            with pytest.raises(UaStatusCodeError, match='BadTypeMismatch'):
                await root.call_method(f'{idx}:Pause', 'yes')
    run(main())


# --- a secured endpoint (127.0.0.2 stands for a non-local address) -----------------------
@pytest.fixture(scope='module')
def secured(tmp_path_factory):
    base = tmp_path_factory.mktemp('opcua')
    server_dir, client_dir, stranger_dir = base / 'server', base / 'client', base / 'stranger'
    security.make_certificate(server_dir)
    client = security.make_certificate(client_dir)
    stranger = security.make_certificate(stranger_dir)
    security.trust_certificate(server_dir, client.cert)
    security.add_user(security.Paths(server_dir).users, 'driller', 'correct horse')
    plant = Plant()
    try:
        with socket.socket() as s:
            s.bind(('127.0.0.2', 0))
    except OSError:
        pytest.skip('127.0.0.2 is not available here')
    url = f'opc.tcp://127.0.0.2:{free_port("127.0.0.2")}/drill_twin/'
    server = TwinServer(url, plant, variables(), security_dir=server_dir)
    server.start()
    yield url, security.Paths(server_dir), client, stranger, plant
    server.stop()


async def _secure_client(url, server_paths, client_paths, user=None, password=None):
    client = Client(url)
    client.application_uri = security.APPLICATION_URI
    if user is not None:
        client.set_user(user)
        client.set_password(password)
    await client.set_security_string(
        f'Basic256Sha256,SignAndEncrypt,{client_paths.cert},{client_paths.key},'
        f'{server_paths.cert}')
    return client


def test_a_secured_endpoint_refuses_strangers_wrong_passwords_and_anonymous_writes(secured):
    url, server_paths, client_paths, stranger_paths, plant = secured

    async def main():
        # no security at all: not offered
        refused = (UaError, OSError, asyncio.TimeoutError)
        with pytest.raises(refused):
            async with Client(url, timeout=5) as c:
                await c.get_namespace_index(NAMESPACE_URI)
        # an untrusted certificate
        stranger = await _secure_client(url, server_paths, stranger_paths, 'driller',
                                        'correct horse')
        with pytest.raises(refused):
            async with stranger:
                pass
        # a wrong password
        wrong = await _secure_client(url, server_paths, client_paths, 'driller', 'wrong')
        with pytest.raises(UaStatusCodeError, match='BadUserAccessDenied|BadIdentityToken'):
            async with wrong:
                pass
        # anonymous: may read, not write or call
        anonymous = await _secure_client(url, server_paths, client_paths)
        async with anonymous as c:
            idx = await c.get_namespace_index(NAMESPACE_URI)
            nodes = await resolve(c, [(ROOT,), (ROOT, 'Rotation', 'Setpoint')])
            assert await nodes[(ROOT, 'Rotation', 'Setpoint')].read_value() == 0.0
            with pytest.raises(UaStatusCodeError, match='BadUserAccessDenied'):
                await _write(nodes[(ROOT, 'Rotation', 'Setpoint')], 5.0, ua.VariantType.Double)
            with pytest.raises(UaStatusCodeError, match='BadUserAccessDenied'):
                await nodes[(ROOT,)].call_method(f'{idx}:RequestControl', 'rotation', 'anon')
        # the right user: takes control and writes
        user = await _secure_client(url, server_paths, client_paths, 'driller',
                                    'correct horse')
        async with user as c:
            idx = await c.get_namespace_index(NAMESPACE_URI)
            nodes = await resolve(c, [(ROOT,), (ROOT, 'Rotation', 'Setpoint')])
            with pytest.raises(UaStatusCodeError, match='BadUserAccessDenied'):
                await _write(nodes[(ROOT, 'Rotation', 'Setpoint')], 5.0, ua.VariantType.Double)
            assert (await nodes[(ROOT,)].call_method(f'{idx}:RequestControl', 'rotation',
                                                     'driller'))[0]
            await _write(nodes[(ROOT, 'Rotation', 'Setpoint')], 5.0, ua.VariantType.Double)
        assert plant.sent == [('surface_speed_setpoint', 5.0)]
    run(main(), timeout=120)


def test_a_secured_endpoint_without_certificate_is_one_line(tmp_path):
    server = TwinServer('opc.tcp://127.0.0.2:4999/drill_twin/', Plant(), variables(),
                        security_dir=tmp_path)
    with pytest.raises(ParameterError, match='drill-twin opcua cert'):
        server.start()
