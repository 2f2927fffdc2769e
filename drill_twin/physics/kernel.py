"""Jitted time-integration kernel: RK4 with event-located bit stick/slip transitions.

Method (one integrator for every model)
---------------------------------------
* The perturbation equations of :mod:`drill_twin.physics.models` are written
  as a first-order system ``x = [u, u', φ, φ', θ_p, ω_p]`` and advanced with the
  classical 4th-order Runge-Kutta method.  Mass matrices are tridiagonal and
  factorised once (Thomas algorithm), so a step costs O(n).
* The bit/rock law is piecewise smooth.  Within a step the *mode* of the
  interface (angular slip/stick, axial down/up/stuck, contact yes/no) is held
  fixed, so the right-hand side is smooth and RK4 keeps its order.  Each mode
  has switching functions ``g >= 0`` (bit speed, reaction force minus its
  bounds, depth of cut).  When one becomes negative at the end of a step, the
  crossing is located by the Illinois (modified regula falsi) method, re-
  integrating from the step start, to 1e-10 of the step; the step is cut
  there, the mode is changed and the integration goes on.  No velocity
  threshold is involved: a stuck bit has its velocity exactly zero and is held
  by a Lagrange multiplier (Schur complement of the tridiagonal mass matrix),
  whose value is the reaction force checked against the set-valued law.
* Stick rules (thesis §3.3): angular stick when the bit speed reaches zero and
  the string torque does not exceed the bit's resisting torque ``n_b δ + β W_f``;
  no backward rotation; no drilling while stuck angularly (the rock blocks
  downward motion, so a bit moving down is stopped by an inelastic impulse,
  reported in the diagnostics); axial stick while ``0 <= W - W_c <= n_b λ``;
  lift-off (W_f < 0) and bit bounce (depth of cut <= 0: no contact at all).
* The delayed state comes from :mod:`drill_twin.physics.delay_history`.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .delay_history import delayed_state, push_sample, velocities_at_time
from .interface_law import bit_torque, bit_weight, cutting_force, wear_flat_force

# parameter vector layout ------------------------------------------------------------
P_NB, P_LAM, P_BETA, P_OMEGA, P_UPS, P_WO, P_TO, P_PSI = 0, 1, 2, 3, 4, 5, 6, 7
P_KTOP_A, P_CTOP_A, P_KTOP_T, P_CTOP_T, P_MTOP_T, P_DRIVE_TAU = 8, 9, 10, 11, 12, 13
P_ZDEL_A, P_TDEL_A, P_ZDEL_T, P_TDEL_T = 14, 15, 16, 17  # delayed dash-pots (model III)
N_PARAMS = 18
# run-time inputs ----------------------------------------------------------------------
IN_OMEGA_CMD, IN_AXIAL_FORCE, IN_MOTOR_TORQUE = 0, 1, 2
N_INPUTS = 3
# mode vector --------------------------------------------------------------------------
MD_ANG, MD_AX, MD_CONTACT = 0, 1, 2
ANG_SLIP, ANG_STICK = 0, 1
AX_DOWN, AX_UP, AX_STUCK = 0, 1, 2
# aux outputs of the right-hand side ---------------------------------------------------
AX_W, AX_T, AX_DELTA, AX_TAU1, AX_RES, AX_CUT, AX_WREQ, AX_TREQ = 0, 1, 2, 3, 4, 5, 6, 7
N_AUX = 8
# counters -----------------------------------------------------------------------------
C_STEPS, C_EVENTS, C_IMPULSES, C_STATUS, C_BAD_INDEX = 0, 1, 2, 3, 4
N_COUNTERS = 5
STATUS_OK, STATUS_NONFINITE = 0, 1
# record columns -----------------------------------------------------------------------
R_TAU, R_V, R_OMEGA, R_W, R_T, R_DELTA, R_TAU1, R_RES = 0, 1, 2, 3, 4, 5, 6, 7
R_ANG, R_AX, R_CONTACT, R_TSURF, R_OMSURF, R_UBIT, R_PHIBIT, R_VTOP = 8, 9, 10, 11, 12, 13, 14, 15
R_STICK_TIME = 16
N_RECORD = 17
# packed chain rows --------------------------------------------------------------------
CH_M, CH_C, CH_K, CH_CP, CH_INV, CH_Z = 0, 3, 6, 9, 10, 11
N_CHAIN_ROWS = 12


def pack_chain(chain) -> np.ndarray:
    """Pack a :class:`~drill_twin.physics.models.Chain` for the kernel (12 x n)."""
    if chain is None:
        return np.zeros((N_CHAIN_ROWS, 0))
    n = chain.n
    out = np.zeros((N_CHAIN_ROWS, n))
    out[CH_M:CH_M + 3] = chain.mass
    out[CH_C:CH_C + 3] = chain.damping
    out[CH_K:CH_K + 3] = chain.stiffness
    lo, d, up = chain.mass
    cp = np.zeros(n)
    inv = np.zeros(n)
    for i in range(n):
        den = d[i] - (lo[i] * cp[i - 1] if i > 0 else 0.0)
        if not den > 0:
            raise ValueError('mass matrix is not positive definite')
        inv[i] = 1.0 / den
        cp[i] = up[i] * inv[i] if i < n - 1 else 0.0
    out[CH_CP] = cp
    out[CH_INV] = inv
    e = np.zeros(n)
    e[-1] = 1.0
    z = np.empty(n)
    _solve(out, e, z)
    out[CH_Z] = z
    return out


@njit(cache=True, nogil=True)
def _solve(ch, r, out):
    """Solve the tridiagonal system M out = r with the precomputed Thomas factors."""
    n = r.size
    if n == 0:
        return
    lo = ch[CH_M]
    cp = ch[CH_CP]
    inv = ch[CH_INV]
    out[0] = r[0] * inv[0]
    for i in range(1, n):
        out[i] = (r[i] - lo[i] * out[i - 1]) * inv[i]
    for i in range(n - 2, -1, -1):
        out[i] -= cp[i] * out[i + 1]


@njit(cache=True, nogil=True)
def _internal_force(ch, q, qd, out):
    """out = -(C qd + K q) for a tridiagonal chain."""
    n = q.size
    for i in range(n):
        s = ch[CH_C + 1, i] * qd[i] + ch[CH_K + 1, i] * q[i]
        if i > 0:
            s += ch[CH_C, i] * qd[i - 1] + ch[CH_K, i] * q[i - 1]
        if i < n - 1:
            s += ch[CH_C + 2, i] * qd[i + 1] + ch[CH_K + 2, i] * q[i + 1]
        out[i] = -s


@njit(cache=True, nogil=True)
def bit_totals(tau, x, P, na, nt):
    """Total bit axial position/velocity and angle/speed (U, V, Φ, Ω), dimensionless."""
    ub = P[P_UPS] * tau + x[na - 1]
    vb = P[P_UPS] + x[2 * na - 1]
    ith = 2 * na + 2 * nt
    if nt > 0:
        phb = P[P_OMEGA] * tau + x[2 * na + nt - 1]
        omb = P[P_OMEGA] + x[2 * na + 2 * nt - 1]
    else:
        phb = P[P_OMEGA] * tau + x[ith]
        omb = P[P_OMEGA] + x[ith + 1]
    return ub, vb, phb, omb


@njit(cache=True, nogil=True)
def rhs(tau, x, mode, P, IN, A, T, hist, meta, dx, aux, ra, ya, rt, yt, dstate):
    """Right-hand side of the first-order system in a fixed interface mode."""
    na = A.shape[1]
    nt = T.shape[1]
    ith = 2 * na + 2 * nt
    n_b = P[P_NB]
    ub, vb, phb, omb = bit_totals(tau, x, P, na, nt)
    delayed_state(hist, meta, phb - 2.0 * np.pi / n_b, dstate)
    delta = ub - dstate[1]
    contact = mode[MD_CONTACT] == 1
    cut = cutting_force(delta, n_b, contact)
    aux[AX_DELTA] = delta
    aux[AX_TAU1] = tau - dstate[0]
    aux[AX_RES] = dstate[2]
    aux[AX_CUT] = cut
    # drive (prescribed top angle perturbation θ_p, speed perturbation ω_p)
    om_p = x[ith + 1]
    if P[P_DRIVE_TAU] > 0.0:
        om_p_dot = (IN[IN_OMEGA_CMD] - P[P_OMEGA] - om_p) / P[P_DRIVE_TAU]
    else:
        om_p_dot = 0.0
    dx[ith] = om_p
    dx[ith + 1] = om_p_dot
    # axial chain
    psi = P[P_PSI]
    u = x[0:na]
    v = x[na:2 * na]
    _internal_force(A, u, v, ra)
    ra[0] += psi * IN[IN_AXIAL_FORCE]
    z_t_delayed = 0.0
    if P[P_ZDEL_A] > 0.0 or P[P_ZDEL_T] > 0.0:
        # lumped model III: pipe force = radiation force of the bit velocity one wave
        # round trip earlier (single-mass chains: DOF 0 is the bit)
        velocities_at_time(hist, meta, tau - P[P_TDEL_A], dstate)
        ra[0] -= P[P_ZDEL_A] * (dstate[0] - P[P_UPS])
        velocities_at_time(hist, meta, tau - P[P_TDEL_T], dstate)
        z_t_delayed = P[P_ZDEL_T] * (dstate[1] - P[P_OMEGA])
    if mode[MD_AX] == AX_STUCK:
        _solve(A, ra, ya)
        lam_c = ya[na - 1] / A[CH_Z, na - 1]
        w_req = P[P_WO] + lam_c / psi
        for i in range(na):
            ya[i] -= lam_c * A[CH_Z, i]
        ya[na - 1] = 0.0
        w_bit = w_req
        w_f = w_req - cut
    else:
        w_f = wear_flat_force(mode[MD_AX] == AX_DOWN, contact, n_b, P[P_LAM])
        w_bit = bit_weight(cut, w_f)
        ra[na - 1] -= psi * (w_bit - P[P_WO])
        _solve(A, ra, ya)
        # the reaction a stuck bit would need (for the event functions)
        w_req = P[P_WO] + (ya[na - 1] / A[CH_Z, na - 1]) / psi + (w_bit - P[P_WO])
    for i in range(na):
        dx[i] = v[i]
        dx[na + i] = ya[i]
    aux[AX_W] = w_bit
    aux[AX_WREQ] = w_req
    # torsional chain
    if nt > 0:
        ph = x[2 * na:2 * na + nt]
        w = x[2 * na + nt:ith]
        _internal_force(T, ph, w, rt)
        rt[0] += (P[P_KTOP_T] * x[ith] + P[P_CTOP_T] * om_p + P[P_MTOP_T] * om_p_dot
                  + IN[IN_MOTOR_TORQUE] - z_t_delayed)
        if mode[MD_ANG] == ANG_STICK:
            _solve(T, rt, yt)
            lam_c = yt[nt - 1] / T[CH_Z, nt - 1]
            t_req = P[P_TO] + lam_c
            for i in range(nt):
                yt[i] -= lam_c * T[CH_Z, i]
            yt[nt - 1] = 0.0
            t_bit = t_req
        else:
            t_bit = bit_torque(cut, w_f, P[P_BETA])
            rt[nt - 1] -= t_bit - P[P_TO]
            _solve(T, rt, yt)
            t_req = t_bit + yt[nt - 1] / T[CH_Z, nt - 1]
        for i in range(nt):
            dx[2 * na + i] = w[i]
            dx[2 * na + nt + i] = yt[i]
        aux[AX_T] = t_bit
        aux[AX_TREQ] = t_req
    else:
        aux[AX_T] = bit_torque(cut, w_f, P[P_BETA])
        aux[AX_TREQ] = aux[AX_T]


@njit(cache=True, nogil=True)
def _switching(tau, x, mode, P, aux, na, nt, g):
    """Switching functions of the current mode; the mode is valid while all g >= 0."""
    ub, vb, phb, omb = bit_totals(tau, x, P, na, nt)
    big = 1e300
    g[0] = big
    g[1] = big
    g[2] = big
    g[3] = big
    n_b_lam = P[P_NB] * P[P_LAM]
    cut = aux[AX_CUT]
    contact = mode[MD_CONTACT] == 1
    ax = mode[MD_AX]
    if ax == AX_STUCK:
        w_f = min(max(aux[AX_WREQ] - cut, 0.0), n_b_lam)
    elif ax == AX_DOWN and contact:
        w_f = n_b_lam
    else:
        w_f = 0.0
    if nt > 0:
        if mode[MD_ANG] == ANG_SLIP:
            g[0] = omb
        else:
            g[0] = cut + P[P_BETA] * w_f - aux[AX_TREQ]
    if ax == AX_DOWN:
        g[1] = vb
    elif ax == AX_UP:
        g[1] = -vb
    else:
        if mode[MD_ANG] == ANG_STICK:
            g[1] = aux[AX_WREQ]
        else:
            g[1] = aux[AX_WREQ] - cut
            g[2] = n_b_lam - (aux[AX_WREQ] - cut)
    if mode[MD_ANG] == ANG_SLIP or ax == AX_UP:
        g[3] = aux[AX_DELTA] if contact else -aux[AX_DELTA]


@njit(cache=True, nogil=True)
def _rk4(tau, x, h, k1, mode, P, IN, A, T, hist, meta, out, k2, k3, k4, tmp, aux, ra, ya,
         rt, yt, ds):
    n = x.size
    for i in range(n):
        tmp[i] = x[i] + 0.5 * h * k1[i]
    rhs(tau + 0.5 * h, tmp, mode, P, IN, A, T, hist, meta, k2, aux, ra, ya, rt, yt, ds)
    for i in range(n):
        tmp[i] = x[i] + 0.5 * h * k2[i]
    rhs(tau + 0.5 * h, tmp, mode, P, IN, A, T, hist, meta, k3, aux, ra, ya, rt, yt, ds)
    for i in range(n):
        tmp[i] = x[i] + h * k3[i]
    rhs(tau + h, tmp, mode, P, IN, A, T, hist, meta, k4, aux, ra, ya, rt, yt, ds)
    for i in range(n):
        out[i] = x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@njit(cache=True, nogil=True)
def _settle(tau, x, mode, P, IN, A, T, hist, meta, k1, aux, ra, ya, rt, yt, ds, counters):
    """Choose the interface mode consistent with the state after an event.

    Called with the velocity that crossed zero already set exactly to zero.
    """
    na = A.shape[1]
    nt = T.shape[1]
    n_b_lam = P[P_NB] * P[P_LAM]
    for _ in range(4):
        old_ang = mode[MD_ANG]
        old_ax = mode[MD_AX]
        ub, vb, phb, omb = bit_totals(tau, x, P, na, nt)
        if nt > 0 and mode[MD_ANG] == ANG_SLIP and omb <= 0.0:
            x[2 * na + 2 * nt - 1] = -P[P_OMEGA]
            mode[MD_ANG] = ANG_STICK
        if mode[MD_ANG] == ANG_STICK:
            if vb > 0.0:  # no drilling without rotation: inelastic stop of the bit
                zb = A[CH_Z, na - 1]
                for i in range(na):
                    x[na + i] -= vb / zb * A[CH_Z, i]
                x[2 * na - 1] = -P[P_UPS]
                counters[C_IMPULSES] += 1
                vb = 0.0
            if vb == 0.0:
                mode[MD_AX] = AX_STUCK
                rhs(tau, x, mode, P, IN, A, T, hist, meta, k1, aux, ra, ya, rt, yt, ds)
                if aux[AX_WREQ] < 0.0:
                    mode[MD_AX] = AX_UP
            # release check of the angular stick
            rhs(tau, x, mode, P, IN, A, T, hist, meta, k1, aux, ra, ya, rt, yt, ds)
            cut = aux[AX_CUT]
            if mode[MD_AX] == AX_STUCK:
                w_f = min(max(aux[AX_WREQ] - cut, 0.0), n_b_lam)
            else:
                w_f = 0.0
            if aux[AX_TREQ] > cut + P[P_BETA] * w_f:
                mode[MD_ANG] = ANG_SLIP
        if mode[MD_ANG] == ANG_SLIP:
            if vb == 0.0:
                mode[MD_AX] = AX_STUCK
                rhs(tau, x, mode, P, IN, A, T, hist, meta, k1, aux, ra, ya, rt, yt, ds)
                w_f = aux[AX_WREQ] - aux[AX_CUT]
                if mode[MD_CONTACT] == 1:
                    if w_f < 0.0:
                        mode[MD_AX] = AX_UP
                    elif w_f > n_b_lam:
                        mode[MD_AX] = AX_DOWN
                else:
                    mode[MD_AX] = AX_DOWN if aux[AX_WREQ] > 0.0 else AX_UP
            elif vb > 0.0:
                mode[MD_AX] = AX_DOWN
            else:
                mode[MD_AX] = AX_UP
        if mode[MD_ANG] == old_ang and mode[MD_AX] == old_ax:
            break
    rhs(tau, x, mode, P, IN, A, T, hist, meta, k1, aux, ra, ya, rt, yt, ds)


@njit(cache=True, nogil=True)
def _write_record(tau, stick_time, x, mode, P, IN, A, T, hist, meta, dx, aux, ra, ya, rt, yt,
                  ds, row):
    """Fill one record row (channels R_*) from the current state."""
    na = A.shape[1]
    nt = T.shape[1]
    ith = 2 * na + 2 * nt
    rhs(tau, x, mode, P, IN, A, T, hist, meta, dx, aux, ra, ya, rt, yt, ds)
    ub, vb, phb, omb = bit_totals(tau, x, P, na, nt)
    row[R_TAU] = tau
    row[R_V] = vb
    row[R_OMEGA] = omb
    row[R_W] = aux[AX_W]
    row[R_T] = aux[AX_T]
    row[R_DELTA] = aux[AX_DELTA]
    row[R_TAU1] = aux[AX_TAU1]
    row[R_RES] = aux[AX_RES]
    row[R_ANG] = mode[MD_ANG]
    row[R_AX] = mode[MD_AX]
    row[R_CONTACT] = mode[MD_CONTACT]
    if nt > 0:
        row[R_TSURF] = P[P_TO] + P[P_KTOP_T] * (x[ith] - x[2 * na]) \
            + P[P_CTOP_T] * (x[ith + 1] - x[2 * na + nt])
    else:
        row[R_TSURF] = aux[AX_T]
    row[R_OMSURF] = P[P_OMEGA] + x[ith + 1]
    row[R_UBIT] = x[na - 1]
    row[R_PHIBIT] = x[2 * na + nt - 1] if nt > 0 else x[ith]
    row[R_VTOP] = P[P_UPS] + x[na]
    row[R_STICK_TIME] = stick_time


@njit(cache=True, nogil=True)
def snapshot(tau_arr, x, mode, P, IN, A, T, hist, meta, row):
    """The record row of the current state, without advancing."""
    na = A.shape[1]
    nt = T.shape[1]
    _write_record(tau_arr[0], tau_arr[1], x, mode, P, IN, A, T, hist, meta,
                  np.empty(x.size), np.zeros(N_AUX), np.empty(na), np.empty(na), np.empty(nt),
                  np.empty(nt), np.zeros(3), row)


@njit(cache=True, nogil=True)
def advance(n_steps, h, tau_arr, x, mode, P, IN, A, T, hist, meta, counters, record,
            record_every, n_rec, state_record):
    """Advance ``n_steps`` steps of size ``h`` (dimensionless) in place.

    ``tau_arr[0]`` is the current time and ``tau_arr[1]`` the accumulated time
    with the bit stuck angularly (both updated; the latter is exact, from the
    located events, not from samples).  Every ``record_every``
    steps a row of :data:`N_RECORD` channels is written to ``record`` (and the
    full state to ``state_record`` if it has rows); ``n_rec[0]`` counts the
    rows written.  Returns on completion or at the first non-finite state
    (``counters[C_STATUS] = STATUS_NONFINITE``, ``counters[C_BAD_INDEX]`` the
    state index).
    """
    na = A.shape[1]
    nt = T.shape[1]
    n = x.size
    ith = 2 * na + 2 * nt
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    xs = np.empty(n)
    xt = np.empty(n)
    aux = np.zeros(N_AUX)
    ra = np.empty(na)
    ya = np.empty(na)
    rt = np.empty(nt)
    yt = np.empty(nt)
    ds = np.zeros(3)
    g = np.empty(4)
    gl = np.empty(4)
    tau = tau_arr[0]
    if P[P_DRIVE_TAU] <= 0.0:
        x[ith + 1] = IN[IN_OMEGA_CMD] - P[P_OMEGA]
    rhs(tau, x, mode, P, IN, A, T, hist, meta, k1, aux, ra, ya, rt, yt, ds)
    for _step in range(n_steps):
        remaining = h
        for _sub in range(20):  # at most 20 events per step
            _rk4(tau, x, remaining, k1, mode, P, IN, A, T, hist, meta, xt, k2, k3, k4, tmp,
                 aux, ra, ya, rt, yt, ds)
            rhs(tau + remaining, xt, mode, P, IN, A, T, hist, meta, k2, aux, ra, ya, rt, yt,
                ds)
            _switching(tau + remaining, xt, mode, P, aux, na, nt, g)
            gmin = min(min(g[0], g[1]), min(g[2], g[3]))
            if gmin >= 0.0 or _sub == 19:  # 20th event in one step: accept (no Zeno loop)
                for i in range(n):
                    x[i] = xt[i]
                    k1[i] = k2[i]
                if mode[MD_ANG] == ANG_STICK:
                    tau_arr[1] += remaining
                tau += remaining
                break
            # locate the crossing: Illinois method on min(g) over the fraction s
            s_lo = 0.0
            rhs(tau, x, mode, P, IN, A, T, hist, meta, k2, aux, ra, ya, rt, yt, ds)
            _switching(tau, x, mode, P, aux, na, nt, gl)
            g_lo = min(min(gl[0], gl[1]), min(gl[2], gl[3]))
            s_hi = 1.0
            g_hi = gmin
            side = 0
            for _it in range(80):
                if s_hi - s_lo < 1e-10:
                    break
                if g_lo > 0.0:
                    s = s_lo + (s_hi - s_lo) * g_lo / (g_lo - g_hi)
                else:
                    s = 0.5 * (s_lo + s_hi)
                if not (s_lo < s < s_hi):
                    s = 0.5 * (s_lo + s_hi)
                _rk4(tau, x, s * remaining, k1, mode, P, IN, A, T, hist, meta, xs, k2, k3, k4,
                     tmp, aux, ra, ya, rt, yt, ds)
                rhs(tau + s * remaining, xs, mode, P, IN, A, T, hist, meta, k2, aux, ra, ya,
                    rt, yt, ds)
                _switching(tau + s * remaining, xs, mode, P, aux, na, nt, g)
                gs = min(min(g[0], g[1]), min(g[2], g[3]))
                if gs >= 0.0:
                    s_lo = s
                    g_lo = gs
                    if side == -1:
                        g_hi *= 0.5
                    side = -1
                else:
                    s_hi = s
                    g_hi = gs
                    if side == 1:
                        g_lo *= 0.5
                    side = 1
            dt = s_hi * remaining
            _rk4(tau, x, dt, k1, mode, P, IN, A, T, hist, meta, xt, k2, k3, k4, tmp, aux, ra,
                 ya, rt, yt, ds)
            rhs(tau + dt, xt, mode, P, IN, A, T, hist, meta, k2, aux, ra, ya, rt, yt, ds)
            _switching(tau + dt, xt, mode, P, aux, na, nt, g)
            for i in range(n):
                x[i] = xt[i]
            if mode[MD_ANG] == ANG_STICK:
                tau_arr[1] += dt
            tau += dt
            remaining -= dt
            counters[C_EVENTS] += 1
            # apply the transition of the violated switching function
            ub, vb, phb, omb = bit_totals(tau, x, P, na, nt)
            k = 0
            for j in range(1, 4):
                if g[j] < g[k]:
                    k = j
            if k == 3:
                mode[MD_CONTACT] = 1 - mode[MD_CONTACT]
                if mode[MD_AX] == AX_STUCK:
                    mode[MD_AX] = AX_DOWN if aux[AX_WREQ] > 0.0 else AX_UP
            elif k == 0:
                if mode[MD_ANG] == ANG_SLIP:
                    x[2 * na + 2 * nt - 1] = -P[P_OMEGA]
                else:
                    mode[MD_ANG] = ANG_SLIP
            else:
                if mode[MD_AX] == AX_STUCK:
                    mode[MD_AX] = AX_UP if k == 1 else AX_DOWN
                else:
                    x[2 * na - 1] = -P[P_UPS]
            ub, vb, phb, omb = bit_totals(tau, x, P, na, nt)
            push_sample(hist, meta, tau, ub, phb, vb, omb)
            _settle(tau, x, mode, P, IN, A, T, hist, meta, k1, aux, ra, ya, rt, yt, ds,
                    counters)
            if remaining <= 1e-12 * h:
                break
        ub, vb, phb, omb = bit_totals(tau, x, P, na, nt)
        push_sample(hist, meta, tau, ub, phb, vb, omb)
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
            _write_record(tau, tau_arr[1], x, mode, P, IN, A, T, hist, meta, k2, aux, ra, ya,
                          rt, yt, ds, record[r])
            if state_record.shape[0] > r:
                for i in range(n):
                    state_record[r, i] = x[i]
            n_rec[0] = r + 1
    tau_arr[0] = tau
