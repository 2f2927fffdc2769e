"""Jitted time-integration kernel: RK4 with event-located stick/slip transitions.

Method (one integrator for every model)
---------------------------------------
* The perturbation equations of :mod:`drill_twin.physics.models` are written as
  a first-order system ``x = [u, u', φ, φ', drive block]``
  (:func:`~drill_twin.physics.layout.state_layout`) and advanced with the classical
  4th-order Runge-Kutta method.  A chain's accelerations cost O(n)
  (:mod:`drill_twin.physics.chain`: Thomas recurrences, or the arrow form of a reduced
  string).
* The bit/rock law (:mod:`drill_twin.physics.interface_law`) is piecewise smooth.
  Within a step the interface *mode* is held fixed, so the right-hand side is
  smooth and RK4 keeps its order.  When a switching function of the mode is
  negative at the end of a step, the crossing is located by the Illinois method on
  the step's cubic Hermite interpolant of the state (the dense output of the step,
  as scipy's ``solve_ivp`` locates events), the step is redone to that instant, the
  law's transition rule applies and the mode is settled; integration goes on.  A
  stuck bit has its velocity exactly zero and is held by a Lagrange multiplier
  (Schur complement of the mass matrix), whose value is the reaction checked against
  the set-valued law.  No velocity threshold is involved.
* The depth of cut comes from the bottom-hole surface
  (:mod:`drill_twin.physics.bottom_surface`), written after every accepted step
  from the step's interpolant of the bit motion.
* The wall's Coulomb friction on the nodes of a string in a deviated well
  (``Model.wall``; none in a vertical well, whose steps are then those above, bit for
  bit) is a set-valued law at every node: after the step, each node's velocity takes the
  implicit (Moreau–Jean) impulse of the step in closed form
  (:func:`~drill_twin.physics.wall_law.project_node`), its position the trapezoidal
  share of it, and the right-hand side is evaluated again.  Lie splitting: first order
  in the step where a node is in contact (docs/physics.md §9).

Data: two named tuples, and one scratch array.  :class:`Model` is what the run is made
of (constant while it runs: the law, the top's couplings, the packed chains, the
surface's geometry); :class:`State` is what the run changes (arrays updated in place:
clock, state vector, mode, inputs, surface, delayed-signal history, counters, the initial
function's end).  Every index into them is a name of :mod:`drill_twin.physics.layout`.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .bottom_surface import read_surface, write_step
from .chain import accelerations
from .interface_law import (
    bit_torque,
    bit_weight,
    contact_forces,
    sliding_wear_flat,
    stuck_wear_flat,
    switching,
    transition,
)
from .jit import entry_jit, kernel_jit
from .layout import (
    ANGULAR,
    AUX,
    AXIAL,
    CHAIN,
    CHAIN_FORMS,
    CONTACT,
    COUNTER,
    DRIVE,
    FORM,
    INPUT,
    MODE,
    READ,
    RECORD,
    RECORD_CHANNELS,
    SIGNAL,
    START,
    STATUS,
    SWITCH,
    TIME,
    TRIPLE,
    WALL,
    BitMotion,
    indices,
    state_layout,
)
from .time_history import push_sample, sample_at_time
from .wall_law import project_node, sliding_friction

__all__ = ['Law', 'Top', 'Model', 'State', 'Recording', 'advance', 'snapshot', 'rhs',
           'RECORD_CHANNELS']


class Law(NamedTuple):
    """Bit/rock law (dimensionless): bluntness λ per blade, β, and the blade groups —
    ``offsets`` their angles on the surface period, ``weights`` blades per group."""

    lam: float
    beta: float
    offsets: np.ndarray
    weights: np.ndarray


class Top(NamedTuple):
    """Nominal motion and the couplings of the string's top to the drives.

    ``omega_o, upsilon_o, W_o, T_o``: steady state; ``psi``: axial force scale;
    ``k_t, c_t, m_t``: torsional coupling of DOF 0 to the motor angle θ_p;
    ``k_a, c_a``: axial coupling of DOF 0 to the block position z_p (imposed
    velocity top or drill line of a hoist); ``drive_node``: 1 when DOF 0 is the
    string's top node carrying the drive (Soft-Torque), 0 when the top is the
    prescribed motion itself; ``drive_tau``: lag of the motor speed
    behind its command (0 = stiff); ``z_a, tau_a, z_t, tau_t``: delayed radiation
    dash-pots of lumped model III (0 otherwise).  ``drive_pi``: 1 when DOF 0 is the motor
    of a PI-controlled top drive (:mod:`drill_twin.physics.top_drive`) with gains ``kp,
    ki``, torque feedback ``g_t``, torque limit ``t_max``, torque-reference filter
    ``t_filter`` and sensor delay ``t_delay`` (all dimensionless, :func:`~drill_twin.
    physics.top_drive.kernel_drive`).
    """

    omega_o: float
    upsilon_o: float
    W_o: float
    T_o: float
    psi: float
    k_t: float
    c_t: float
    m_t: float
    k_a: float
    c_a: float
    drive_node: float
    drive_tau: float
    z_a: float
    tau_a: float
    z_t: float
    tau_t: float
    drive_pi: float
    kp: float
    ki: float
    g_t: float
    t_max: float
    t_filter: float
    t_delay: float


class Model(NamedTuple):
    """What a run is made of, constant while it runs: the bit/rock :class:`Law`, the
    :class:`Top` couplings, the packed axial and torsional chains
    (:func:`~drill_twin.physics.chain.pack_chain`), the bottom surface's geometry
    (:data:`~drill_twin.physics.layout.GEOM`) and the nodes in contact with the wall
    (:data:`~drill_twin.physics.layout.WALL` rows, one column per node; no columns in a
    vertical well)."""

    law: Law
    top: Top
    axial: np.ndarray
    torsional: np.ndarray
    geom: np.ndarray
    wall: np.ndarray


class State(NamedTuple):
    """What a run changes, arrays updated in place (names of :mod:`~drill_twin.physics.
    layout`): the clock (``TIME``), the state vector (``state_layout``), the interface
    mode (``MODE``, int), the run-time inputs (``INPUT``), the bottom surface (``SURFACE``
    rows), the delayed-signal ring and its bookkeeping (``RING``, ``HISTORY``, int), the
    counters (``COUNTER``, int), the end of the initial function (``START``) and each
    wall node's state (``CONTACT``, int, one per column of ``Model.wall``)."""

    time: np.ndarray
    x: np.ndarray
    mode: np.ndarray
    inputs: np.ndarray
    surface: np.ndarray
    history: np.ndarray
    history_meta: np.ndarray
    counters: np.ndarray
    start: np.ndarray
    wall: np.ndarray


class Recording(NamedTuple):
    """Where :func:`advance` records: a row of ``RECORD`` channels into ``rows`` every
    ``every`` steps (0: none), the state vector into ``states`` if it has rows, and the
    count of rows written in ``written`` (a one-element int array)."""

    rows: np.ndarray
    states: np.ndarray
    every: int
    written: np.ndarray


@kernel_jit(inline='always')
def bit_motion(tau, x, m):
    """The bit's total motion (:class:`~drill_twin.physics.layout.BitMotion`,
    dimensionless) in the state ``x`` at time ``tau``."""
    L = state_layout(m.axial.shape[1], m.torsional.shape[1])
    top = m.top
    ub = top.upsilon_o * tau + x[L.bit_u]
    vb = top.upsilon_o + x[L.bit_v]
    if m.torsional.shape[1] > 0:
        phb = top.omega_o * tau + x[L.bit_phi]
        omb = top.omega_o + x[L.bit_omega]
    else:  # axial-only models: the bit turns with the prescribed drive
        phb = top.omega_o * tau + x[L.drive + DRIVE.angle]
        omb = top.omega_o + x[L.drive + DRIVE.speed]
    return BitMotion(ub, vb, phb, omb)


class Work(NamedTuple):
    """Named views of the scratch array of one integration (:func:`_work`): the RK4 stages,
    the step's end and trial states, the aux values, the blade depths, what a blade
    reads, the switching functions and the delayed signals.

    The kernel's non-inlined functions take the one scratch array and name its rows with
    :func:`_views` (free: views are pointer arithmetic); a tuple of fifteen arrays passed
    by value through every call cost more than the right-hand side of a small model."""

    k1: np.ndarray
    k2: np.ndarray
    k3: np.ndarray
    k4: np.ndarray
    tmp: np.ndarray
    x_end: np.ndarray
    x_try: np.ndarray
    aux: np.ndarray
    depths: np.ndarray
    read: np.ndarray
    g: np.ndarray
    g_lo: np.ndarray
    delayed: np.ndarray
    values: np.ndarray
    slopes: np.ndarray


#: rows of the scratch array: one per :class:`Work` field, then its sizes
_ROW = indices('Row', Work._fields + ('sizes',))
#: what the sizes row holds: the state's size and the blade groups
_SIZES = indices('Sizes', ('n', 'groups'))


@entry_jit
def _work(n, groups):
    """The scratch array (one row per :class:`Work` field, then the sizes)."""
    width = max(n, len(AUX), len(SWITCH) + groups, len(SIGNAL), len(READ))
    work = np.zeros((len(_ROW), width))
    work[_ROW.sizes, _SIZES.n] = n
    work[_ROW.sizes, _SIZES.groups] = groups
    return work


@kernel_jit(inline='always')
def _views(work):
    """The :class:`Work` views of the scratch array."""
    n = int(work[_ROW.sizes, _SIZES.n])
    groups = int(work[_ROW.sizes, _SIZES.groups])
    switches = len(SWITCH) - 1 + groups
    signals = len(SIGNAL)
    return Work(work[_ROW.k1, :n], work[_ROW.k2, :n], work[_ROW.k3, :n], work[_ROW.k4, :n],
                work[_ROW.tmp, :n], work[_ROW.x_end, :n], work[_ROW.x_try, :n],
                work[_ROW.aux, :len(AUX)], work[_ROW.depths, :groups],
                work[_ROW.read, :len(READ)], work[_ROW.g, :switches],
                work[_ROW.g_lo, :switches], work[_ROW.delayed, :signals],
                work[_ROW.values, :signals], work[_ROW.slopes, :signals])


@kernel_jit(inline='always')
def _depths(tau, bit, m, s, w):
    """Depth of cut of every blade group (and the mean delay / worst residual in aux)."""
    law = m.law
    delay = 0.0
    res = 0.0
    for b in range(law.offsets.size):
        read_surface(s.surface, m.geom, bit.angle, law.offsets[b], w.read)
        w.depths[b] = bit.position - w.read[READ.height]
        delay += tau - w.read[READ.time]
        res = max(res, w.read[READ.residual])
    w.aux[AUX.delay] = delay / law.offsets.size
    w.aux[AUX.delay_residual] = res


@kernel_jit
def rhs(tau, x, dx, m, s, work):
    """Right-hand side of the first-order system in a fixed interface mode; fills ``dx`` and
    the aux values (forces, reactions the law checks, delay)."""
    _rhs(tau, x, dx, m, s, _views(work))


@kernel_jit(inline='always')
def _rhs(tau, x, dx, m, s, w):
    """:func:`rhs` on the views ``w``, inlined at its one call site in the stepping path
    (RK4's stage loop); everything else calls :func:`rhs`."""
    L = state_layout(m.axial.shape[1], m.torsional.shape[1])
    law, top, inp = m.law, m.top, s.inputs
    bit = bit_motion(tau, x, m)
    _depths(tau, bit, m, s, w)
    cut, cap = contact_forces(w.depths, law.weights, s.mode, law.lam)
    w.aux[AUX.cut] = cut
    w.aux[AUX.capacity] = cap
    n_b = 0.0
    for b in range(law.weights.size):
        n_b += law.weights[b]
    mean_depth = 0.0
    for b in range(law.weights.size):
        mean_depth += law.weights[b] * w.depths[b]
    w.aux[AUX.depth] = mean_depth / n_b
    # drives: motor angle/speed perturbation θ_p, ω_p (first-order lag or stiff); block z_p
    d = L.drive
    om_p = x[d + DRIVE.speed]
    om_p_dot = (inp[INPUT.speed_command] - top.omega_o - om_p) / top.drive_tau \
        if top.drive_tau > 0.0 else 0.0
    z_p_dot = inp[INPUT.block_velocity] - top.upsilon_o
    dx[d + DRIVE.angle] = om_p
    dx[d + DRIVE.speed] = om_p_dot
    dx[d + DRIVE.block] = z_p_dot
    dx[d + DRIVE.integral] = 0.0
    dx[d + DRIVE.torque_reference] = 0.0
    _axial(tau, x, dx, m, s, w)
    w_f = w.aux[AUX.weight] - cut
    if m.torsional.shape[1] > 0:
        _torsional(tau, x, dx, m, s, w)
    else:
        w.aux[AUX.torque] = bit_torque(cut, w_f, law.beta)
        w.aux[AUX.torque_required] = w.aux[AUX.torque]


@kernel_jit(inline='always')
def _axial(tau, x, dx, m, s, w):
    """The axial chain's accelerations and the weight on bit (free, or the reaction a stuck
    bit needs); reads the cutting force and capacity from ``w.aux``."""
    A = m.axial
    na = A.shape[1]
    L = state_layout(na, m.torsional.shape[1])
    top, inp = m.top, s.inputs
    cut, cap = w.aux[AUX.cut], w.aux[AUX.capacity]
    z_p_dot = dx[L.drive + DRIVE.block]
    psi = top.psi
    u = x[L.u:L.u + na]
    v = x[L.v:L.v + na]
    ya = dx[L.v:L.v + na]
    f_top = psi * inp[INPUT.axial_force] + top.k_a * x[L.drive + DRIVE.block] \
        + top.c_a * z_p_dot
    if top.z_a > 0.0:
        # lumped model III: pipe force = radiation force of the bit velocity one wave round
        # trip earlier (single-mass chains: DOF 0 is the bit)
        sample_at_time(s.history, s.history_meta, tau - top.tau_a, w.delayed)
        f_top -= top.z_a * (w.delayed[SIGNAL.bit_axial_speed] - top.upsilon_o)
    z = A[CHAIN.compliance]
    if s.mode[MODE.axial] == AXIAL.stuck:
        accelerations(A, u, v, f_top, 0.0, ya)
        lam_c = ya[na - 1] / z[na - 1]
        w_req = top.W_o + lam_c / psi
        for i in range(na):
            ya[i] -= lam_c * z[i]
        ya[na - 1] = 0.0
        w_bit = w_req
    else:
        w_bit = bit_weight(cut, sliding_wear_flat(s.mode[MODE.axial], cap))
        accelerations(A, u, v, f_top, -psi * (w_bit - top.W_o), ya)
        # the reaction a stuck bit would need (for the switching functions)
        w_req = top.W_o + (ya[na - 1] / z[na - 1]) / psi + (w_bit - top.W_o)
    for i in range(na):
        dx[L.u + i] = v[i]
    w.aux[AUX.weight] = w_bit
    w.aux[AUX.weight_required] = w_req


@kernel_jit(inline='always')
def surface_torque_perturbation(x, m):
    """Perturbation of the torque in the string's first element (a free top node: the
    motor or the Soft-Torque drive), units C."""
    T = m.torsional
    nt = T.shape[1]
    L = state_layout(m.axial.shape[1], nt)
    p0, w0 = L.top_phi, L.top_omega
    if T[CHAIN.form, FORM.kind] != CHAIN_FORMS.arrow:
        k01 = T[CHAIN.stiffness + TRIPLE.upper, 0]
        c01 = T[CHAIN.damping + TRIPLE.upper, 0]
        return -k01 * (x[p0] - x[p0 + 1]) - c01 * (x[w0] - x[w0 + 1])
    node1 = T[CHAIN.node1]              # node 1 is a combination of the chain's DOFs
    p1 = 0.0
    w1 = 0.0
    for j in range(nt):
        p1 += node1[j] * x[p0 + j]
        w1 += node1[j] * x[w0 + j]
    return -T[CHAIN.form, FORM.top_stiffness] * (x[p0] - p1) \
        - T[CHAIN.form, FORM.top_damping] * (x[w0] - w1)


@kernel_jit(inline='always')
def _motor_drive(tau, x, dx, m, s, w):
    """Motor torque of the PI top drive (total, units C) and the derivatives of its
    integral ϑ_p and torque reference T_ref (docs/control.md, eqs C.1-C.4): sensors
    delayed by ``t_delay``, torque feedback ``g_t``, limit ``t_max`` (or the lower one the
    input ``torque_limit`` sets), back-calculation
    anti-windup with tracking time kp/ki."""
    top = m.top
    L = state_layout(m.axial.shape[1], m.torsional.shape[1])
    d = L.drive
    om_p = x[d + DRIVE.speed]
    if top.t_delay > 0.0:
        sample_at_time(s.history, s.history_meta, tau - top.t_delay, w.delayed)
        speed = w.delayed[SIGNAL.motor_speed]
        torque = w.delayed[SIGNAL.surface_torque]
    else:
        speed = x[L.top_omega]
        torque = surface_torque_perturbation(x, m)
    error = om_p - top.g_t * (torque - x[d + DRIVE.torque_reference]) - speed
    demand = top.T_o + top.kp * error + top.ki * x[d + DRIVE.integral]
    limit = min(top.t_max, s.inputs[INPUT.torque_limit])
    motor = min(max(demand, -limit), limit)
    dx[d + DRIVE.integral] = error + (motor - demand) / top.kp
    dx[d + DRIVE.torque_reference] = (torque - x[d + DRIVE.torque_reference]) / top.t_filter \
        if top.t_filter > 0.0 else 0.0
    w.aux[AUX.motor_torque] = motor
    return motor


@kernel_jit(inline='always')
def _torsional(tau, x, dx, m, s, w):
    """The torsional chain's accelerations and the torque on bit (free, or the reaction a
    stuck bit needs); reads the cutting force and the wear-flat force from ``w.aux`` and
    the drive's motion from ``x`` and ``dx``."""
    T = m.torsional
    nt = T.shape[1]
    L = state_layout(m.axial.shape[1], nt)
    law, top = m.law, m.top
    d = L.drive
    cut = w.aux[AUX.cut]
    w_f = w.aux[AUX.weight] - cut
    om_p, om_p_dot = x[d + DRIVE.speed], dx[d + DRIVE.speed]
    ph = x[L.phi:L.phi + nt]
    om = x[L.omega:L.omega + nt]
    yt = dx[L.omega:L.omega + nt]
    f_top = top.k_t * x[d + DRIVE.angle] + top.c_t * om_p + top.m_t * om_p_dot
    if top.drive_pi > 0.0:
        f_top += _motor_drive(tau, x, dx, m, s, w) - top.T_o
    if top.z_t > 0.0:
        sample_at_time(s.history, s.history_meta, tau - top.tau_t, w.delayed)
        f_top -= top.z_t * (w.delayed[SIGNAL.bit_angular_speed] - top.omega_o)
    z = T[CHAIN.compliance]
    if s.mode[MODE.angular] == ANGULAR.stick:
        accelerations(T, ph, om, f_top, 0.0, yt)
        lam_c = yt[nt - 1] / z[nt - 1]
        t_req = top.T_o + lam_c
        for i in range(nt):
            yt[i] -= lam_c * z[i]
        yt[nt - 1] = 0.0
        t_bit = t_req
    else:
        t_bit = bit_torque(cut, w_f, law.beta)
        accelerations(T, ph, om, f_top, -(t_bit - top.T_o), yt)
        t_req = t_bit + yt[nt - 1] / z[nt - 1]
    for i in range(nt):
        dx[L.phi + i] = om[i]
    w.aux[AUX.torque] = t_bit
    w.aux[AUX.torque_required] = t_req


@kernel_jit
def _switching_at(tau, x, dx, m, s, work, g):
    """Evaluate the right-hand side (for the reactions) and the switching functions (at an
    interpolated state, while an event is located)."""
    rhs(tau, x, dx, m, s, work)
    return _switching(tau, x, m, s, work, g)


@kernel_jit(inline='always')
def _switching(tau, x, m, s, work, g):
    """The switching functions of the state ``x`` whose right-hand side was just evaluated
    (its aux values are in the work array); returns the smallest.  Inlined: a few lines
    around the compiled law, called every step."""
    w = _views(work)
    switching(s.mode, bit_motion(tau, x, m), w.depths, w.aux, m.law.beta,
              m.torsional.shape[1] > 0, g)
    gmin = g[0]
    for k in range(1, g.size):
        gmin = min(gmin, g[k])
    return gmin


@kernel_jit
def _rk4(tau, h, m, s, work):
    """One classical RK4 step of size ``h`` from the state (``s.x`` at ``tau``, with
    ``w.k1 = f(tau, x)``): stages k2, k3, k4 at (tau + h/2, x + h/2 k1), (tau + h/2,
    x + h/2 k2), (tau + h, x + h k3), the step's end into ``w.x_end``, and f at the end
    into ``w.k4`` (with the aux values there: what the switching functions and the next
    step need) — four evaluations through one call site of the inlined right-hand side,
    the only one in the stepping path."""
    w = _views(work)
    x = s.x
    n = x.size
    tmp, out, k1 = w.tmp, w.x_end, w.k1
    stages = (k1, w.k2, w.k3, w.k4)
    for stage in range(1, 5):
        point = tmp
        if stage < 4:
            c = 1.0 if stage == 3 else 0.5
            previous = stages[stage - 1]
            for i in range(n):
                tmp[i] = x[i] + c * h * previous[i]
        else:
            c = 1.0
            for i in range(n):
                out[i] = x[i] + h / 6.0 * (k1[i] + 2.0 * w.k2[i] + 2.0 * w.k3[i] + w.k4[i])
            point = out
        _rhs(tau + c * h, point, stages[min(stage, 3)], m, s, w)


@kernel_jit
def _interpolate(x0, x1, f0, f1, h, s, out):
    """The step's dense output: cubic Hermite of the state on ``x0, x1`` and the
    derivatives ``f0, f1`` at its ends, at fraction ``s``."""
    s2 = s * s
    s3 = s2 * s
    a0 = 2 * s3 - 3 * s2 + 1
    b0 = (s3 - 2 * s2 + s) * h
    a1 = -2 * s3 + 3 * s2
    b1 = (s3 - s2) * h
    for i in range(x0.size):
        out[i] = a0 * x0[i] + b0 * f0[i] + a1 * x1[i] + b1 * f1[i]


@kernel_jit
def _locate(tau, h, g_end, m, s, work):
    """Fraction of the step at which the smallest switching function reaches zero: the
    Illinois method on the step's interpolant (from ``s.x`` with slope ``w.k1`` to
    ``w.x_end`` with slope ``w.k3``)."""
    w = _views(work)
    s_lo = 0.0
    g_lo = _switching_at(tau, s.x, w.tmp, m, s, work, w.g_lo)
    s_hi = 1.0
    g_hi = g_end
    side = 0
    for _ in range(80):
        if s_hi - s_lo < 1e-10:
            break
        f = s_lo + (s_hi - s_lo) * g_lo / (g_lo - g_hi) if g_lo > 0.0 else 0.5 * (s_lo + s_hi)
        if not (s_lo < f < s_hi):
            f = 0.5 * (s_lo + s_hi)
        _interpolate(s.x, w.x_end, w.k1, w.k3, h, f, w.x_try)
        gs = _switching_at(tau + f * h, w.x_try, w.tmp, m, s, work, w.g)
        if gs >= 0.0:
            s_lo, g_lo = f, gs
            if side == -1:
                g_hi *= 0.5
            side = -1
        else:
            s_hi, g_hi = f, gs
            if side == 1:
                g_lo *= 0.5
            side = 1
    return s_hi


@kernel_jit(inline='always')
def _commit(tau0, tau1, m, s, work):
    """After an accepted (sub)step from ``s.x`` (slope ``w.k1``) to ``w.x_end`` (slope
    ``w.k4``): the blades write the surface they swept, and the delayed signals go into
    their history.  ``start[START.pending]``: the step began at an instantaneous
    perturbation; the rock it swept is written from the bit motion before it (the end of
    the DDE's initial function, ``s.start``), and the flag is cleared.  Inlined at its two
    call sites in :func:`_step` (it is called every step; what it calls is compiled on its
    own)."""
    w = _views(work)
    b0 = bit_motion(tau0, s.x, m)
    start = s.start
    if start[START.pending] > 0.0:
        b0 = BitMotion(start[START.position], start[START.velocity], start[START.angle],
                       start[START.speed])
        start[START.pending] = 0.0
    b1 = bit_motion(tau1, w.x_end, m)
    s.counters[COUNTER.writes] += write_step(s.surface, m.geom, m.law.offsets, tau0, tau1,
                                             b0, b1)
    top = m.top
    if top.z_a > 0.0 or top.z_t > 0.0 or top.t_delay > 0.0:
        _push_history(tau1, b1, m, s, work)


@kernel_jit
def _push_history(tau1, b1, m, s, work):
    """Append the delayed signals (:data:`~drill_twin.physics.layout.SIGNAL`) at the end of
    a step (``w.x_end``, slope ``w.k4``; the bit's motion ``b1``): the surface torque's
    slope is that of the first element's torque, from the state slope."""
    w = _views(work)
    L = state_layout(m.axial.shape[1], m.torsional.shape[1])
    x1, f1 = w.x_end, w.k4
    ib = L.bit_omega if m.torsional.shape[1] > 0 else L.drive + DRIVE.speed
    values, slopes = w.values, w.slopes
    values[SIGNAL.bit_axial_speed], slopes[SIGNAL.bit_axial_speed] = b1.velocity, f1[L.bit_v]
    values[SIGNAL.bit_angular_speed], slopes[SIGNAL.bit_angular_speed] = b1.speed, f1[ib]
    if m.top.drive_pi > 0.0 and m.torsional.shape[1] > 1:
        w0 = L.top_omega
        values[SIGNAL.motor_speed], slopes[SIGNAL.motor_speed] = x1[w0], f1[w0]
        values[SIGNAL.surface_torque] = surface_torque_perturbation(x1, m)
        slopes[SIGNAL.surface_torque] = surface_torque_perturbation(f1, m)
    push_sample(s.history, s.history_meta, tau1, values, slopes)


@kernel_jit(inline='always')
def _any_contact(mode, groups):
    for b in range(groups):
        if mode[MODE.contact + b] == 1:
            return True
    return False


@kernel_jit
def _settle(tau, m, s, work):
    """Choose the interface mode consistent with the state ``s.x`` after an event (called
    with the velocity that crossed zero already set exactly to zero)."""
    w = _views(work)
    A = m.axial
    na = A.shape[1]
    nt = m.torsional.shape[1]
    L = state_layout(na, nt)
    x, mode, law, top = s.x, s.mode, m.law, m.top
    dx = w.k1
    if not _any_contact(mode, law.offsets.size):
        # off bottom the interface law has nothing to hold: free motion both ways
        bit = bit_motion(tau, x, m)
        mode[MODE.angular] = ANGULAR.slip
        mode[MODE.axial] = AXIAL.up if bit.velocity < 0.0 else AXIAL.down
        rhs(tau, x, w.k1, m, s, work)
        return
    for _ in range(4):
        old_ang = mode[MODE.angular]
        old_ax = mode[MODE.axial]
        bit = bit_motion(tau, x, m)
        vb = bit.velocity
        if nt > 0 and mode[MODE.angular] == ANGULAR.slip and bit.speed <= 0.0:
            x[L.bit_omega] = -top.omega_o
            mode[MODE.angular] = ANGULAR.stick
        if mode[MODE.angular] == ANGULAR.stick:
            if vb > 0.0:  # no drilling without rotation: inelastic stop of the bit
                z = A[CHAIN.compliance]
                zb = z[na - 1]
                for i in range(na):
                    x[L.v + i] -= vb / zb * z[i]
                x[L.bit_v] = -top.upsilon_o
                s.counters[COUNTER.impulses] += 1
                vb = 0.0
            if vb == 0.0:
                mode[MODE.axial] = AXIAL.stuck
                rhs(tau, x, dx, m, s, work)
                if w.aux[AUX.weight_required] < 0.0:
                    mode[MODE.axial] = AXIAL.up
            # release check of the angular stick
            rhs(tau, x, dx, m, s, work)
            cut, cap = w.aux[AUX.cut], w.aux[AUX.capacity]
            w_f = stuck_wear_flat(w.aux[AUX.weight_required], cut, cap) \
                if mode[MODE.axial] == AXIAL.stuck else 0.0
            if w.aux[AUX.torque_required] > bit_torque(cut, w_f, law.beta):
                mode[MODE.angular] = ANGULAR.slip
        if mode[MODE.angular] == ANGULAR.slip:
            if vb == 0.0:
                mode[MODE.axial] = AXIAL.stuck
                rhs(tau, x, dx, m, s, work)
                w_f = w.aux[AUX.weight_required] - w.aux[AUX.cut]
                if _any_contact(mode, law.offsets.size):  # some blade on the rock
                    if w_f < 0.0:
                        mode[MODE.axial] = AXIAL.up
                    elif w_f > w.aux[AUX.capacity]:
                        mode[MODE.axial] = AXIAL.down
                else:
                    mode[MODE.axial] = AXIAL.down if w.aux[AUX.weight_required] > 0.0 \
                        else AXIAL.up
            elif vb > 0.0:
                mode[MODE.axial] = AXIAL.down
            else:
                mode[MODE.axial] = AXIAL.up
        if mode[MODE.angular] == old_ang and mode[MODE.axial] == old_ax:
            break
    rhs(tau, x, w.k1, m, s, work)


@kernel_jit
def _apply_transition(tau, m, s, work):
    """At a located event: the rule of the violated switching function, then settle."""
    w = _views(work)
    L = state_layout(m.axial.shape[1], m.torsional.shape[1])
    g = w.g
    k = 0
    for j in range(1, g.size):
        if g[j] < g[k]:
            k = j
    stop_rotation, stop_descent = transition(k, s.mode, w.aux[AUX.weight_required])
    if stop_rotation:
        s.x[L.bit_omega] = -m.top.omega_o
    if stop_descent:
        s.x[L.bit_v] = -m.top.upsilon_o
    _settle(tau, m, s, work)


@kernel_jit
def _step(tau, h, m, s, work):
    """Advance one step of size ``h``, cut at the events inside it (at most 20: a 20th is
    accepted, no Zeno loop).  ``w.k1`` holds f(tau, x) on entry and on exit."""
    w = _views(work)
    x = s.x
    n = x.size
    remaining = h
    for sub in range(20):
        _rk4(tau, remaining, m, s, work)
        gmin = _switching(tau + remaining, w.x_end, m, s, work, w.g)
        if gmin >= 0.0 or sub == 19:
            _commit(tau, tau + remaining, m, s, work)
            if s.mode[MODE.angular] == ANGULAR.stick:
                s.time[TIME.stuck] += remaining
            for i in range(n):
                x[i] = w.x_end[i]
                w.k1[i] = w.k4[i]
            return tau + remaining
        # an event inside the step: locate it on the interpolant, redo the step to it
        for i in range(n):
            w.k3[i] = w.k4[i]  # f at the step end, for the interpolant
        f = _locate(tau, remaining, gmin, m, s, work)
        dt = f * remaining
        _rk4(tau, dt, m, s, work)
        _switching(tau + dt, w.x_end, m, s, work, w.g)
        _commit(tau, tau + dt, m, s, work)
        for i in range(n):
            x[i] = w.x_end[i]
        if s.mode[MODE.angular] == ANGULAR.stick:
            s.time[TIME.stuck] += dt
        tau += dt
        remaining -= dt
        s.counters[COUNTER.events] += 1
        _apply_transition(tau, m, s, work)
        if remaining <= 1e-12 * h:
            break
    return tau


@kernel_jit
def _wall(h, m, s):
    """The wall's friction impulse of a step of size ``h`` on every node of ``m.wall``
    (docs/physics.md §9, eqs 9.4-9.9; the bit node only while no blade is on the rock):
    the node's total velocity (axial, and rim speed ρ ω), with the sliding friction at the
    speed of the step's start (eq. 9.9), is projected by
    :func:`~drill_twin.physics.wall_law.project_node`, and its position moves by half a
    step of the velocity change (the trapezoidal rule of the impulse's constant force: a
    stuck node does not creep)."""
    na = m.axial.shape[1]
    L = state_layout(na, m.torsional.shape[1])
    wall, x, contact = m.wall, s.x, s.wall
    upsilon_o, omega_o = m.top.upsilon_o, m.top.omega_o
    on_bottom = _any_contact(s.mode, m.law.offsets.size)
    for j in range(wall.shape[1]):
        ia = int(wall[WALL.axial_dof, j])
        it = int(wall[WALL.torsional_dof, j])
        if ia == na - 1 and on_bottom:
            continue            # a blade on the rock: the bit's own law holds the bit
        rho = wall[WALL.radius, j]
        m_a = wall[WALL.axial_mass, j]
        m_t = wall[WALL.tangential_mass, j]
        y_a = upsilon_o + x[L.v + ia]
        y_t = rho * (omega_o + x[L.omega + it])
        static, stribeck = wall[WALL.static, j], wall[WALL.stribeck, j]
        speed = math.sqrt(y_a * y_a + y_t * y_t) if stribeck > 0.0 else 0.0  # unused at 0
        slide = h * sliding_friction(static, wall[WALL.dynamic, j], stribeck, speed)
        hold = h * static if contact[j] == CONTACT.stick else slide
        new_a, new_t, stuck = project_node(m_a * y_a, m_t * y_t, m_a, m_t, hold, slide)
        contact[j] = CONTACT.stick if stuck else CONTACT.slide
        if stuck:               # exactly at rest: total velocity zero
            dv, dw = -y_a, -y_t / rho
            x[L.v + ia] = -upsilon_o
            x[L.omega + it] = -omega_o
        else:
            dv, dw = new_a - y_a, (new_t - y_t) / rho
            x[L.v + ia] += dv
            x[L.omega + it] += dw
        x[L.u + ia] += 0.5 * h * dv
        x[L.phi + it] += 0.5 * h * dw


@kernel_jit
def _write_record(row, evaluated, m, s, work):
    """Fill one record row (:data:`~drill_twin.physics.layout.RECORD`) from the current
    state.  ``evaluated``: the aux values already belong to this state (every step ends
    with a right-hand side at its final state and mode — the switching check or the
    settling after an event — and the surface a step writes is read with the values from
    before the write), so the right-hand side is not evaluated again."""
    w = _views(work)
    na = m.axial.shape[1]
    nt = m.torsional.shape[1]
    L = state_layout(na, nt)
    top, inp, x, mode = m.top, s.inputs, s.x, s.mode
    tau = s.time[TIME.now]
    d = L.drive
    if not evaluated:
        rhs(tau, x, w.tmp, m, s, work)
    bit = bit_motion(tau, x, m)
    row[RECORD.tau] = tau
    row[RECORD.bit_axial_speed] = bit.velocity
    row[RECORD.bit_angular_speed] = bit.speed
    row[RECORD.weight_on_bit] = w.aux[AUX.weight]
    row[RECORD.torque_on_bit] = w.aux[AUX.torque]
    row[RECORD.depth_of_cut] = w.aux[AUX.depth]
    row[RECORD.delay] = w.aux[AUX.delay]
    row[RECORD.delay_residual] = w.aux[AUX.delay_residual]
    row[RECORD.angular_stick] = mode[MODE.angular]
    row[RECORD.axial_mode] = mode[MODE.axial]
    contact = 0
    for b in range(m.law.offsets.size):
        contact += mode[MODE.contact + b]
    row[RECORD.contact] = 1.0 if contact > 0 else 0.0
    p0, w0 = L.top_phi, L.top_omega     # top torsional DOF: angle, speed
    coupling = top.T_o + top.k_t * (x[d + DRIVE.angle] - x[p0]) \
        + top.c_t * (x[d + DRIVE.speed] - x[w0]) if nt > 0 else 0.0
    if nt > 1 and top.drive_node > 0.0:  # torque in the string's first element
        row[RECORD.surface_torque] = top.T_o + surface_torque_perturbation(x, m)
        row[RECORD.top_drive_speed] = top.omega_o + x[w0]
        # the motor's torque: the PI drive's, or the Soft-Torque spring and dash-pot's
        row[RECORD.motor_torque] = w.aux[AUX.motor_torque] if top.drive_pi > 0.0 \
            else coupling
    elif nt > 0:                        # the coupling to the prescribed top
        row[RECORD.surface_torque] = coupling
        row[RECORD.top_drive_speed] = top.omega_o + x[d + DRIVE.speed]
        row[RECORD.motor_torque] = row[RECORD.surface_torque]
    else:
        row[RECORD.surface_torque] = w.aux[AUX.torque]
        row[RECORD.top_drive_speed] = top.omega_o + x[d + DRIVE.speed]
        row[RECORD.motor_torque] = row[RECORD.surface_torque]
    row[RECORD.surface_speed] = top.omega_o + x[d + DRIVE.speed]
    row[RECORD.bit_axial_perturbation] = x[L.bit_u]
    row[RECORD.bit_angle_perturbation] = x[L.bit_phi] if nt > 0 else x[d + DRIVE.angle]
    row[RECORD.top_axial_speed] = top.upsilon_o + x[L.top_v]
    row[RECORD.stick_time] = s.time[TIME.stuck]
    # hook load change [W*]: the hook pulls up, so it changes by minus the extra downward
    # force on the top (the set force, or the pull of the line / imposed top)
    line = top.k_a * (x[d + DRIVE.block] - x[L.u]) + top.c_a * (
        inp[INPUT.block_velocity] - top.upsilon_o - x[L.top_v])
    row[RECORD.hook_load_change] = -(inp[INPUT.axial_force] + line / top.psi)
    row[RECORD.bit_position] = bit.position
    row[RECORD.bit_angle] = bit.angle
    row[RECORD.block_position] = top.upsilon_o * tau + x[d + DRIVE.block]
    row[RECORD.top_angle_perturbation] = x[d + DRIVE.angle]
    # total angle of the top drive: the driven top node, or the prescribed motor angle
    row[RECORD.top_drive_angle] = top.omega_o * tau + (
        x[p0] if nt > 1 and top.drive_node > 0.0 else x[d + DRIVE.angle])


@entry_jit
def snapshot(m, s, row):
    """The record row of the current state, without advancing."""
    work = _work(s.x.size, m.law.offsets.size)
    _write_record(row, False, m, s, work)


@entry_jit
def advance(n_steps, h, m, s, rec):
    """Advance ``n_steps`` steps of size ``h`` (dimensionless) in place.

    ``s.time`` holds the current time and the accumulated time with the bit stuck
    angularly (both updated; the latter is exact, from the located events).  Every
    ``rec.every`` steps a row of channels is written (:class:`Recording`).  Returns on
    completion or at the first non-finite state (``counters[COUNTER.status]`` is
    ``STATUS.nonfinite``, ``counters[COUNTER.bad_index]`` the index)."""
    x = s.x
    n = x.size
    L = state_layout(m.axial.shape[1], m.torsional.shape[1])
    work = _work(n, m.law.offsets.size)
    w = _views(work)
    tau = s.time[TIME.now]
    if m.top.drive_tau <= 0.0:  # stiff speed drive: the motor speed is the command
        x[L.drive + DRIVE.speed] = s.inputs[INPUT.speed_command] - m.top.omega_o
    rhs(tau, x, w.k1, m, s, work)
    walls = m.wall.shape[1] > 0
    for _ in range(n_steps):
        tau = _step(tau, h, m, s, work)
        if walls:
            _wall(h, m, s)
            rhs(tau, x, w.k1, m, s, work)
        s.time[TIME.now] = tau
        s.counters[COUNTER.steps] += 1
        for i in range(n):
            if not np.isfinite(x[i]):
                s.counters[COUNTER.status] = STATUS.nonfinite
                s.counters[COUNTER.bad_index] = i
                return
        written = rec.written
        if rec.every > 0 and (s.counters[COUNTER.steps] % rec.every) == 0 \
                and written[0] < rec.rows.shape[0]:
            r = written[0]
            _write_record(rec.rows[r], True, m, s, work)
            if rec.states.shape[0] > r:
                for i in range(n):
                    rec.states[r, i] = x[i]
            written[0] = r + 1
