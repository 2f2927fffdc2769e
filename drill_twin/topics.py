"""The twin's ROS interface as plain data (imports no ROS).

One table says, for every drill_twin topic, its message type, its QoS and how
its fields come from :meth:`drill_twin.runtime.digital_twin.DigitalTwin.measurements`.
The ROS nodes build their publishers from it, the MCAP recorder its channels
(schema + ``offered_qos_profiles``), and replay / resimulation decode with it,
so a topic is described once.

Fields are nested dicts in the layout of the ROS message (``{'twist':
{'angular': {'x': 1.0}}}``); fields left out keep the message default (0).
Units: SI (m, m/s, rad/s, N, N m); frame ``bit`` has x along the string axis,
pointing down-hole, for both the axial and the angular components.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

__all__ = ['QoS', 'Topic', 'TOPICS', 'JOINTS', 'COMMANDS_TOPIC', 'BY_NAME', 'SENSOR',
           'SETPOINT', 'COMMAND', 'EVENTS',
           'stamp_fields', 'measurement_messages', 'diagnostics_fields', 'clock_fields',
           'FLOAT64', 'MEASUREMENTS', 'PARAMETER_EVENTS', 'parameter_event_fields',
           'parameter_value_fields', 'parameter_value', 'SURFACE_INPUTS', 'ESTIMATE_TOPICS',
           'RECORDABLE', 'RECORDABLE_BY_NAME', 'TF', 'LATCHED', 'SCENE', 'LIVE_ROLES']


@dataclass(frozen=True)
class QoS:
    """A QoS profile as data (keep-last history; default deadline/lifespan/liveliness)."""

    reliability: str  # 'reliable' | 'best_effort'
    durability: str   # 'volatile' | 'transient_local'
    depth: int


#: measurements: best effort, volatile, depth 5 (= rclpy ``qos_profile_sensor_data``)
SENSOR = QoS('best_effort', 'volatile', 5)
#: set-points and low-rate advisories a late joiner must still get (REP-2003)
SETPOINT = QoS('reliable', 'transient_local', 1)
#: controller commands: reliable, volatile (a stale command must not be replayed)
COMMAND = QoS('reliable', 'volatile', 1)
#: /diagnostics and /clock (rclpy's default profile)
EVENTS = QoS('reliable', 'volatile', 10)
#: /parameter_events (rclpy's ``qos_profile_parameter_events``)
PARAMETER_EVENTS = QoS('reliable', 'volatile', 1000)
#: /tf (tf2_ros's ``DynamicBroadcasterQoS``)
TF = QoS('reliable', 'volatile', 100)
#: /tf_static and the well geometry: sent once, a late joiner still gets them
LATCHED = QoS('reliable', 'transient_local', 1)

FLOAT64 = 'std_msgs/msg/Float64'
#: joint names of ``joint_states``: rotational (top drive, bit), axial (block, bit)
JOINTS = ('top_drive', 'bit', 'block', 'bit_axial')
#: forward-command-controller style commands: data = [top-drive speed rad/s(, block
#: velocity m/s for a hoist)]
COMMANDS_TOPIC = 'forward_velocity_controller/commands'


@dataclass(frozen=True)
class Topic:
    """One topic of the twin's interface.

    ``role``: ``setpoint`` (into the twin), ``measurement`` (out, every tick),
    ``advisory`` (stability, low rate), ``diagnostics``, ``clock``, ``parameters``
    (run-time parameter changes, published by rclpy and recorded by the twin), ``scene``
    (the 3-D view, a few Hz: :mod:`drill_twin.runtime.scene`), ``geometry`` (the latched
    part of the 3-D view).
    ``fields(m, stamp)`` maps a measurement dict to message fields (measurements only).
    """

    name: str
    type: str
    qos: QoS
    role: str
    fields: Callable[[dict, dict], dict] | None = None


def stamp_fields(time_s: float | None = None, ns: int | None = None) -> dict:
    """``builtin_interfaces/Time`` fields of a time given in s or (exactly) in ns."""
    ns = int(round(time_s * 1e9)) if ns is None else int(ns)
    return {'sec': ns // 1_000_000_000, 'nanosec': ns % 1_000_000_000}


def _header(stamp):
    return {'stamp': stamp, 'frame_id': 'bit'}


def _float(key):
    return lambda m, stamp: {'data': float(m[key])}


TOPICS = (
    Topic('surface_speed_setpoint', FLOAT64, SETPOINT, 'setpoint'),
    Topic('hook_load_setpoint', FLOAT64, SETPOINT, 'setpoint'),
    Topic('surface_speed_command', FLOAT64, COMMAND, 'setpoint'),
    Topic('block_velocity_setpoint', FLOAT64, SETPOINT, 'setpoint'),
    Topic('torque_limit_setpoint', FLOAT64, SETPOINT, 'setpoint'),
    Topic('bit/velocity', 'geometry_msgs/msg/TwistStamped', SENSOR, 'measurement',
          lambda m, st: {'header': _header(st), 'twist': {
              'linear': {'x': float(m['bit_axial_speed_m_s'])},
              'angular': {'x': float(m['bit_angular_speed_rad_s'])}}}),
    Topic('bit/wrench', 'geometry_msgs/msg/WrenchStamped', SENSOR, 'measurement',
          lambda m, st: {'header': _header(st), 'wrench': {
              'force': {'x': float(m['weight_on_bit_N'])},
              'torque': {'x': float(m['torque_on_bit_Nm'])}}}),
    Topic('bit/depth_of_cut', FLOAT64, SENSOR, 'measurement', _float('depth_of_cut_m')),
    Topic('bit/rate_of_penetration', FLOAT64, SENSOR, 'measurement',
          _float('rate_of_penetration_m_s')),
    Topic('bit/stuck', 'std_msgs/msg/Bool', SENSOR, 'measurement',
          lambda m, st: {'data': bool(m['stuck'])}),
    Topic('bit/stick_slip_severity', FLOAT64, SENSOR, 'measurement',
          _float('stick_slip_severity')),
    Topic('bit/height_above_bottom', FLOAT64, SENSOR, 'measurement',
          _float('bit_above_bottom_m')),
    Topic('surface/top_drive_speed', FLOAT64, SENSOR, 'measurement',
          _float('top_drive_speed_rad_s')),
    Topic('surface/torque', FLOAT64, SENSOR, 'measurement', _float('surface_torque_Nm')),
    Topic('surface/motor_torque', FLOAT64, SENSOR, 'measurement', _float('motor_torque_Nm')),
    Topic('surface/hook_load', FLOAT64, SENSOR, 'measurement', _float('hook_load_N')),
    # the ros2_control vocabulary (stamped): rotational joints rad, rad/s, N m; axial m, m/s, N
    Topic('joint_states', 'sensor_msgs/msg/JointState', SENSOR, 'measurement',
          lambda m, st: {'header': {'stamp': st, 'frame_id': ''}, 'name': list(JOINTS),
                         'position': [float(m[k]) for k in ('top_drive_angle_rad',
                                                            'bit_angle_rad',
                                                            'block_position_m', 'bit_depth_m')],
                         'velocity': [float(m[k]) for k in ('top_drive_speed_rad_s',
                                                            'bit_angular_speed_rad_s',
                                                            'block_velocity_m_s',
                                                            'bit_axial_speed_m_s')],
                         'effort': [float(m[k]) for k in ('surface_torque_Nm',
                                                          'torque_on_bit_Nm', 'hook_load_N',
                                                          'weight_on_bit_N')]}),
    # stamped forms of the surface scalars (frame 'surface': x along the hole axis, down)
    Topic('surface/twist', 'geometry_msgs/msg/TwistStamped', SENSOR, 'measurement',
          lambda m, st: {'header': {'stamp': st, 'frame_id': 'surface'}, 'twist': {
              'linear': {'x': float(m['block_velocity_m_s'])},
              'angular': {'x': float(m['top_drive_speed_rad_s'])}}}),
    Topic('surface/wrench', 'geometry_msgs/msg/WrenchStamped', SENSOR, 'measurement',
          lambda m, st: {'header': {'stamp': st, 'frame_id': 'surface'}, 'wrench': {
              'force': {'x': float(m['hook_load_N'])},
              'torque': {'x': float(m['surface_torque_Nm'])}}}),
    Topic('surface/block_velocity', FLOAT64, SENSOR, 'measurement',
          _float('block_velocity_m_s')),
    # stamped forms of the bit's scalars (no standard stamped scalar exists: a Vector3Stamped
    # per physical group, each component named in the README)
    Topic('bit/penetration', 'geometry_msgs/msg/Vector3Stamped', SENSOR, 'measurement',
          lambda m, st: {'header': _header(st), 'vector': {
              'x': float(m['depth_of_cut_m']), 'y': float(m['bit_above_bottom_m']),
              'z': float(m['rate_of_penetration_m_s'])}}),
    Topic('bit/stick_slip', 'geometry_msgs/msg/Vector3Stamped', SENSOR, 'measurement',
          lambda m, st: {'header': _header(st), 'vector': {
              'x': float(m['stick_slip_severity']), 'y': 1.0 if m['stuck'] else 0.0}}),
    Topic('stability/spectral_abscissa', FLOAT64, SETPOINT, 'advisory'),
    Topic('stability/critical_surface_speed', FLOAT64, SETPOINT, 'advisory'),
    Topic('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray', EVENTS, 'diagnostics'),
    Topic('/clock', 'rosgraph_msgs/msg/Clock', EVENTS, 'clock'),
    Topic('/parameter_events', 'rcl_interfaces/msg/ParameterEvent', PARAMETER_EVENTS,
          'parameters'),
    # the 3-D view (drill_twin.runtime.scene): frames well -> top_drive, bit; the string
    Topic('/tf', 'tf2_msgs/msg/TFMessage', TF, 'scene'),
    Topic('string/markers', 'visualization_msgs/msg/MarkerArray', EVENTS, 'scene'),
    # along the string, node by node: depth, speed, torque, tension, wall contact force
    Topic('string/profile', 'std_msgs/msg/Float64MultiArray', EVENTS, 'scene'),
    Topic('/tf_static', 'tf2_msgs/msg/TFMessage', LATCHED, 'geometry'),
    Topic('well/markers', 'visualization_msgs/msg/MarkerArray', LATCHED, 'geometry'),
    Topic('well/path', 'nav_msgs/msg/Path', LATCHED, 'geometry'),
)
BY_NAME = {t.name: t for t in TOPICS}
MEASUREMENTS = tuple(t for t in TOPICS if t.role == 'measurement')
SCENE = tuple(t for t in TOPICS if t.role in ('scene', 'geometry'))
#: what the twin publishes (and the live view serves): set-points as applied included
LIVE_ROLES = ('setpoint', 'measurement', 'advisory', 'diagnostics', 'clock', 'scene',
              'geometry')
#: what ``downhole_estimator`` reads (a real rig's topics are remapped onto these)
SURFACE_INPUTS = ('surface/top_drive_speed', 'surface/torque', 'surface/hook_load',
                  'surface/block_velocity')


def _covariance(variances: dict) -> list:
    """Row-major 6×6 covariance of (x, y, z, rot x, rot y, rot z) with the given diagonal
    entries (index: variance); the components not estimated are left at 0."""
    cov = [0.0] * 36
    for index, value in variances.items():
        cov[7 * index] = float(value)
    return cov


#: the downhole estimator's outputs, from an :class:`~drill_twin.estimation.Estimate` as a
#: dict (``dataclasses.asdict``); frame ``bit`` as for the twin's bit topics
ESTIMATE_TOPICS = (
    Topic('estimate/bit/velocity', 'geometry_msgs/msg/TwistWithCovarianceStamped', SENSOR,
          'estimate', lambda e, st: {'header': _header(st), 'twist': {
              'twist': {'linear': {'x': _finite(e['bit_axial_speed_m_s'])},
                        'angular': {'x': float(e['bit_speed_rad_s'])}},
              'covariance': _covariance({0: _finite(e['bit_axial_speed_std']) ** 2,
                                         3: e['bit_speed_std'] ** 2})}}),
    Topic('estimate/bit/wrench', 'geometry_msgs/msg/WrenchStamped', SENSOR, 'estimate',
          lambda e, st: {'header': _header(st), 'wrench': {
              'force': {'x': _finite(e['weight_on_bit_N'])},
              'torque': {'x': float(e['torque_on_bit_Nm'])}}}),
    Topic('estimate/bit/stuck', 'std_msgs/msg/Bool', SENSOR, 'estimate',
          lambda e, st: {'data': bool(e['stuck'])}),
    Topic('estimate/stick_slip_severity', FLOAT64, SENSOR, 'estimate',
          lambda e, st: {'data': float(e['stick_slip_severity'])}),
)


#: every topic a drill_twin node publishes or reads: what ``mcap_recorder`` knows
RECORDABLE = TOPICS + ESTIMATE_TOPICS
RECORDABLE_BY_NAME = {t.name: t for t in RECORDABLE}


def _finite(value) -> float:
    """NaN (not estimated: no hook load / block velocity) is published as 0."""
    value = float(value)
    return value if value == value else 0.0


def measurement_messages(m: dict, stamp: dict):
    """``(topic, fields)`` of every measurement topic for one tick's measurements."""
    return [(t, t.fields(m, stamp)) for t in MEASUREMENTS]


def diagnostics_fields(stamp: dict, level: int, message: str, values: dict,
                       name: str = 'drill_twin: model') -> dict:
    """``diagnostic_msgs/DiagnosticArray`` fields with one status (level 0 OK, 1 WARN,
    2 ERROR)."""
    return {'header': {'stamp': stamp, 'frame_id': ''},
            'status': [{'level': int(level), 'name': name, 'message': message,
                        'hardware_id': 'drill_twin',
                        'values': [{'key': k, 'value': f'{v}'} for k, v in values.items()]}]}


def clock_fields(time_s: float) -> dict:
    """``rosgraph_msgs/Clock`` fields."""
    return {'clock': stamp_fields(time_s)}


#: ``rcl_interfaces/msg/ParameterType`` code of a Python value (scalars and string lists)
_PARAMETER_TYPES = ((bool, 1, 'bool_value'), (int, 2, 'integer_value'),
                    (float, 3, 'double_value'), (str, 4, 'string_value'))


def parameter_value_fields(value) -> dict:
    """``rcl_interfaces/ParameterValue`` fields of a bool, int, float, str or list of str."""
    if isinstance(value, (list, tuple)):
        return {'type': 9, 'string_array_value': [str(v) for v in value]}
    for kind, code, key in _PARAMETER_TYPES:
        if isinstance(value, kind):
            return {'type': code, key: value}
    raise ValueError(f'unsupported parameter value {value!r}')


def parameter_value(fields) -> object:
    """The Python value of decoded ``ParameterValue`` fields (None if not set)."""
    code = fields.type
    keys = {1: 'bool_value', 2: 'integer_value', 3: 'double_value', 4: 'string_value',
            9: 'string_array_value'}
    return getattr(fields, keys[code]) if code in keys else None


def parameter_event_fields(stamp: dict, node: str, changed: dict) -> dict:
    """``rcl_interfaces/ParameterEvent`` fields: ``changed`` maps names to new values."""
    return {'stamp': stamp, 'node': node,
            'changed_parameters': [{'name': k, 'value': parameter_value_fields(v)}
                                   for k, v in changed.items()]}
