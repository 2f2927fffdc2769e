"""Jitted time-integration kernel: RK4 with event-located stick/slip transitions.

Method (one integrator for every model)
---------------------------------------
* The perturbation equations of :mod:`drill_twin.physics.models` are written as
  a first-order system ``x = [u, u', φ, φ', θ_p, ω_p, z_p]`` (:func:`layout`) and
  advanced with the classical 4th-order Runge-Kutta method.  Mass matrices are
  tridiagonal and factorised once (Thomas algorithm), or, for a Craig–Bampton reduced
  string (:mod:`drill_twin.physics.reduction`), arrow matrices solved through the 2 x 2
  Schur complement of the top and bit DOFs; either way a step costs O(n).
* The bit/rock law (:mod:`drill_twin.physics.interface_law`) is piecewise smooth.
  Within a step the interface *mode* is held fixed, so the right-hand side is
  smooth and RK4 keeps its order.  When a switching function of the mode is
  negative at the end of a step, the crossing is located by the Illinois method on
  the step's cubic Hermite interpolant of the state (the dense output of the step,
  as scipy's ``solve_ivp`` locates events), the step is redone to that instant, the
  law's transition rule applies and the mode is settled; integration goes on.  A
  stuck bit has its velocity exactly zero and is held by a Lagrange multiplier
  (Schur complement of the tridiagonal mass matrix), whose value is the reaction
  checked against the set-valued law.  No velocity threshold is involved.
* The depth of cut comes from the bottom-hole surface
  (:mod:`drill_twin.physics.bottom_surface`), written after every accepted step
  from the step's interpolant of the bit motion.

Data: the chains ``A`` (axial) and ``T`` (torsional) are packed tridiagonal
matrices (:func:`pack_chain`); the rest of the model is a few small tuples and
arrays, named in :mod:`drill_twin.physics.simulation`:

``law``   :class:`Law` — bit/rock numbers and the blade groups;
``top``   :class:`Top` — nominal motion and the couplings of the top to the drives;
``inp``   run-time inputs ``[surface speed command, axial top force, block velocity]``;
``surf, geom``  the bottom surface; ``th, thm`` the velocity history (model III).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .bottom_surface import read_surface, write_step
from .interface_law import (
    ANG_SLIP,
    ANG_STICK,
    AX_DOWN,
    AX_STUCK,
    AX_UP,
    MD_ANG,
    MD_AX,
    MD_CONTACT,
    bit_torque,
    bit_weight,
    contact_forces,
    sliding_wear_flat,
    stuck_wear_flat,
    switching,
    transition,
)
from .jit import entry_jit, kernel_jit
from .time_history import (
    N_SIGNALS,
    S_BIT_ANGULAR_SPEED,
    S_BIT_AXIAL_SPEED,
    S_MOTOR_SPEED,
    S_SURFACE_TORQUE,
    push_sample,
    sample_at_time,
)

__all__ = ['Law', 'Top', 'pack_chain', 'advance', 'snapshot', 'layout', 'RECORD_CHANNELS',
           'IN_OMEGA_CMD', 'IN_AXIAL_FORCE', 'IN_BLOCK_VELOCITY', 'N_INPUTS',
           'C_STEPS', 'C_EVENTS', 'C_IMPULSES', 'C_STATUS', 'C_BAD_INDEX', 'C_WRITES',
           'N_COUNTERS', 'STATUS_OK', 'STATUS_NONFINITE']


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


# run-time inputs ------------------------------------------------------------------------
IN_OMEGA_CMD, IN_AXIAL_FORCE, IN_BLOCK_VELOCITY = 0, 1, 2
N_INPUTS = 3
# counters -------------------------------------------------------------------------------
C_STEPS, C_EVENTS, C_IMPULSES, C_STATUS, C_BAD_INDEX, C_WRITES = 0, 1, 2, 3, 4, 5
N_COUNTERS = 6
STATUS_OK, STATUS_NONFINITE = 0, 1
# record channels (one row per recorded step), in this order ---------------------------------
RECORD_CHANNELS = ('tau', 'bit_axial_speed', 'bit_angular_speed', 'weight_on_bit',
                   'torque_on_bit', 'depth_of_cut', 'delay', 'delay_residual',
                   'angular_stick', 'axial_mode', 'contact', 'surface_torque',
                   'surface_speed', 'bit_axial_perturbation', 'bit_angle_perturbation',
                   'top_axial_speed', 'stick_time', 'hook_load_change', 'bit_position',
                   'bit_angle', 'block_position', 'top_angle_perturbation', 'top_drive_speed',
                   'motor_torque', 'top_drive_angle')
N_RECORD = len(RECORD_CHANNELS)
# aux values of the right-hand side --------------------------------------------------------
X_W, X_T, X_CUT, X_CAP, X_WREQ, X_TREQ, X_DELAY, X_RES, X_DEPTH, X_MOTOR = range(10)
N_AUX = 10
# packed chain rows ----------------------------------------------------------------------
# tridiagonal chain: the three rows (lower, diag, upper) of M, C, K, the Thomas factors and
# z = M⁻¹ e_last; arrow chain (Craig–Bampton, :mod:`~drill_twin.physics.reduction`): the top
# row, the diagonal and the bit row of M, C, K, the inverse of the boundary Schur complement
# (CH_CP[0:4]), the inverse modal masses and z.  CH_FORM[0] says which; for an arrow chain
# CH_FORM[1:3] hold the physical first element's stiffness and damping couplings K01, C01
# and CH_NODE1 the physical DOF 1 in chain coordinates (the torque at the top of the string).
CH_M, CH_C, CH_K, CH_CP, CH_INV, CH_Z, CH_FORM, CH_NODE1 = 0, 3, 6, 9, 10, 11, 12, 13
N_CHAIN_ROWS = 14
FORM_TRIDIAGONAL, FORM_ARROW = 0.0, 1.0


N_DRIVE_STATES = 5


def layout(na: int, nt: int) -> dict:
    """Slices of the state vector: axial u, u', torsional φ, φ', then the drives: set-point
    angle θ_p and speed ω_p, block z_p, the motor drive's integral ϑ_p and torque reference
    T_ref (perturbations)."""
    d = 2 * na + 2 * nt
    return {'u': slice(0, na), 'v': slice(na, 2 * na), 'phi': slice(2 * na, 2 * na + nt),
            'omega': slice(2 * na + nt, d), 'drive_angle': slice(d, d + 1),
            'drive_speed': slice(d + 1, d + 2), 'block': slice(d + 2, d + 3),
            'drive_integral': slice(d + 3, d + 4), 'torque_reference': slice(d + 4, d + 5)}


def pack_chain(chain) -> np.ndarray:
    """Pack a :class:`~drill_twin.physics.models.Chain` (tridiagonal) or a
    :class:`~drill_twin.physics.reduction.ReducedChain` (arrow) for the kernel
    (:data:`N_CHAIN_ROWS` x n), with ``z = M⁻¹ e_last`` (the compliance of the last DOF, for
    the Lagrange multiplier of a stuck bit)."""
    if chain is None:
        return np.zeros((N_CHAIN_ROWS, 0))
    n = chain.n
    out = np.zeros((N_CHAIN_ROWS, n))
    if getattr(chain, 'form', 'tridiagonal') == 'arrow':
        _pack_arrow(chain, out)
    else:
        _pack_tridiagonal(chain, out)
    z = np.empty(n)
    rest = np.zeros(n)
    accelerations(out, rest, rest, 0.0, 1.0, z)
    out[CH_Z] = z
    return out


def _pack_tridiagonal(chain, out):
    n = chain.n
    out[CH_M:CH_M + 3] = chain.mass
    out[CH_C:CH_C + 3] = chain.damping
    out[CH_K:CH_K + 3] = chain.stiffness
    lo, d, up = chain.mass
    cp = out[CH_CP]
    inv = out[CH_INV]
    for i in range(n):
        den = d[i] - (lo[i] * cp[i - 1] if i > 0 else 0.0)
        if not den > 0:
            raise ValueError('mass matrix is not positive definite')
        inv[i] = 1.0 / den
        cp[i] = up[i] * inv[i] if i < n - 1 else 0.0
    out[CH_FORM, 0] = FORM_TRIDIAGONAL


def _pack_arrow(chain, out):
    n = chain.n
    for row, A in ((CH_M, chain.mass), (CH_C, chain.damping), (CH_K, chain.stiffness)):
        out[row] = A[0]
        out[row + 1] = np.diag(A)
        out[row + 2] = A[-1]
    M = chain.mass
    d = np.diag(M)[1:-1]
    if not np.all(d > 0):
        raise ValueError('mass matrix is not positive definite')
    P = M[np.ix_([0, n - 1], range(1, n - 1))]
    schur = M[np.ix_([0, n - 1], [0, n - 1])] - (P / d) @ P.T
    if not np.all(np.linalg.eigvalsh(schur) > 0):
        raise ValueError('mass matrix is not positive definite')
    out[CH_CP, 0:4] = np.linalg.inv(schur).ravel()
    out[CH_INV, 1:-1] = 1.0 / d
    out[CH_FORM, 0] = FORM_ARROW
    full = chain.full
    out[CH_FORM, 1] = full.stiffness[2, 0]
    out[CH_FORM, 2] = full.damping[2, 0]
    out[CH_NODE1] = chain.basis[1]


@kernel_jit(inline='always')
def accelerations(ch, q, qd, f_top, f_bit, out):
    """The chain's accelerations ``out = M⁻¹ (e_top f_top + e_bit f_bit − C q̇ − K q)``:
    every external force on a chain acts on its top DOF (drives, hook load) or its bit DOF
    (the interface law).  A single mass (RGD): a few multiply-adds, inlined where they are
    used; a longer chain: :func:`_accelerations_chain`, compiled once and called (its O(n)
    loops outweigh a call, and inlining them at each of the four call sites of the
    right-hand side multiplied the kernel's compile time)."""
    n = q.size
    if n == 0:
        return
    if n == 1:      # a lumped mass (RGD): top and bit are the one DOF
        out[0] = ((-(ch[CH_C + 1, 0] * qd[0] + ch[CH_K + 1, 0] * q[0]) + f_top) + f_bit) \
            * ch[CH_INV, 0]
        return
    _accelerations_chain(ch, q, qd, f_top, f_bit, out)


@kernel_jit
def _accelerations_chain(ch, q, qd, f_top, f_bit, out):
    """:func:`accelerations` of a chain of n >= 2 DOFs: the Thomas recurrences with the
    precomputed factors of a tridiagonal chain, or :func:`_accelerations_arrow`."""
    n = q.size
    if ch[CH_FORM, 0] == FORM_ARROW:
        _accelerations_arrow(ch, q, qd, f_top, f_bit, out)
        return
    for i in range(n):
        s = ch[CH_C + 1, i] * qd[i] + ch[CH_K + 1, i] * q[i]
        if i > 0:
            s += ch[CH_C, i] * qd[i - 1] + ch[CH_K, i] * q[i - 1]
        if i < n - 1:
            s += ch[CH_C + 2, i] * qd[i + 1] + ch[CH_K + 2, i] * q[i + 1]
        out[i] = -s
    out[0] += f_top
    out[n - 1] += f_bit
    lo = ch[CH_M]
    cp = ch[CH_CP]
    inv = ch[CH_INV]
    out[0] = out[0] * inv[0]
    for i in range(1, n):
        out[i] = (out[i] - lo[i] * out[i - 1]) * inv[i]
    for i in range(n - 2, -1, -1):
        out[i] -= cp[i] * out[i + 1]


@kernel_jit(inline='always')
def _accelerations_arrow(ch, q, qd, f_top, f_bit, out):
    """:func:`accelerations` of an arrow chain ``q = [top, η_1 … η_m, bit]`` (boundary rows
    full, modes diagonal): each mode's acceleration without the boundary's inertial pull,
    ``s_j = −(C q̇ + K q)_j / M_jj`` (independent per mode); the boundary rows' forces less
    the modes' pull, summed in four interleaved partial sums (one running sum would chain
    every mode's multiply-add behind the previous one's latency); the 2 x 2 boundary Schur
    complement; then ``a_j = s_j − (M_j,top a_top + M_j,bit a_bit) / M_jj``."""
    b = q.size - 1
    m_top, m_bit, inv = ch[CH_M], ch[CH_M + 2], ch[CH_INV]
    c_top, c_diag, c_bit = ch[CH_C], ch[CH_C + 1], ch[CH_C + 2]
    k_top, k_diag, k_bit = ch[CH_K], ch[CH_K + 1], ch[CH_K + 2]
    q0, qd0, qb, qdb = q[0], qd[0], q[b], qd[b]
    for j in range(1, b):
        out[j] = -(c_diag[j] * qd[j] + k_diag[j] * q[j] + c_top[j] * qd0 + k_top[j] * q0
                   + c_bit[j] * qdb + k_bit[j] * qb) * inv[j]
    t0 = t1 = t2 = t3 = 0.0
    s0 = s1 = s2 = s3 = 0.0
    j = 1
    while j + 3 < b:
        t0 += c_top[j] * qd[j] + k_top[j] * q[j] + m_top[j] * out[j]
        s0 += c_bit[j] * qd[j] + k_bit[j] * q[j] + m_bit[j] * out[j]
        t1 += c_top[j + 1] * qd[j + 1] + k_top[j + 1] * q[j + 1] + m_top[j + 1] * out[j + 1]
        s1 += c_bit[j + 1] * qd[j + 1] + k_bit[j + 1] * q[j + 1] + m_bit[j + 1] * out[j + 1]
        t2 += c_top[j + 2] * qd[j + 2] + k_top[j + 2] * q[j + 2] + m_top[j + 2] * out[j + 2]
        s2 += c_bit[j + 2] * qd[j + 2] + k_bit[j + 2] * q[j + 2] + m_bit[j + 2] * out[j + 2]
        t3 += c_top[j + 3] * qd[j + 3] + k_top[j + 3] * q[j + 3] + m_top[j + 3] * out[j + 3]
        s3 += c_bit[j + 3] * qd[j + 3] + k_bit[j + 3] * q[j + 3] + m_bit[j + 3] * out[j + 3]
        j += 4
    while j < b:
        t0 += c_top[j] * qd[j] + k_top[j] * q[j] + m_top[j] * out[j]
        s0 += c_bit[j] * qd[j] + k_bit[j] * q[j] + m_bit[j] * out[j]
        j += 1
    r0 = f_top - (c_top[0] * qd0 + k_top[0] * q0 + c_top[b] * qdb + k_top[b] * qb) \
        - ((t0 + t1) + (t2 + t3))
    rb = f_bit - (c_bit[0] * qd0 + k_bit[0] * q0 + c_bit[b] * qdb + k_bit[b] * qb) \
        - ((s0 + s1) + (s2 + s3))
    a0 = ch[CH_CP, 0] * r0 + ch[CH_CP, 1] * rb
    ab = ch[CH_CP, 2] * r0 + ch[CH_CP, 3] * rb
    out[0] = a0
    out[b] = ab
    for j in range(1, b):
        out[j] -= (m_top[j] * a0 + m_bit[j] * ab) * inv[j]


@kernel_jit(inline='always')
def bit_totals(tau, x, top, na, nt):
    """Total bit axial position/velocity and angle/speed (U, V, Φ, Ω), dimensionless."""
    ub = top.upsilon_o * tau + x[na - 1]
    vb = top.upsilon_o + x[2 * na - 1]
    if nt > 0:
        phb = top.omega_o * tau + x[2 * na + nt - 1]
        omb = top.omega_o + x[2 * na + 2 * nt - 1]
    else:  # axial-only models: the bit turns with the prescribed drive
        d = 2 * na + 2 * nt
        phb = top.omega_o * tau + x[d]
        omb = top.omega_o + x[d + 1]
    return ub, vb, phb, omb


class Work(NamedTuple):
    """Named views of the scratch array of one integration (:func:`_work`): the RK4 stages,
    the step's end and trial states, the aux values, the blade depths,
    the switching functions and the delayed signals.

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


_SIZES_ROW = len(Work._fields)   # after one row per field: n, na, nt and the blade groups


@entry_jit
def _work(n, na, nt, groups):
    """The scratch array (one row per :class:`Work` field, then the sizes)."""
    width = max(n, N_AUX, 3 + groups, N_SIGNALS, 4)
    work = np.zeros((_SIZES_ROW + 1, width))
    work[_SIZES_ROW, 0] = n
    work[_SIZES_ROW, 1] = na
    work[_SIZES_ROW, 2] = nt
    work[_SIZES_ROW, 3] = groups
    return work


@kernel_jit(inline='always')
def _views(work):
    """The :class:`Work` views of the scratch array."""
    n = int(work[_SIZES_ROW, 0])
    groups = int(work[_SIZES_ROW, 3])
    return Work(work[0, :n], work[1, :n], work[2, :n], work[3, :n], work[4, :n], work[5, :n],
                work[6, :n], work[7, :N_AUX], work[8, :groups], work[9, :3],
                work[10, :3 + groups], work[11, :3 + groups], work[12, :N_SIGNALS],
                work[13, :N_SIGNALS], work[14, :N_SIGNALS])


@kernel_jit(inline='always')
def _depths(tau, ub, phb, law, surf, geom, w):
    """Depth of cut of every blade group (and the mean delay / worst residual in aux)."""
    delay = 0.0
    res = 0.0
    for b in range(law.offsets.size):
        read_surface(surf, geom, phb, law.offsets[b], w.read)
        w.depths[b] = ub - w.read[0]
        delay += tau - w.read[1]
        res = max(res, w.read[2])
    w.aux[X_DELAY] = delay / law.offsets.size
    w.aux[X_RES] = res


@kernel_jit
def rhs(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, dx, work):
    """Right-hand side of the first-order system in a fixed interface mode; fills ``dx`` and
    the aux values (forces, reactions the law checks, delay)."""
    w = _views(work)
    _rhs(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, dx, w)


@kernel_jit(inline='always')
def _rhs(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, dx, w):
    """:func:`rhs`, inlined where it is called every stage (RK4, switching functions)."""
    na = A.shape[1]
    nt = T.shape[1]
    d = 2 * na + 2 * nt
    ub, vb, phb, omb = bit_totals(tau, x, top, na, nt)
    _depths(tau, ub, phb, law, surf, geom, w)
    cut, cap = contact_forces(w.depths, law.weights, mode, law.lam)
    w.aux[X_CUT] = cut
    w.aux[X_CAP] = cap
    n_b = 0.0
    for b in range(law.weights.size):
        n_b += law.weights[b]
    mean_depth = 0.0
    for b in range(law.weights.size):
        mean_depth += law.weights[b] * w.depths[b]
    w.aux[X_DEPTH] = mean_depth / n_b
    # drives: motor angle/speed perturbation θ_p, ω_p (first-order lag or stiff); block z_p
    om_p = x[d + 1]
    om_p_dot = (inp[IN_OMEGA_CMD] - top.omega_o - om_p) / top.drive_tau \
        if top.drive_tau > 0.0 else 0.0
    z_p_dot = inp[IN_BLOCK_VELOCITY] - top.upsilon_o
    dx[d] = om_p
    dx[d + 1] = om_p_dot
    dx[d + 2] = z_p_dot
    dx[d + 3] = 0.0
    dx[d + 4] = 0.0
    _axial(tau, x, mode, law, top, inp, A, th, thm, cut, cap, z_p_dot, dx, w)
    w_f = w.aux[X_W] - cut
    if nt > 0:
        _torsional(tau, x, mode, law, top, inp, T, th, thm, cut, w_f, om_p, om_p_dot, dx,
                   w, na)
    else:
        w.aux[X_T] = bit_torque(cut, w_f, law.beta)
        w.aux[X_TREQ] = w.aux[X_T]


@kernel_jit(inline='always')
def _axial(tau, x, mode, law, top, inp, A, th, thm, cut, cap, z_p_dot, dx, w):
    na = A.shape[1]
    nt_off = x.size - N_DRIVE_STATES  # the drive block starts at 2 na + 2 nt
    psi = top.psi
    u = x[0:na]
    v = x[na:2 * na]
    ya = dx[na:2 * na]
    f_top = psi * inp[IN_AXIAL_FORCE] + top.k_a * x[nt_off + 2] + top.c_a * z_p_dot
    if top.z_a > 0.0:
        # lumped model III: pipe force = radiation force of the bit velocity one wave round
        # trip earlier (single-mass chains: DOF 0 is the bit)
        sample_at_time(th, thm, tau - top.tau_a, w.delayed)
        f_top -= top.z_a * (w.delayed[S_BIT_AXIAL_SPEED] - top.upsilon_o)
    if mode[MD_AX] == AX_STUCK:
        accelerations(A, u, v, f_top, 0.0, ya)
        lam_c = ya[na - 1] / A[CH_Z, na - 1]
        w_req = top.W_o + lam_c / psi
        for i in range(na):
            ya[i] -= lam_c * A[CH_Z, i]
        ya[na - 1] = 0.0
        w_bit = w_req
    else:
        w_bit = bit_weight(cut, sliding_wear_flat(mode[MD_AX], cap))
        accelerations(A, u, v, f_top, -psi * (w_bit - top.W_o), ya)
        # the reaction a stuck bit would need (for the switching functions)
        w_req = top.W_o + (ya[na - 1] / A[CH_Z, na - 1]) / psi + (w_bit - top.W_o)
    for i in range(na):
        dx[i] = v[i]
    w.aux[X_W] = w_bit
    w.aux[X_WREQ] = w_req


@kernel_jit(inline='always')
def surface_torque_perturbation(x, T, na):
    """Perturbation of the torque in the string's first element (a free top node: the
    motor or the Soft-Torque drive), units C."""
    nt = T.shape[1]
    p0, w0 = 2 * na, 2 * na + nt
    if T[CH_FORM, 0] != FORM_ARROW:
        return -T[CH_K + 2, 0] * (x[p0] - x[p0 + 1]) - T[CH_C + 2, 0] * (x[w0] - x[w0 + 1])
    node1 = T[CH_NODE1]                 # node 1 is a combination of the chain's DOFs
    p1 = 0.0
    w1 = 0.0
    for j in range(nt):
        p1 += node1[j] * x[p0 + j]
        w1 += node1[j] * x[w0 + j]
    return -T[CH_FORM, 1] * (x[p0] - p1) - T[CH_FORM, 2] * (x[w0] - w1)


@kernel_jit(inline='always')
def _motor_drive(tau, x, top, T, th, thm, om_p, dx, w, na):
    """Motor torque of the PI top drive (total, units C) and the derivatives of its
    integral ϑ_p and torque reference T_ref (docs/control.md, eqs C.1-C.4): sensors
    delayed by ``t_delay``, torque feedback ``g_t``, limit ``t_max``, back-calculation
    anti-windup with tracking time kp/ki."""
    nt = T.shape[1]
    d = 2 * na + 2 * nt
    if top.t_delay > 0.0:
        sample_at_time(th, thm, tau - top.t_delay, w.delayed)
        speed = w.delayed[S_MOTOR_SPEED]
        torque = w.delayed[S_SURFACE_TORQUE]
    else:
        speed = x[2 * na + nt]
        torque = surface_torque_perturbation(x, T, na)
    error = om_p - top.g_t * (torque - x[d + 4]) - speed
    demand = top.T_o + top.kp * error + top.ki * x[d + 3]
    motor = min(max(demand, -top.t_max), top.t_max)
    dx[d + 3] = error + (motor - demand) / top.kp
    dx[d + 4] = (torque - x[d + 4]) / top.t_filter if top.t_filter > 0.0 else 0.0
    w.aux[X_MOTOR] = motor
    return motor


@kernel_jit(inline='always')
def _torsional(tau, x, mode, law, top, inp, T, th, thm, cut, w_f, om_p, om_p_dot, dx, w, na):
    nt = T.shape[1]
    d = 2 * na + 2 * nt
    ph = x[2 * na:2 * na + nt]
    om = x[2 * na + nt:d]
    yt = dx[2 * na + nt:d]
    f_top = top.k_t * x[d] + top.c_t * om_p + top.m_t * om_p_dot
    if top.drive_pi > 0.0:
        f_top += _motor_drive(tau, x, top, T, th, thm, om_p, dx, w, na) - top.T_o
    if top.z_t > 0.0:
        sample_at_time(th, thm, tau - top.tau_t, w.delayed)
        f_top -= top.z_t * (w.delayed[S_BIT_ANGULAR_SPEED] - top.omega_o)
    if mode[MD_ANG] == ANG_STICK:
        accelerations(T, ph, om, f_top, 0.0, yt)
        lam_c = yt[nt - 1] / T[CH_Z, nt - 1]
        t_req = top.T_o + lam_c
        for i in range(nt):
            yt[i] -= lam_c * T[CH_Z, i]
        yt[nt - 1] = 0.0
        t_bit = t_req
    else:
        t_bit = bit_torque(cut, w_f, law.beta)
        accelerations(T, ph, om, f_top, -(t_bit - top.T_o), yt)
        t_req = t_bit + yt[nt - 1] / T[CH_Z, nt - 1]
    for i in range(nt):
        dx[2 * na + i] = om[i]
    w.aux[X_T] = t_bit
    w.aux[X_TREQ] = t_req


@kernel_jit
def _switching_at(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, dx, work, g):
    """Evaluate the right-hand side (for the reactions) and the switching functions (at an
    interpolated state, while an event is located)."""
    rhs(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, dx, work)
    return _switching(tau, x, mode, law, top, A, T, work, g)


@kernel_jit
def _switching(tau, x, mode, law, top, A, T, work, g):
    """The switching functions of the state ``x`` whose right-hand side was just evaluated
    (its aux values are in the work array); returns the smallest."""
    w = _views(work)
    na = A.shape[1]
    nt = T.shape[1]
    ub, vb, phb, omb = bit_totals(tau, x, top, na, nt)
    switching(mode, omb, vb, w.depths, w.aux[X_CUT], w.aux[X_CAP], law.beta, w.aux[X_WREQ],
              w.aux[X_TREQ], nt > 0, g)
    gmin = g[0]
    for k in range(1, g.size):
        gmin = min(gmin, g[k])
    return gmin


@kernel_jit
def _rk4(tau, x, h, k1, mode, law, top, inp, A, T, surf, geom, th, thm, out, work):
    """One classical RK4 step of size ``h`` from (tau, x) with ``k1 = f(tau, x)``: stages
    k2, k3, k4 at (tau + h/2, x + h/2 k1), (tau + h/2, x + h/2 k2), (tau + h, x + h k3),
    the step's end ``out``, and f at the end into ``w.k4`` (with the aux values there: what
    the switching functions and the next step need) — four evaluations through one call
    site of the inlined right-hand side, the only one in the stepping path."""
    w = _views(work)
    n = x.size
    tmp = w.tmp
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
        _rhs(tau + c * h, point, mode, law, top, inp, A, T, surf, geom, th, thm,
             stages[min(stage, 3)], w)


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
def _locate(tau, x, h, k_start, k_end, g_end, mode, law, top, inp, A, T, surf, geom, th,
            thm, work):
    """Fraction of the step at which the smallest switching function reaches zero: the
    Illinois method on the step's interpolant (``w.x_end`` is the state at the end)."""
    w = _views(work)
    s_lo = 0.0
    g_lo = _switching_at(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, w.tmp, work,
                         w.g_lo)
    s_hi = 1.0
    g_hi = g_end
    side = 0
    for _ in range(80):
        if s_hi - s_lo < 1e-10:
            break
        s = s_lo + (s_hi - s_lo) * g_lo / (g_lo - g_hi) if g_lo > 0.0 else 0.5 * (s_lo + s_hi)
        if not (s_lo < s < s_hi):
            s = 0.5 * (s_lo + s_hi)
        _interpolate(x, w.x_end, k_start, k_end, h, s, w.x_try)
        gs = _switching_at(tau + s * h, w.x_try, mode, law, top, inp, A, T, surf, geom, th,
                           thm, w.tmp, work, w.g)
        if gs >= 0.0:
            s_lo, g_lo = s, gs
            if side == -1:
                g_hi *= 0.5
            side = -1
        else:
            s_hi, g_hi = s, gs
            if side == 1:
                g_lo *= 0.5
            side = 1
    return s_hi


@kernel_jit
def _commit(tau0, x0, f0, tau1, x1, f1, law, top, T, surf, geom, th, thm, counters, na, nt,
            start, work):
    """After an accepted (sub)step: the blades write the surface they swept, and the bit
    velocities go into the time history (model III).  ``start[4] == 1``: the step began
    at an instantaneous perturbation; the rock it swept is written from the bit motion
    before it, ``start[:4] = (U, V, Φ, Ω)`` (the end of the DDE's initial function), and the
    flag is cleared."""
    u0, v0, p0, o0 = bit_totals(tau0, x0, top, na, nt)
    if start[4] > 0.0:
        u0, v0, p0, o0 = start[0], start[1], start[2], start[3]
        start[4] = 0.0
    u1, v1, p1, o1 = bit_totals(tau1, x1, top, na, nt)
    counters[C_WRITES] += write_step(surf, geom, law.offsets, tau0, tau1, u0, u1, p0, p1,
                                     v0, v1, o0, o1)
    if top.z_a > 0.0 or top.z_t > 0.0 or top.t_delay > 0.0:
        _push_history(th, thm, tau1, x1, f1, v1, o1, top, T, na, nt, work)


@kernel_jit
def _push_history(th, thm, tau1, x1, f1, v1, o1, top, T, na, nt, work):
    """Append the delayed signals (time_history.SIGNALS) at the end of a step: the
    surface torque's slope is that of the first element's torque, from the state slope
    ``f1``."""
    w = _views(work)
    ib = 2 * na + 2 * nt - 1 if nt > 0 else 2 * na + 2 * nt + 1
    values, slopes = w.values, w.slopes
    values[S_BIT_AXIAL_SPEED], slopes[S_BIT_AXIAL_SPEED] = v1, f1[2 * na - 1]
    values[S_BIT_ANGULAR_SPEED], slopes[S_BIT_ANGULAR_SPEED] = o1, f1[ib]
    if top.drive_pi > 0.0 and nt > 1:
        w0 = 2 * na + nt
        values[S_MOTOR_SPEED], slopes[S_MOTOR_SPEED] = x1[w0], f1[w0]
        values[S_SURFACE_TORQUE] = surface_torque_perturbation(x1, T, na)
        slopes[S_SURFACE_TORQUE] = surface_torque_perturbation(f1, T, na)
    push_sample(th, thm, tau1, values, slopes)


@kernel_jit(inline='always')
def _any_contact(mode, groups):
    for b in range(groups):
        if mode[MD_CONTACT + b] == 1:
            return True
    return False


@kernel_jit
def _settle(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, counters, work):
    """Choose the interface mode consistent with the state after an event (called with the
    velocity that crossed zero already set exactly to zero)."""
    w = _views(work)
    na = A.shape[1]
    nt = T.shape[1]
    dx = w.k1
    if not _any_contact(mode, law.offsets.size):
        # off bottom the interface law has nothing to hold: free motion both ways
        ub, vb, phb, omb = bit_totals(tau, x, top, na, nt)
        mode[MD_ANG] = ANG_SLIP
        mode[MD_AX] = AX_UP if vb < 0.0 else AX_DOWN
        rhs(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, w.k1, work)
        return
    for _ in range(4):
        old_ang = mode[MD_ANG]
        old_ax = mode[MD_AX]
        ub, vb, phb, omb = bit_totals(tau, x, top, na, nt)
        if nt > 0 and mode[MD_ANG] == ANG_SLIP and omb <= 0.0:
            x[2 * na + 2 * nt - 1] = -top.omega_o
            mode[MD_ANG] = ANG_STICK
        if mode[MD_ANG] == ANG_STICK:
            if vb > 0.0:  # no drilling without rotation: inelastic stop of the bit
                zb = A[CH_Z, na - 1]
                for i in range(na):
                    x[na + i] -= vb / zb * A[CH_Z, i]
                x[2 * na - 1] = -top.upsilon_o
                counters[C_IMPULSES] += 1
                vb = 0.0
            if vb == 0.0:
                mode[MD_AX] = AX_STUCK
                rhs(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, dx, work)
                if w.aux[X_WREQ] < 0.0:
                    mode[MD_AX] = AX_UP
            # release check of the angular stick
            rhs(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, dx, work)
            cut, cap = w.aux[X_CUT], w.aux[X_CAP]
            w_f = stuck_wear_flat(w.aux[X_WREQ], cut, cap) if mode[MD_AX] == AX_STUCK \
                else 0.0
            if w.aux[X_TREQ] > bit_torque(cut, w_f, law.beta):
                mode[MD_ANG] = ANG_SLIP
        if mode[MD_ANG] == ANG_SLIP:
            if vb == 0.0:
                mode[MD_AX] = AX_STUCK
                rhs(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, dx, work)
                w_f = w.aux[X_WREQ] - w.aux[X_CUT]
                if _any_contact(mode, law.offsets.size):  # some blade on the rock
                    if w_f < 0.0:
                        mode[MD_AX] = AX_UP
                    elif w_f > w.aux[X_CAP]:
                        mode[MD_AX] = AX_DOWN
                else:
                    mode[MD_AX] = AX_DOWN if w.aux[X_WREQ] > 0.0 else AX_UP
            elif vb > 0.0:
                mode[MD_AX] = AX_DOWN
            else:
                mode[MD_AX] = AX_UP
        if mode[MD_ANG] == old_ang and mode[MD_AX] == old_ax:
            break
    rhs(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, w.k1, work)


@kernel_jit
def _apply_transition(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, counters, work):
    """At a located event: the rule of the violated switching function, then settle."""
    w = _views(work)
    na = A.shape[1]
    nt = T.shape[1]
    g = w.g
    k = 0
    for j in range(1, g.size):
        if g[j] < g[k]:
            k = j
    stop_rotation, stop_descent = transition(k, mode, w.aux[X_WREQ])
    if stop_rotation:
        x[2 * na + 2 * nt - 1] = -top.omega_o
    if stop_descent:
        x[2 * na - 1] = -top.upsilon_o
    _settle(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, counters, work)


@kernel_jit
def _step(tau, x, h, mode, law, top, inp, A, T, surf, geom, th, thm, counters, tau_arr,
          start, work):
    """Advance one step of size ``h``, cut at the events inside it (at most 20: a 20th is
    accepted, no Zeno loop).  ``w.k1`` holds f(tau, x) on entry and on exit."""
    w = _views(work)
    na = A.shape[1]
    nt = T.shape[1]
    n = x.size
    remaining = h
    for sub in range(20):
        _rk4(tau, x, remaining, w.k1, mode, law, top, inp, A, T, surf, geom, th, thm,
             w.x_end, work)
        gmin = _switching(tau + remaining, w.x_end, mode, law, top, A, T, work, w.g)
        if gmin >= 0.0 or sub == 19:
            _commit(tau, x, w.k1, tau + remaining, w.x_end, w.k4, law, top, T, surf, geom, th,
                    thm, counters, na, nt, start, work)
            if mode[MD_ANG] == ANG_STICK:
                tau_arr[1] += remaining
            for i in range(n):
                x[i] = w.x_end[i]
                w.k1[i] = w.k4[i]
            return tau + remaining
        # an event inside the step: locate it on the interpolant, redo the step to it
        for i in range(n):
            w.k3[i] = w.k4[i]  # f at the step end, for the interpolant
        s = _locate(tau, x, remaining, w.k1, w.k3, gmin, mode, law, top, inp, A, T, surf,
                    geom, th, thm, work)
        dt = s * remaining
        _rk4(tau, x, dt, w.k1, mode, law, top, inp, A, T, surf, geom, th, thm, w.x_end, work)
        _switching(tau + dt, w.x_end, mode, law, top, A, T, work, w.g)
        _commit(tau, x, w.k1, tau + dt, w.x_end, w.k4, law, top, T, surf, geom, th, thm,
                counters, na, nt, start, work)
        for i in range(n):
            x[i] = w.x_end[i]
        if mode[MD_ANG] == ANG_STICK:
            tau_arr[1] += dt
        tau += dt
        remaining -= dt
        counters[C_EVENTS] += 1
        _apply_transition(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, counters,
                          work)
        if remaining <= 1e-12 * h:
            break
    return tau


@kernel_jit
def _write_record(tau, stick_time, x, mode, law, top, inp, A, T, surf, geom, th, thm, work, row,
                  evaluated):
    """Fill one record row (:data:`RECORD_CHANNELS`) from the current state.  ``evaluated``:
    the aux values already belong to this state (every step ends with a right-hand side at
    its final state and mode — the switching check or the settling after an event — and the
    surface a step writes is read with the values from before the write), so the
    right-hand side is not evaluated again."""
    w = _views(work)
    na = A.shape[1]
    nt = T.shape[1]
    d = 2 * na + 2 * nt
    if not evaluated:
        rhs(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, w.tmp, work)
    ub, vb, phb, omb = bit_totals(tau, x, top, na, nt)
    row[0] = tau
    row[1] = vb
    row[2] = omb
    row[3] = w.aux[X_W]
    row[4] = w.aux[X_T]
    row[5] = w.aux[X_DEPTH]
    row[6] = w.aux[X_DELAY]
    row[7] = w.aux[X_RES]
    row[8] = mode[MD_ANG]
    row[9] = mode[MD_AX]
    contact = 0
    for b in range(law.offsets.size):
        contact += mode[MD_CONTACT + b]
    row[10] = 1.0 if contact > 0 else 0.0
    p0, w0 = 2 * na, 2 * na + nt      # top torsional DOF: angle, speed
    if nt > 1 and top.drive_node > 0.0:  # torque in the string's first element
        row[11] = top.T_o + surface_torque_perturbation(x, T, na)
        row[22] = top.omega_o + x[w0]
        # the motor's torque: the PI drive's, or the Soft-Torque spring and dash-pot's
        row[23] = w.aux[X_MOTOR] if top.drive_pi > 0.0 else \
            top.T_o + top.k_t * (x[d] - x[p0]) + top.c_t * (x[d + 1] - x[w0])
    elif nt > 0:                        # the coupling to the prescribed top
        row[11] = top.T_o + top.k_t * (x[d] - x[p0]) + top.c_t * (x[d + 1] - x[w0])
        row[22] = top.omega_o + x[d + 1]
        row[23] = row[11]
    else:
        row[11] = w.aux[X_T]
        row[22] = top.omega_o + x[d + 1]
        row[23] = row[11]
    row[12] = top.omega_o + x[d + 1]
    row[13] = x[na - 1]
    row[14] = x[2 * na + nt - 1] if nt > 0 else x[d]
    row[15] = top.upsilon_o + x[na]
    row[16] = stick_time
    # hook load change [W*]: the hook pulls up, so it changes by minus the extra downward
    # force on the top (the set force, or the pull of the line / imposed top)
    line = top.k_a * (x[d + 2] - x[0]) + top.c_a * (inp[IN_BLOCK_VELOCITY] - top.upsilon_o
                                                    - x[na])
    row[17] = -(inp[IN_AXIAL_FORCE] + line / top.psi)
    row[18] = ub
    row[19] = phb
    row[20] = top.upsilon_o * tau + x[d + 2]
    row[21] = x[d]
    # total angle of the top drive: the driven top node, or the prescribed motor angle
    row[24] = top.omega_o * tau + (x[p0] if nt > 1 and top.drive_node > 0.0 else x[d])


@entry_jit
def snapshot(tau_arr, x, mode, law, top, inp, A, T, surf, geom, th, thm, row):
    """The record row of the current state, without advancing."""
    na = A.shape[1]
    nt = T.shape[1]
    work = _work(x.size, na, nt, law.offsets.size)
    _write_record(tau_arr[0], tau_arr[1], x, mode, law, top, inp, A, T, surf, geom, th, thm,
                  work, row, False)


@entry_jit
def advance(n_steps, h, tau_arr, x, mode, law, top, inp, A, T, surf, geom, th, thm, counters,
            start, record, record_every, n_rec, state_record):
    """Advance ``n_steps`` steps of size ``h`` (dimensionless) in place.

    ``tau_arr[0]`` is the current time and ``tau_arr[1]`` the accumulated time with
    the bit stuck angularly (both updated; the latter is exact, from the located
    events).  ``start``: see :func:`_commit`.  Every ``record_every`` steps a row of
    :data:`RECORD_CHANNELS` is written to
    ``record`` (and the full state to ``state_record`` if it has rows); ``n_rec[0]``
    counts the rows written.  Returns on completion or at the first non-finite state
    (``counters[C_STATUS] = STATUS_NONFINITE``, ``counters[C_BAD_INDEX]`` the index).
    """
    na = A.shape[1]
    nt = T.shape[1]
    n = x.size
    d = 2 * na + 2 * nt
    work = _work(n, na, nt, law.offsets.size)
    w = _views(work)
    tau = tau_arr[0]
    if top.drive_tau <= 0.0:  # stiff speed drive: the motor speed is the command
        x[d + 1] = inp[IN_OMEGA_CMD] - top.omega_o
    rhs(tau, x, mode, law, top, inp, A, T, surf, geom, th, thm, w.k1, work)
    for _ in range(n_steps):
        tau = _step(tau, x, h, mode, law, top, inp, A, T, surf, geom, th, thm, counters,
                    tau_arr, start, work)
        counters[C_STEPS] += 1
        for i in range(n):
            if not np.isfinite(x[i]):
                counters[C_STATUS] = STATUS_NONFINITE
                counters[C_BAD_INDEX] = i
                tau_arr[0] = tau
                return
        if record_every > 0 and (counters[C_STEPS] % record_every) == 0 \
                and n_rec[0] < record.shape[0]:
            r = n_rec[0]
            _write_record(tau, tau_arr[1], x, mode, law, top, inp, A, T, surf, geom, th, thm,
                          work, record[r], True)
            if state_record.shape[0] > r:
                for i in range(n):
                    state_record[r, i] = x[i]
            n_rec[0] = r + 1
    tau_arr[0] = tau
