"""Every index of the kernel's arrays, named once.

The kernel keeps its state and its model in a few flat numpy arrays (numba compiles
array access to pointer arithmetic; Python objects it cannot pass).  What each slot
holds is declared here, once, as a tuple of names; :func:`indices` turns the tuple into a
named tuple of integers, which numba reads as compile-time constants (``x[DRIVE.speed]``
costs what ``x[1]`` costs).  The kernel, the Python API around it
(:mod:`drill_twin.physics.simulation`) and the linearisation
(:mod:`drill_twin.stability.linearize`) all import their indices from here: adding a state,
a record channel or an input is one name in one tuple.

The state vector of a model with ``na`` axial and ``nt`` torsional degrees of freedom is
``x = [u (na), u' (na), φ (nt), φ' (nt), drive block]`` (perturbations of the steady motion;
the bit is the last DOF of each chain): :func:`state_layout`.
"""
from __future__ import annotations

from collections import namedtuple
from typing import NamedTuple

from .jit import kernel_jit

__all__ = ['indices', 'offsets', 'MODE', 'ANGULAR', 'AXIAL', 'SWITCH', 'INPUT', 'COUNTER', 'STATUS',
           'AUX', 'CHAIN', 'TRIPLE', 'FORM', 'SURFACE', 'READ', 'GEOM', 'SIGNAL', 'RING', 'HISTORY',
           'DRIVE', 'START', 'TIME', 'RECORD', 'RECORD_CHANNELS', 'CHAIN_FORMS', 'WALL',
           'CONTACT',
           'BitMotion', 'StateLayout', 'state_layout']


def indices(typename: str, names, start: int = 0):
    """A named tuple whose fields are ``names`` and whose values are their positions
    (``start``, ``start + 1``, ...)."""
    return namedtuple(typename, names)(*range(start, start + len(names)))


def offsets(typename: str, sized):
    """A named tuple of where each of ``sized = ((name, size), ...)`` starts when they
    follow one another, and the total ``size``."""
    starts, at = [], 0
    for _, size in sized:
        starts.append(at)
        at += size
    return namedtuple(typename, [name for name, _ in sized] + ['size'])(*starts, at)


#: the interface mode (int array): angular and axial mode, then one contact flag per blade
#: group from ``contact`` on
MODE = indices('Mode', ('angular', 'axial', 'contact'))
#: values of ``mode[MODE.angular]``: the bit slips (turns) or sticks
ANGULAR = indices('Angular', ('slip', 'stick'))
#: values of ``mode[MODE.axial]``: the bit moves down, up, or is stuck axially
AXIAL = indices('Axial', ('down', 'up', 'stuck'))
#: switching functions (the mode holds while all are >= 0): angular, the two axial bounds,
#: then one per blade group from ``contact`` on
SWITCH = indices('Switch', ('angular', 'axial_low', 'axial_high', 'contact'))
#: run-time inputs: surface (motor) speed command, extra axial force on the top, block
#: velocity, the PI motor drive's torque limit in force (at most its rated ``Top.t_max``)
INPUT = indices('Input', ('speed_command', 'axial_force', 'block_velocity', 'torque_limit'))
#: counters (int array)
COUNTER = indices('Counter', ('steps', 'events', 'impulses', 'status', 'bad_index',
                              'writes'))
#: values of ``counters[COUNTER.status]``
STATUS = indices('Status', ('ok', 'nonfinite'))
#: what the right-hand side leaves for the law and the record: weight and torque on bit,
#: cutting force, wear-flat capacity, the reactions a stuck bit needs, the mean delay and
#: worst residual of the bottom surface, the mean depth of cut, the motor's torque
AUX = indices('Aux', ('weight', 'torque', 'cut', 'capacity', 'weight_required',
                      'torque_required', 'delay', 'delay_residual', 'depth', 'motor_torque'))
#: rows of a packed chain (mass, damping, stiffness: three rows each, TRIPLE), the Thomas
#: factors (or the boundary Schur complement's inverse), the inverse diagonal, the
#: compliance of the bit z = M⁻¹ e_bit, the form (FORM), the first element's node 1
CHAIN = offsets('Chain', (('mass', 3), ('damping', 3), ('stiffness', 3), ('thomas', 1),
                         ('inverse', 1), ('compliance', 1), ('form', 1), ('node1', 1)))
#: the rows of a tridiagonal triple: below, on and above the diagonal (arrow chains: the
#: top row, the diagonal, the bit row)
TRIPLE = indices('Triple', ('lower', 'diagonal', 'upper'))
#: ``chain[CHAIN.form]``: [form, first element's stiffness coupling, damping coupling]
FORM = indices('Form', ('kind', 'top_stiffness', 'top_damping'))
#: values of ``chain[CHAIN.form, FORM.kind]``: a tridiagonal mass, an arrow (a reduced
#: string), a diagonal (lumped) mass with tridiagonal damping and stiffness
CHAIN_FORMS = indices('ChainForms', ('tridiagonal', 'arrow', 'diagonal'))
#: rows of the bottom surface (:mod:`~drill_twin.physics.bottom_surface`)
SURFACE = indices('Surface', ('height', 'previous', 'angle', 'time', 'previous_time',
                              'residual'))
#: what a blade reads of the surface ahead of it: the height, the time the preceding blade
#: left it, the largest crossing residual of the nodes used
READ = indices('Read', ('height', 'time', 'residual'))
#: the surface's geometry: its period, node spacing, smallest blade gap [rad]
GEOM = indices('Geom', ('period', 'spacing', 'min_gap'))
#: signals of the constant-delay history (:mod:`~drill_twin.physics.time_history`)
SIGNAL = indices('Signal', ('bit_axial_speed', 'bit_angular_speed', 'motor_speed',
                            'surface_torque'))
#: rows of the history ring: the sample times, each signal's value, each signal's slope
RING = offsets('Ring', (('time', 1), ('values', len(SIGNAL)), ('slopes', len(SIGNAL))))
#: the history ring's bookkeeping: first sample, samples held, reads before the first
HISTORY = indices('History', ('start', 'count', 'overflows'))
#: the drive block at the end of the state vector: set-point angle θ_p and speed ω_p,
#: block position z_p, the motor drive's integral and torque reference
DRIVE = indices('Drive', ('angle', 'speed', 'block', 'integral', 'torque_reference'))
#: the bit's motion at the end of the initial function (a perturbation jumps from it):
#: position, velocity, angle, speed, and whether the jump is still to be written
START = indices('Start', ('position', 'velocity', 'angle', 'speed', 'pending'))
#: rows of the wall-contact array (one column per string node that touches the wall,
#: :mod:`~drill_twin.physics.wall_contact`): the node's axial and torsional DOF, its static
#: and dynamic friction capacity μ_s n, μ_d n (axial force units M d*/t*²), its contact
#: radius ρ = r/d*, the masses of its sliding velocity (axial lumped mass; tangential
#: mass κ m_t/ρ², κ = C t*²/(M d*²)), and the Stribeck speed v_S/(d*/t*) over which the
#: sliding friction falls from the static to the dynamic level (0: at once) —
#: docs/physics.md §9
WALL = indices('Wall', ('axial_dof', 'torsional_dof', 'static', 'dynamic', 'radius',
                        'axial_mass', 'tangential_mass', 'stribeck'))
#: values of the per-node wall state (int array): the node slides, or sticks to the wall
CONTACT = indices('Contact', ('slide', 'stick'))
#: the run's clock: time and the accumulated time with the bit stuck angularly [t*]
TIME = indices('Time', ('now', 'stuck'))
#: the recorded channels, one row per recorded step, in this order
RECORD_CHANNELS = ('tau', 'bit_axial_speed', 'bit_angular_speed', 'weight_on_bit',
                   'torque_on_bit', 'depth_of_cut', 'delay', 'delay_residual',
                   'angular_stick', 'axial_mode', 'contact', 'surface_torque',
                   'surface_speed', 'bit_axial_perturbation', 'bit_angle_perturbation',
                   'top_axial_speed', 'stick_time', 'hook_load_change', 'bit_position',
                   'bit_angle', 'block_position', 'top_angle_perturbation', 'top_drive_speed',
                   'motor_torque', 'top_drive_angle')
RECORD = indices('Record', RECORD_CHANNELS)


class BitMotion(NamedTuple):
    """The bit's total (not perturbed) motion at one instant, dimensionless: axial
    position U and velocity U' (units d*, d*/t*), angle Φ and speed Φ' (rad, rad/t*)."""

    position: float
    velocity: float
    angle: float
    speed: float


class StateLayout(NamedTuple):
    """Where each part of the state vector of ``na`` axial and ``nt`` torsional DOFs
    starts (see the module docstring), and the DOFs the kernel addresses one by one."""

    u: int              # axial displacements (na)
    v: int              # axial velocities (na)
    phi: int            # angles (nt)
    omega: int          # angular speeds (nt)
    drive: int          # the drive block (DRIVE)
    size: int           # the whole state
    bit_u: int          # the bit's axial displacement, velocity
    bit_v: int
    top_v: int          # the top's axial velocity
    top_phi: int        # the top's angle and speed (torsional DOF 0)
    top_omega: int
    bit_phi: int        # the bit's angle and speed (torsional DOF nt - 1)
    bit_omega: int


@kernel_jit(inline='always')
def state_layout(na, nt):
    """The :class:`StateLayout` of ``na`` axial and ``nt`` torsional DOFs (compiled into
    the kernel; from Python, ``state_layout.py_func``)."""
    d = 2 * na + 2 * nt
    return StateLayout(0, na, 2 * na, 2 * na + nt, d, d + len(DRIVE), na - 1, 2 * na - 1, na,
                       2 * na, 2 * na + nt, 2 * na + nt - 1, d - 1)
