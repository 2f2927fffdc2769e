"""The twin's OPC UA server on asyncua, in a thread of its own (no ROS).

:class:`TwinServer` builds the address space of :mod:`drill_twin.opcua.address_space`
under ``Objects/DrillTwin``, serves it on one endpoint, and talks to the twin through a
*plant* (the ROS bridge, :mod:`drill_twin.ros.opcua_bridge`), which must offer::

    plant.setpoint(topic, value)        # publish a set-point (called from the server thread)
    await plant.call(service, argument)  # a twin service -> (success, message)
    plant.log(level, line)               # 'info' | 'warning' | 'error'
    plant.control_changed(function, client, reason)   # control / safe state, for ROS

and which feeds it with :meth:`TwinServer.update` (measurements with the twin's stamps),
:meth:`TwinServer.ros_setpoint` (set-points seen on ROS) and
:meth:`TwinServer.twin_health` (the twin's /diagnostics), from any thread.

Security (docs/opcua.md): on the loopback endpoint (127.0.0.1, localhost, ::1) there is no
message security and an anonymous client may take control and write; on any other
endpoint only ``Basic256Sha256`` ``SignAndEncrypt`` with a trusted client certificate is
offered, users log in with a password checked against salted hashes, and anonymous
sessions may browse, read and subscribe but not write or call methods.
"""
from __future__ import annotations

import asyncio
import contextvars
import math
import threading
import time
from collections import deque
from datetime import UTC, datetime

from asyncua import Server, ua
from asyncua.crypto.permission_rules import USER_TYPES, PermissionRuleset, User, UserRole
from asyncua.server.internal_server import InternalServer
from asyncua.server.internal_session import InternalSession

from ..errors import ParameterError
from . import security
from .address_space import FUNCTIONS, METHODS, NAMESPACE_URI, ROOT, UNITS, Variable, unit_id
from .policy import SAFE_STATE, BurstLog, ControlArbiter, check_write

__all__ = ['TwinServer', 'UNITS_NAMESPACE']

#: EUInformation.NamespaceUri of UNECE codes (OPC UA Part 8)
UNITS_NAMESPACE = 'http://www.opcfoundation.org/UA/units/un/cefact'
#: the session of the request being served (set around write and call)
_SESSION = contextvars.ContextVar('drill_twin_opcua_session', default=None)
#: how long an event of the bridge keeps Diagnostics at WARN [s]
EVENT_WINDOW_S = 10.0
_VARIANT = {'Double': ua.VariantType.Double, 'Boolean': ua.VariantType.Boolean,
            'UInt32': ua.VariantType.UInt32, 'Int32': ua.VariantType.Int32,
            'String': ua.VariantType.String}
_NO_WRITE = {ua.ObjectIds.WriteRequest_Encoding_DefaultBinary,
             ua.ObjectIds.CallRequest_Encoding_DefaultBinary}


class _Session(InternalSession):
    """A session that makes itself known to the write and method handlers."""

    async def write(self, params):
        token = _SESSION.set(self)
        try:
            return await super().write(params)
        finally:
            _SESSION.reset(token)

    async def call(self, params):
        token = _SESSION.set(self)
        try:
            return await super().call(params)
        finally:
            _SESSION.reset(token)


class _InternalServer(InternalServer):
    def create_session(self, name, user=None, external=False):
        user = User(role=UserRole.Anonymous) if user is None else user
        return _Session(self, self.aspace, self.subscription_service, name, user=user,
                        external=external)


class _Rules(PermissionRuleset):
    """Users (and, on the loopback endpoint, anonymous sessions) may do what asyncua's
    users may; anonymous sessions on a secured endpoint may not write or call methods."""

    def __init__(self):
        user = {ua.NodeId(i) for i in USER_TYPES}
        self._allowed = {UserRole.Admin: user, UserRole.User: user,
                         UserRole.Anonymous: {i for i in user
                                              if i.Identifier not in _NO_WRITE}}

    def check_validity(self, user, action_type_id, body):
        return action_type_id in self._allowed[user.role]


class _Users:
    """Anonymous: a local writer on the loopback endpoint, a reader elsewhere; a named user:
    the password must match its salted hash."""

    def __init__(self, users: dict, local: bool, log):
        self.users, self.local, self.log = users, local, log

    def get_user(self, iserver, username=None, password=None, certificate=None):
        if username is None:
            return User(role=UserRole.User if self.local else UserRole.Anonymous,
                        name='anonymous')
        if isinstance(password, bytes):
            password = password.decode('utf-8', errors='replace')
        stored = self.users.get(username)
        if stored is not None and security.verify_password(password or '', stored):
            return User(role=UserRole.User, name=username)
        self.log('warning', f'OPC UA login refused for user {username!r}: unknown user or '
                 'wrong password')
        return None


def _stamp(ns: int | None) -> datetime:
    if ns is None:
        return datetime.now(UTC)
    return datetime.fromtimestamp(ns / 1e9, tz=UTC)


class TwinServer:
    """The OPC UA server (see module docstring).

    Parameters
    ----------
    endpoint : str
        ``opc.tcp://HOST:PORT/PATH``.
    plant : object
        The twin's side (see module docstring).
    table : tuple of Variable
        :func:`drill_twin.opcua.address_space.variables` of the twin's configuration.
    security_dir : str or Path, optional
        Certificates, trusted clients and users (:mod:`drill_twin.opcua.security`);
        needed on a non-loopback endpoint.
    max_refresh_delay_s : float
        Initial ``MaxRefreshDelay`` [s].
    has_block : bool
        Hoisting's safe state sets the block velocity to 0 (hoist tops only).
    """

    def __init__(self, endpoint: str, plant, table: tuple, security_dir=None,
                 max_refresh_delay_s: float = 0.5, has_block: bool = False):
        self.endpoint = endpoint
        self.local = security.is_local(endpoint)
        self.plant = plant
        self.table = tuple(table)
        self.by_key = {v.key: v for v in self.table}
        self.paths = security.Paths(security_dir)
        self.arbiter = ControlArbiter(max_refresh_delay_s)
        self.has_block = has_block
        self.rejections = BurstLog(1.0)
        self._torque_log = BurstLog(1.0)
        self.rejected = 0
        self.safe_states = 0
        self._values = {v.key: v.initial for v in self.table}
        self._values.update({f'{f.title()}.MaxRefreshDelay': float(max_refresh_delay_s)
                             for f in FUNCTIONS})
        self._published = {v.ros: deque(maxlen=32) for v in self.table if v.writable}
        self._twin_health = (0, '')
        self._events = deque(maxlen=50)      # (monotonic time, level, message)
        self._last_stamp_ns = None
        self._loop = None
        self._thread = None
        self._started = threading.Event()
        self._failure = None
        self._stopping = None
        self.server = None

    # --- life cycle (any thread) ------------------------------------------------------
    def start(self, timeout_s: float = 20.0):
        """Start serving; raises OSError / ParameterError with one line if it cannot."""
        if not self.local:
            self._check_security_files()
        self._thread = threading.Thread(target=self._run, name='opcua_server', daemon=True)
        self._thread.start()
        if not self._started.wait(timeout_s):
            raise OSError(f'OPC UA server on {self.endpoint} did not start within '
                          f'{timeout_s:g} s')
        if self._failure is not None:
            raise self._failure

    def stop(self, timeout_s: float = 0.5):
        """Stop serving (sessions are closed); returns within about ``timeout_s``."""
        loop = self._loop
        if loop is None or not loop.is_running() or self._stopping is None:
            return
        loop.call_soon_threadsafe(self._stopping.set)
        self._thread.join(timeout_s)

    def _check_security_files(self):
        missing = [p for p in (self.paths.key, self.paths.cert) if not p.is_file()]
        if missing:
            raise ParameterError(
                f'endpoint {self.endpoint} is not loopback: it needs the server certificate '
                f'({", ".join(str(p) for p in missing)} missing): run drill-twin opcua cert '
                f'--dir {self.paths.dir}')
        self._users = security.load_users(self.paths.users)

    def _run(self):
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._main())
        except Exception as exc:  # noqa: BLE001 - reported by start() in one line
            if not self._started.is_set():
                self._failure = exc if isinstance(exc, (OSError, ParameterError)) else OSError(
                    f'OPC UA server on {self.endpoint} failed to start: {exc}')
                self._started.set()
            else:
                self.plant.log('error', f'OPC UA server stopped: {exc!r}')
        finally:
            loop.close()

    async def _main(self):
        self._stopping = asyncio.Event()
        await self._build()
        try:
            await self.server.start()
        except OSError as exc:
            host, port = security.parse_endpoint(self.endpoint)
            raise OSError(f'cannot listen on {host}:{port} ({exc.strerror or exc}): another '
                          'server there? (parameter endpoint)') from None
        self._started.set()
        try:
            await self._watch()
        finally:
            try:
                await asyncio.wait_for(self.server.stop(), 0.3)
            except (TimeoutError, Exception):  # noqa: BLE001 - leaving anyway
                pass

    async def _watch(self):
        """The heartbeat watchdog: checks at every deadline (at least every 5 ms)."""
        while not self._stopping.is_set():
            now = time.monotonic()
            for function, client, silence in self.arbiter.expired(now):
                await self._safe_state(function, client, silence)
            deadline = self.arbiter.deadline()
            wait = 0.005 if deadline is None else min(0.005, max(deadline - now, 0.0) + 1e-4)
            try:
                await asyncio.wait_for(self._stopping.wait(), wait)
            except TimeoutError:
                pass

    # --- the address space ---------------------------------------------------------------
    async def _build(self):
        iserver = _InternalServer(user_manager=_Users(
            getattr(self, '_users', {}), self.local, self.plant.log))
        server = Server(iserver=iserver)
        await server.init()
        server.set_endpoint(self.endpoint)
        server.set_server_name('drill_twin')
        await server.set_application_uri(security.APPLICATION_URI)
        if self.local:
            server.set_security_policy([ua.SecurityPolicyType.NoSecurity],
                                       permission_ruleset=_Rules())
            server.set_identity_tokens([ua.AnonymousIdentityToken])
        else:
            from asyncua.crypto.truststore import TrustStore
            from asyncua.crypto.validator import CertificateValidator, CertificateValidatorOptions
            await server.load_certificate(str(self.paths.cert))
            await server.load_private_key(str(self.paths.key))
            server.set_security_policy([ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt],
                                       permission_ruleset=_Rules())
            server.set_identity_tokens([ua.AnonymousIdentityToken, ua.UserNameIdentityToken])
            store = TrustStore([self.paths.trusted], [])
            await store.load()
            server.set_certificate_validator(CertificateValidator(
                CertificateValidatorOptions.TRUSTED_VALIDATION
                | CertificateValidatorOptions.PEER_CLIENT, store))
        self.idx = idx = await server.register_namespace(NAMESPACE_URI)
        root = await server.nodes.objects.add_object(ua.NodeId(ROOT, idx),
                                                     ua.QualifiedName(ROOT, idx))
        await root.write_attribute(ua.AttributeIds.Description, ua.DataValue(ua.Variant(
            ua.LocalizedText('drill_twin: the digital twin of a drill string (docs/opcua.md)'))))
        folders = {}
        self.nodeid, self.by_nodeid = {}, {}
        for var in self.table:
            if var.folder not in folders:
                folders[var.folder] = await root.add_object(
                    ua.NodeId(f'{ROOT}.{var.folder}', idx), ua.QualifiedName(var.folder, idx))
            node = await self._add_variable(folders[var.folder], var)
            self.nodeid[var.key] = node.nodeid
            self.by_nodeid[node.nodeid] = var
        for method in METHODS:
            await self._add_method(root, method)
        original = iserver.attribute_service.write

        async def guarded(params, user=None):
            user = User(role=UserRole.Admin) if user is None else user
            return await self._write(params, user, original)
        iserver.attribute_service.write = guarded
        self.aspace = iserver.aspace
        self.server = server

    async def _add_variable(self, parent, var: Variable):
        idx = self.idx
        node = await parent.add_variable(ua.NodeId(f'{ROOT}.{var.key}', idx),
                                         ua.QualifiedName(var.name, idx),
                                         ua.Variant(self._values[var.key], _VARIANT[var.kind]))
        text = var.description + (f' [{UNITS[var.unit][0]}]' if var.unit else '')
        await node.write_attribute(ua.AttributeIds.Description,
                                   ua.DataValue(ua.Variant(ua.LocalizedText(text))))
        if var.writable:
            await node.set_writable()
        if var.unit is not None:
            await node.delete_reference(ua.NodeId(ua.ObjectIds.BaseDataVariableType),
                                        ua.ObjectIds.HasTypeDefinition)
            await node.add_reference(ua.NodeId(ua.ObjectIds.AnalogItemType),
                                     ua.ObjectIds.HasTypeDefinition)
            name, long = UNITS[var.unit]
            eu = ua.EUInformation(NamespaceUri=UNITS_NAMESPACE, UnitId=unit_id(var.unit),
                                  DisplayName=ua.LocalizedText(name),
                                  Description=ua.LocalizedText(long))
            await node.add_property(ua.NodeId(f'{ROOT}.{var.key}.EngineeringUnits', idx),
                                    ua.QualifiedName('EngineeringUnits', 0), eu,
                                    datatype=ua.NodeId(ua.ObjectIds.EUInformation))
            if var.low is not None and var.high is not None:
                await node.add_property(ua.NodeId(f'{ROOT}.{var.key}.EURange', idx),
                                        ua.QualifiedName('EURange', 0),
                                        ua.Range(Low=float(var.low), High=float(var.high)),
                                        datatype=ua.NodeId(ua.ObjectIds.Range))
        return node

    async def _add_method(self, root, method):
        def arguments(spec):
            return [ua.Argument(Name=name, DataType=ua.NodeId(getattr(ua.ObjectIds, kind)),
                                ValueRank=-1) for name, kind in spec]
        handler = getattr(self, f'_m_{method.name}')
        node = await root.add_method(ua.NodeId(f'{ROOT}.{method.name}', self.idx),
                                     ua.QualifiedName(method.name, self.idx), handler,
                                     arguments(method.inputs), arguments(method.outputs))
        await node.write_attribute(ua.AttributeIds.Description,
                                   ua.DataValue(ua.Variant(ua.LocalizedText(method.description))))

    # --- values in (from ROS: any thread) --------------------------------------------------
    def update(self, values: dict, stamp_ns: int | None):
        """New values of variables (``Folder.Name`` -> value) measured at ``stamp_ns`` (the
        twin's stamp; None: now)."""
        loop = self._loop
        if loop is not None and self.server is not None and not loop.is_closed():
            try:
                loop.call_soon_threadsafe(self._schedule, values, stamp_ns)
            except RuntimeError:   # the loop closed meanwhile (shutting down)
                pass

    def ros_setpoint(self, topic: str, value: float):
        """A set-point seen on ROS: ours (mirrored) or the operator's (who takes control
        back from the client holding that function)."""
        self.update({'__ros__': (topic, float(value))}, None)

    def twin_health(self, level: int, message: str):
        """The twin's /diagnostics (its worst status)."""
        self.update({'__health__': (int(level), str(message))}, None)

    def _schedule(self, values, stamp_ns):
        self._loop.create_task(self._apply(values, stamp_ns))

    async def _apply(self, values: dict, stamp_ns):
        if '__ros__' in values:
            await self._on_ros_setpoint(*values.pop('__ros__'))
        if '__health__' in values:
            self._twin_health = values.pop('__health__')
            await self._refresh_diagnostics()
        if stamp_ns is not None:
            self._last_stamp_ns = stamp_ns
        await self._write_values(values, stamp_ns)
        torque = values.get('Rotation.SurfaceTorque')
        limit = self._values.get('Rotation.MaxTorque')
        if torque is not None and limit is not None and abs(torque) > limit:
            line = self._torque_log.add(time.monotonic(), f'surface torque {torque:.0f} N m '
                                        f'above Rotation.MaxTorque {limit:.0f} N m')
            if line is not None:
                self.plant.log('warning', line)
                self._event(1, line)

    async def _write_values(self, values: dict, stamp_ns):
        source, now = _stamp(stamp_ns), datetime.now(UTC)
        for key, value in values.items():
            var = self.by_key.get(key)
            if var is None:
                continue
            if var.kind == 'Double':
                value = float(value)
            self._values[key] = value
            dv = ua.DataValue(ua.Variant(value, _VARIANT[var.kind]), SourceTimestamp=source,
                              ServerTimestamp=now)
            await self.aspace.write_attribute_value(self.nodeid[key], ua.AttributeIds.Value, dv)

    async def _on_ros_setpoint(self, topic, value):
        var = next((v for v in self.table if v.ros == topic and v.writable), None)
        if var is None:
            return
        ours = self._published.get(topic, ())
        if value in ours:
            ours.remove(value)
        elif self.arbiter.granted(var.function) and math.isfinite(value):
            client = self.arbiter.take_back(var.function)
            self._event(1, f'{var.function}: operator set-point {topic} = {value:g} on ROS: '
                           f'{client} loses control')
            await self._control_nodes(var.function, 'operator set-point on ROS')
        if math.isfinite(value):
            await self._write_values({var.key: value}, self._last_stamp_ns)

    # --- client writes --------------------------------------------------------------------
    async def _write(self, params, user, original):
        session = _SESSION.get()
        out = []
        for wv in params.NodesToWrite:
            var = self.by_nodeid.get(wv.NodeId)
            if var is None and wv.NodeId not in self.aspace:
                self._refuse(None, 'BadNodeIdUnknown', f'no node {wv.NodeId.to_string()}')
                out.append(ua.StatusCode(ua.StatusCodes.BadNodeIdUnknown))
                continue
            if var is None:
                out.extend(await original(ua.WriteParameters(NodesToWrite=[wv]), user=user))
                continue
            status = await self._client_write(var, wv, session, user)
            out.append(ua.StatusCode(getattr(ua.StatusCodes, status)))
        return out

    async def _client_write(self, var: Variable, wv, session, user) -> str:
        if wv.AttributeId != ua.AttributeIds.Value:
            return self._refuse(var, 'BadNotWritable', f'{var.key}: only its Value may be '
                                'written')
        if not var.writable:
            return self._refuse(var, 'BadNotWritable', f'{var.key} is not writable')
        if session is None or user is None or user.role == UserRole.Anonymous:
            return self._refuse(var, 'BadUserAccessDenied', f'{var.key}: anonymous sessions '
                                'on this endpoint may not write (log in)')
        if not self.arbiter.holds(var.function, session):
            holder = self.arbiter.holder(var.function) or 'the operator (ROS)'
            return self._refuse(var, 'BadUserAccessDenied', f'{var.key}: {var.function} is '
                                f'held by {holder}; call RequestControl first')
        variant = wv.Value.Value if wv.Value is not None else None
        kind = variant.VariantType.name if variant is not None else 'Null'
        value = variant.Value if variant is not None else None
        refusal = check_write(var, kind, value)
        if refusal is not None:
            return self._refuse(var, refusal.status, refusal.reason)
        now = time.monotonic()
        if var.name == 'Heartbeat':
            self.arbiter.heartbeat(var.function, now)
            value = int(value)
        elif var.name == 'MaxRefreshDelay':
            self.arbiter.set_max_refresh_delay(var.function, float(value))
        elif var.ros and not var.ros.startswith('('):
            self._published[var.ros].append(float(value))
            self.plant.setpoint(var.ros, float(value))
        await self._write_values({var.key: value}, self._last_stamp_ns)
        return 'Good'

    def _refuse(self, var, status, reason) -> str:
        self.rejected += 1
        line = self.rejections.add(time.monotonic(), f'OPC UA write refused ({status}): '
                                   f'{reason}; the last valid value stays')
        if line is not None:
            self.plant.log('warning', line)
            self._event(1, line)
        return status

    # --- control -----------------------------------------------------------------------------
    @staticmethod
    def _text(arg) -> str | None:
        value = arg.Value if isinstance(arg, ua.Variant) else arg
        return value if isinstance(value, str) else None

    async def _m_RequestControl(self, parent, function=None, client=None):
        function, client = self._text(function), self._text(client)
        if function not in FUNCTIONS or client is None:
            return ua.StatusCode(ua.StatusCodes.BadInvalidArgument)
        granted, message = self.arbiter.request(function, client, _SESSION.get(),
                                                time.monotonic())
        if granted:
            await self._control_nodes(function, 'granted')
            self.plant.log('info', f'OPC UA: {message}')
        return [ua.Variant(granted, ua.VariantType.Boolean),
                ua.Variant(message, ua.VariantType.String)]

    async def _m_ReleaseControl(self, parent, function=None):
        function = self._text(function)
        if function not in FUNCTIONS:
            return ua.StatusCode(ua.StatusCodes.BadInvalidArgument)
        client = self.arbiter.holder(function)
        released = self.arbiter.release(function, _SESSION.get())
        if released:
            await self._control_nodes(function, 'released')
            self.plant.log('info', f'OPC UA: {client} released {function}: back to the '
                           'operator, set-points kept')
        return [ua.Variant(released, ua.VariantType.Boolean)]

    async def _control_nodes(self, function, reason):
        folder = function.title()
        client = self.arbiter.holder(function)
        await self._write_values({f'{folder}.ControlGranted': bool(client),
                                  f'{folder}.ControlOwner': client}, self._last_stamp_ns)
        self.plant.control_changed(function, client, reason)

    async def _safe_state(self, function, client, silence_s):
        """Heartbeat lost: the function's safe state (:data:`SAFE_STATE`), control back to
        the operator, reported on OPC UA and (by the plant) on /diagnostics."""
        self.safe_states += 1
        if function == 'rotation':
            held = self._values.get('Rotation.Setpoint', 0.0)
            what = f'holding the speed set-point {held:g} rad/s'
        else:
            what = 'hook-load set-point held'
            if self.has_block:
                self._published['block_velocity_setpoint'].append(0.0)
                self.plant.setpoint('block_velocity_setpoint', 0.0)
                await self._write_values({'Hoisting.BlockVelocitySetpoint': 0.0},
                                         self._last_stamp_ns)
                what = 'block velocity set-point 0 m/s, ' + what
        line = (f'{function}: heartbeat of {client} silent for {silence_s:.3f} s (> '
                f'MaxRefreshDelay {self.arbiter.max_refresh_delay_s[function]:g} s): safe '
                f'state, {what}; control back to the operator')
        self.plant.log('warning', line)
        self._event(1, line)
        await self._control_nodes(function, 'safe state: ' + SAFE_STATE[function].split(',')[0])
        await self._refresh_diagnostics()

    # --- methods on the twin -------------------------------------------------------------------
    async def _service(self, service, argument=None):
        try:
            ok, message = await self.plant.call(service, argument)
        except Exception as exc:  # noqa: BLE001 - a method's failure is its answer
            ok, message = False, f'{service} failed: {exc}'
        return [ua.Variant(bool(ok), ua.VariantType.Boolean),
                ua.Variant(str(message), ua.VariantType.String)]

    async def _m_Reset(self, parent):
        return await self._service('reset')

    async def _m_Pause(self, parent, pause=None):
        value = pause.Value if isinstance(pause, ua.Variant) else pause
        if not isinstance(value, bool):
            return ua.StatusCode(ua.StatusCodes.BadTypeMismatch)
        return await self._service('pause', value)

    async def _m_StartScenario(self, parent, name=None):
        if self._text(name) is None:
            return ua.StatusCode(ua.StatusCodes.BadTypeMismatch)
        return await self._service('start_scenario', self._text(name))

    # --- health ----------------------------------------------------------------------------
    def _event(self, level, message):
        self._events.append((time.monotonic(), level, message))
        if self._loop is not None:
            self._loop.create_task(self._refresh_diagnostics())

    def status(self) -> tuple:
        """The bridge's own ``(level, message)``: WARN while an event of the last
        :data:`EVENT_WINDOW_S` s stands (its latest message), else OK."""
        now = time.monotonic()
        recent = [(lvl, msg) for t, lvl, msg in self._events if now - t <= EVENT_WINDOW_S]
        if not recent:
            return 0, 'OK'
        return max(lvl for lvl, _ in recent), recent[-1][1]

    async def _refresh_diagnostics(self):
        own, twin = self.status(), self._twin_health
        level, message = max((twin, own), key=lambda s: s[0])
        if own[0] and twin[0] and twin[1] and own[1] != twin[1]:
            message = f'{own[1]}; twin: {twin[1]}'
        await self._write_values({'Diagnostics.Level': int(level),
                                  'Diagnostics.Message': message or 'OK'}, None)

    def value(self, key):
        """The current value of a variable (as the server holds it)."""
        return self._values.get(key)
