"""The OPC UA address space of the twin as plain data (no asyncua, no ROS).

Every variable under ``Objects/DrillTwin`` is one :class:`Variable`: its browse path, its
OPC UA data type, its unit as a UNECE Recommendation 20 common code (what OPC UA Part 8
prescribes for ``EngineeringUnits``), its ``EURange`` where one exists, whether a client
may write it, and the ROS topic field it mirrors.  The server builds its nodes from this
table, the bridge fills them from it and docs/opcua.md describes it, so a node is
described once.
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ['NAMESPACE_URI', 'ROOT', 'Variable', 'Method', 'UNITS', 'unit_id', 'variables',
           'METHODS', 'FUNCTIONS', 'DEFAULT_ENDPOINT']

#: the namespace of every drill_twin node
NAMESPACE_URI = 'urn:drill_twin'
#: the object under ``Objects`` that holds the twin
ROOT = 'DrillTwin'
#: loopback: a local anonymous client may take control and write
DEFAULT_ENDPOINT = 'opc.tcp://127.0.0.1:4840/drill_twin/'
#: the functions a client takes control of (``RequestControl``)
FUNCTIONS = ('rotation', 'hoisting')

#: UNECE Rec. 20 common code -> (display name, description)
UNITS = {
    '2A': ('rad/s', 'radian per second'),
    'C81': ('rad', 'radian'),
    'NEW': ('N', 'newton'),
    'NU': ('N·m', 'newton metre'),
    'MTR': ('m', 'metre'),
    'MTS': ('m/s', 'metre per second'),
    'SEC': ('s', 'second'),
    'C97': ('1/s', 'reciprocal second'),
    'C62': ('1', 'one (dimensionless)'),
}


def unit_id(code: str) -> int:
    """``EUInformation.UnitId`` of a UNECE common code (OPC UA Part 8, 5.6.3: the code's
    ASCII characters, left to right, each shifted in by 8 bits)."""
    value = 0
    for char in code.strip():
        value = (value << 8) | ord(char)
    return value


@dataclass(frozen=True)
class Variable:
    """One variable of the address space.

    Parameters
    ----------
    folder, name : str
        Browse path ``DrillTwin/<folder>/<name>`` (namespace :data:`NAMESPACE_URI`).
    kind : str
        OPC UA data type: ``Double``, ``Boolean``, ``UInt32``, ``Int32`` or ``String``.
    description : str
        The node's ``Description``.
    unit : str or None
        UNECE common code (a key of :data:`UNITS`); None for booleans, counters, text.
    low, high : float or None
        ``EURange`` (SI, inclusive); for a writable variable, the range a write must be in.
    writable : bool
        A client holding control of ``function`` may write it.
    function : str or None
        The function (:data:`FUNCTIONS`) a write needs control of.
    ros : str
        The ROS topic (and field) the value comes from or goes to.
    initial : object
        Value before the twin has said anything.
    """

    folder: str
    name: str
    kind: str
    description: str
    unit: str | None = None
    low: float | None = None
    high: float | None = None
    writable: bool = False
    function: str | None = None
    ros: str = ''
    initial: object = 0.0

    @property
    def key(self) -> str:
        """``Folder.Name``: how the bridge and the tests name the variable."""
        return f'{self.folder}.{self.name}'

    @property
    def path(self) -> tuple:
        """Browse names below ``Objects``."""
        return (ROOT, self.folder, self.name)


@dataclass(frozen=True)
class Method:
    """A method of ``DrillTwin``: name, (argument name, type) in and out, description."""

    name: str
    inputs: tuple
    outputs: tuple
    description: str
    ros: str = ''


def _function_block(folder, function):
    return (
        Variable(folder, 'ControlGranted', 'Boolean', f'true while a client holds control of '
                 f'{function} (RequestControl); false: the operator (ROS) has it',
                 initial=False, ros='bridge /diagnostics (opcua control)'),
        Variable(folder, 'ControlOwner', 'String', f'the client holding control of {function}, '
                 '"" for the operator (ROS)', initial='', ros='bridge /diagnostics'),
        Variable(folder, 'Heartbeat', 'UInt32', 'counter the controlling client writes at least '
                 'every MaxRefreshDelay; silence longer than that puts the function in its safe '
                 'state and returns control to the operator', writable=True, function=function,
                 initial=0, low=0, high=2 ** 32 - 1),
        Variable(folder, 'MaxRefreshDelay', 'Double', 'longest heartbeat silence accepted',
                 'SEC', 0.05, 10.0, writable=True, function=function, initial=0.5),
    )


def variables(max_speed_rad_s: float = 40.0, string_weight_N: float = 1.0e7,
              has_block: bool = False, max_torque_Nm: float = 1.0e5,
              speed_rad_s: float = 0.0, hook_load_N: float = 0.0,
              motor_drive: bool = True) -> tuple:
    """The variables of the address space, with the ranges of the twin's configuration.

    Parameters
    ----------
    max_speed_rad_s : float
        Largest surface-speed set-point the twin accepts [rad/s].
    string_weight_N : float
        Buoyed string weight [N]: the hook-load set-point's upper bound.
    has_block : bool
        The string hangs on a hoist / imposed block velocity (block velocity set-points);
        otherwise on a constant hook load (hook-load set-points).
    max_torque_Nm : float
        The motor drive's rated torque limit [N m]: ``Rotation.MaxTorque``'s initial value
        and upper bound.
    motor_drive : bool
        The twin turns the string with a PI motor drive (``Rotation.MaxTorque`` writable);
        otherwise the speed is prescribed and the limit only reported against.
    speed_rad_s, hook_load_N : float
        Initial values of ``Rotation.Setpoint`` [rad/s] and ``Hoisting.HookLoadSetpoint`` [N]:
        the twin's configured operating point, so that a client reading the set-point before
        it writes one reads what the twin runs at (until a set-point arrives).
    """
    hook_note = '' if not has_block else ' (not writable: this string hangs on a hoist; set ' \
        'BlockVelocitySetpoint)'
    block_note = '' if has_block else ' (not writable: this string hangs on a constant hook ' \
        'load; set HookLoadSetpoint)'
    table = (
        Variable('Rotation', 'Setpoint', 'Double', 'top-drive (surface) speed set-point',
                 '2A', 0.0, float(max_speed_rad_s), True, 'rotation', 'surface_speed_setpoint',
                 float(speed_rad_s)),
        Variable('Rotation', 'Measured', 'Double', 'measured top-drive speed', '2A',
                 ros='joint_states velocity[top_drive] (= surface/top_drive_speed)'),
        Variable('Rotation', 'SurfaceTorque', 'Double', 'surface (top-drive) torque', 'NU',
                 ros='joint_states effort[top_drive] (= surface/torque)'),
        Variable('Rotation', 'MotorTorque', 'Double', "the top-drive motor's torque (what "
                 'its drive reports; it answers a set-point in the tick that applies it)',
                 'NU', ros='surface/motor_torque'),
        Variable('Rotation', 'MaxTorque', 'Double', "the top-drive motor's torque limit: the "
                 "drive's demand is clipped to it (at most the rated limit); a surface torque "
                 'above it is reported (Diagnostics WARN)', 'NU', 0.0, float(max_torque_Nm),
                 bool(motor_drive), 'rotation', 'torque_limit_setpoint', float(max_torque_Nm)),
        *_function_block('Rotation', 'rotation'),
        Variable('Hoisting', 'HookLoadSetpoint', 'Double', 'hook-load set-point' + hook_note,
                 'NEW', 0.0, float(string_weight_N), not has_block, 'hoisting',
                 'hook_load_setpoint', float(hook_load_N)),
        Variable('Hoisting', 'BlockVelocitySetpoint', 'Double', 'block velocity set-point, '
                 'down-hole positive' + block_note, 'MTS', -10.0, 10.0, has_block, 'hoisting',
                 'block_velocity_setpoint'),
        Variable('Hoisting', 'HookLoad', 'Double', 'hook load', 'NEW',
                 ros='joint_states effort[block] (= surface/hook_load)'),
        Variable('Hoisting', 'BlockVelocity', 'Double', 'block velocity, down-hole positive',
                 'MTS', ros='joint_states velocity[block] (= surface/block_velocity)'),
        Variable('Hoisting', 'BlockPosition', 'Double', 'block position, down-hole positive',
                 'MTR', ros='joint_states position[block]'),
        *_function_block('Hoisting', 'hoisting'),
        Variable('Bit', 'AngularSpeed', 'Double', 'bit angular speed', '2A',
                 ros='joint_states velocity[bit] (= bit/velocity twist.angular.x)'),
        Variable('Bit', 'AxialSpeed', 'Double', 'bit axial speed, down-hole positive', 'MTS',
                 ros='joint_states velocity[bit_axial] (= bit/velocity twist.linear.x)'),
        Variable('Bit', 'WeightOnBit', 'Double', 'weight on bit (WOB)', 'NEW',
                 ros='joint_states effort[bit_axial] (= bit/wrench force.x)'),
        Variable('Bit', 'TorqueOnBit', 'Double', 'torque on bit (TOB)', 'NU',
                 ros='joint_states effort[bit] (= bit/wrench torque.x)'),
        Variable('Bit', 'DepthOfCut', 'Double', 'depth of cut per revolution', 'MTR',
                 ros='bit/penetration vector.x (= bit/depth_of_cut)'),
        Variable('Bit', 'HeightAboveBottom', 'Double', 'bit height above the hole bottom',
                 'MTR', 0.0, None, ros='bit/penetration vector.y (= bit/height_above_bottom)'),
        Variable('Bit', 'RateOfPenetration', 'Double', 'rate of penetration', 'MTS',
                 ros='bit/penetration vector.z (= bit/rate_of_penetration)'),
        Variable('Bit', 'Depth', 'Double', 'bit axial position', 'MTR',
                 ros='joint_states position[bit_axial]'),
        Variable('Bit', 'Stuck', 'Boolean', 'bit stuck (angular stick phase)', initial=False,
                 ros='bit/stick_slip vector.y (= bit/stuck)'),
        Variable('Bit', 'StickSlipSeverity', 'Double', 'stick-slip severity (max - min)/(2 '
                 'mean) of the bit speed over 10 s', 'C62', 0.0, None,
                 ros='bit/stick_slip vector.x (= bit/stick_slip_severity)'),
        Variable('Estimate', 'BitAngularSpeed', 'Double', 'estimated bit angular speed '
                 '(downhole_estimator)', '2A', ros='estimate/bit/velocity twist.angular.x'),
        Variable('Estimate', 'BitAngularSpeedStd', 'Double', 'standard deviation of '
                 'BitAngularSpeed', '2A', 0.0, None,
                 ros='estimate/bit/velocity sqrt(covariance[21])'),
        Variable('Estimate', 'BitAxialSpeed', 'Double', 'estimated bit axial speed', 'MTS',
                 ros='estimate/bit/velocity twist.linear.x'),
        Variable('Estimate', 'BitAxialSpeedStd', 'Double', 'standard deviation of '
                 'BitAxialSpeed', 'MTS', 0.0, None,
                 ros='estimate/bit/velocity sqrt(covariance[0])'),
        Variable('Estimate', 'WeightOnBit', 'Double', 'estimated weight on bit', 'NEW',
                 ros='estimate/bit/wrench force.x'),
        Variable('Estimate', 'TorqueOnBit', 'Double', 'estimated torque on bit', 'NU',
                 ros='estimate/bit/wrench torque.x'),
        Variable('Estimate', 'Stuck', 'Boolean', 'estimated bit stuck', initial=False,
                 ros='estimate/bit/stuck'),
        Variable('Estimate', 'StickSlipSeverity', 'Double', 'estimated stick-slip severity',
                 'C62', 0.0, None, ros='estimate/stick_slip_severity'),
        Variable('Stability', 'SpectralAbscissa', 'Double', 'largest real part of the '
                 'linearised model\'s roots at the current set-points (> 0: unstable)', 'C97',
                 ros='stability/spectral_abscissa'),
        Variable('Stability', 'CriticalSpeed', 'Double', 'surface speed below which the '
                 'linearised model is unstable', '2A', ros='stability/critical_surface_speed'),
        Variable('Diagnostics', 'Level', 'Int32', 'worst health level: 0 OK, 1 WARN, 2 ERROR '
                 '(the twin\'s and the bridge\'s)', initial=0, low=0, high=2,
                 ros='/diagnostics level'),
        Variable('Diagnostics', 'Message', 'String', 'what the level is about', initial='',
                 ros='/diagnostics message'),
    )
    return table


METHODS = (
    Method('RequestControl', (('function', 'String'), ('client', 'String')),
           (('granted', 'Boolean'), ('message', 'String')),
           'take control of a function (rotation | hoisting) as the named client; granted '
           'unless another client holds it', '(bridge arbitration)'),
    Method('ReleaseControl', (('function', 'String'),), (('released', 'Boolean'),),
           'give control of a function back to the operator (the set-points are kept)',
           '(bridge arbitration)'),
    Method('Reset', (), (('success', 'Boolean'), ('message', 'String')),
           'back to the configured initial state', '/drill_twin/reset (std_srvs/Trigger)'),
    Method('Pause', (('pause', 'Boolean'),), (('success', 'Boolean'), ('message', 'String')),
           'true holds simulated time, false resumes', '/drill_twin/pause (std_srvs/SetBool)'),
    Method('StartScenario', (('name', 'String'),), (('success', 'Boolean'),
                                                    ('message', 'String')),
           '(re)start the operations scenario the twin was started with (name: informative)',
           '/drill_twin/start_scenario (std_srvs/Trigger)'),
)
