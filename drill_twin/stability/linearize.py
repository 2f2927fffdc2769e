"""Linearisation of any drill-string model about steady drilling (thesis §5.1-5.2).

Derivation
----------
About the steady state (bit moving down, in contact, slipping) the wear-flat
force is constant (W_f = n_b λ), so only the cutting term varies.  With the
total delay τ_1 = τ_1,0 + τ̂ and eq. 2.4.14 linearised,
``ω_o τ̂ = φ_b(τ - τ_1,0) - φ_b(τ)``, the depth-of-cut perturbation is

    δ̂ = u_b(τ) - u_b(τ-τ_1,0) + υ_o τ̂
       = u_b - u_b(τ-τ_1,0) - α_o φ_b + α_o φ_b(τ-τ_1,0),      α_o = υ_o/ω_o

(the ``u_b(τ-τ_1)`` shift by τ̂ is of second order because ``u_b' `` is a
perturbation).  Both W - W_o and T - T_o equal ``n_b δ̂`` (units W* and C).
With ``y = [u, u', φ, φ']`` the chains of :mod:`drill_twin.physics.models` give
``y' = A0 y + A1 y(τ - τ_1,0)`` with, writing ``e`` for the bit unit vector,

    u''  = M_a⁻¹[-K_a u - C_a u' - ψ n_b e (u_b - α_o φ_b)] + M_a⁻¹ ψ n_b e (u_b - α_o φ_b)(τ-τ_1,0)
    φ''  = M_t⁻¹[-K_t φ - C_t φ' - n_b e (u_b - α_o φ_b)]   + M_t⁻¹ n_b e (u_b - α_o φ_b)(τ-τ_1,0)

For RGD-2 (masses 1/2) this gives A0[3,3] = -4 + 2 n_b α_o and
A1[1,3] = -2 n_b ψ α_o, where the printed eq. 5.1.1 has -2(2 + n_b α_o) and
+2 n_b ψ α_o: the two sign errors of the thesis.

Uneven blades (§6.2: "multiple delays per one particular bit design")
---------------------------------------------------------------------
Blade b cuts the rock the blade ahead of it left one gap Δθ_b earlier: its delay is
τ_b(τ) with Φ(τ - τ_b) = Φ(τ) - Δθ_b, steady value τ_b,0 = Δθ_b/ω_o and steady depth
υ_o τ_b,0 (the depths differ; their sum is still υ_o 2π/ω_o = n_b δ_o, so the steady
state and W_o = n_b(δ_o + λ) are those of the even bit).  Linearised exactly as above,
each blade contributes ``s(τ) - s(τ - τ_b,0)`` with the same ``s = u_b - α_o φ_b``, so

    y' = A0 y + Σ_b (A1 / n_b) y(τ - τ_b,0)

— the even bit is the case where all n_b delays coincide.  Blades with equal gaps
are grouped into one delayed term.

Motor top drive (docs/control.md)
---------------------------------
With a PI motor drive on the top node the state grows by the controller's integral ϑ
and torque reference T_ref, ``y = [u, u', φ, φ', ϑ, T_ref]``.  Below its torque limit the
drive is linear; with the surface torque ``T_s = s_Tᵀ y`` (first element) and the
measured signals delayed by τ_m,

    T_m = K_p r(τ - τ_m) + K_p g_T T_ref + K_i ϑ,     r = -(φ'_0 + g_T T_s),
    ϑ'  = r(τ - τ_m) + g_T T_ref,                     T_ref' = (T_s(τ - τ_m) - T_ref)/τ_f,

and ``T_m`` enters the motor row ``φ''_0``.  ``r`` and ``T_s`` are two scalars, so with
τ_m > 0 the delayed part is two rank-one terms of delay τ_m (in A0 when τ_m = 0).

The wall's friction in a deviated well (docs/physics.md §9.9)
------------------------------------------------------------
Steady drilling slides every node on the wall with y_o = (υ_o, ρ ω_o) (axial, rim speed).
The friction -F(|y|) y/|y| (F of eq. 9.9) has a constant part, which only moves the steady
state (the elastic chains are linear: the twist and stretch it needs do not enter the
perturbation), and a velocity dependence, which does: its Jacobian at y_o is
-(F/|y_o|)(I - ŷŷᵀ) - F'(|y_o|) ŷŷᵀ, ŷ = y_o/|y_o|, a damping block per node on
(δu', ρ δφ'); with the two-level law (F' = 0)

    δf_a = -(F/|y_o|)(ŷ_t² δu' - ŷ_a ŷ_t ρ δφ'),
    δτ   = -(F ρ/κ |y_o|)(-ŷ_a ŷ_t δu' + ŷ_a² ρ δφ')      (torque: units C, κ of §9.3)

— rotation turns the axial Coulomb drag into a viscous one, F/(ρ ω_o) per node when
υ_o ≪ ρ ω_o, while the torsional part is second order in υ_o/(ρ ω_o).  Stribeck's
weakening (F' < 0) adds -F' along ŷ: a negative damping, mostly torsional.  The bit node
is left out, as in the kernel while a blade is on the rock.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..physics.layout import TRIPLE, WALL, indices, state_layout
from ..physics.models import StringModel
from ..physics.parameters import BitRockGroups
from ..physics.wall_contact import rim_inertia_factor
from ..physics.wall_law import sliding_friction, sliding_friction_slope

#: a motor drive's states, appended to the linear state ``[u, u', φ, φ']`` (the kernel's
#: drive block also holds the prescribed angle, speed and block, which are not states of
#: the linearisation: they are the operating point)
LINEAR_DRIVE = indices('LinearDrive', ('integral', 'torque_reference'))

__all__ = ['LinearDDE', 'linearize', 'linearize_semi_infinite', 'linearize_scenario']


@dataclass
class LinearDDE:
    """``y'(τ) = A0 y(τ) + A1 y(τ - delay) + Σ_k B_k y(τ - τ_k)``.

    ``labels`` name the state entries; ``extra`` lists ``(B_k, τ_k)`` for the
    constant delays of lumped model III (empty for every other model).
    """

    A0: np.ndarray
    A1: np.ndarray
    delay: float
    labels: list
    extra: list = field(default_factory=list)

    @property
    def size(self) -> int:
        return self.A0.shape[0]

    def modes(self):
        """Eigen-decomposition (μ, V) of A0, computed once per linearisation."""
        cached = self.__dict__.get('_modes')
        if cached is None:
            cached = np.linalg.eig(self.A0)
            self.__dict__['_modes'] = cached
        return cached

    def terms(self):
        """All delayed terms ``(matrix, delay)``."""
        return [(self.A1, self.delay)] + list(self.extra)

    def characteristic_matrix(self, lam: complex) -> np.ndarray:
        """Δ(λ) = λ I - A0 - Σ A_k exp(-λ τ_k)."""
        out = lam * np.eye(self.size) - self.A0
        for B, tau in self.terms():
            out = out - B * np.exp(-lam * tau)
        return out


def linearize(model: StringModel, groups: BitRockGroups, wall=None,
              kappa: float = 1.0) -> LinearDDE:
    """Matrices of the linearised perturbation equations (see module docstring).

    ``wall``: the nodes on the wall of a deviated well (the kernel's array, :data:`~drill_
    twin.physics.layout.WALL` rows), with ``kappa`` = C t*²/(M d*²) of docs/physics.md
    eq. 9.3; None in a vertical well."""
    ax = model.axial
    tr = model.torsional
    na = ax.n
    nt = tr.n if tr is not None else 0
    L = state_layout.py_func(na, nt)
    n = L.drive                        # the linear state: [u, u', φ, φ']
    A0 = np.zeros((n, n))
    A1 = np.zeros((n, n))
    nb = groups.n_b
    alpha = groups.alpha_o
    # selector rows for the delayed depth-of-cut combination (u_b - α φ_b)
    sel = np.zeros(n)
    sel[L.bit_u] = 1.0
    if nt:
        sel[L.bit_phi] = -alpha
    u, v = slice(L.u, L.u + na), slice(L.v, L.v + na)
    Ma_inv = np.linalg.inv(ax.dense('mass'))
    A0[u, v] = np.eye(na)
    A0[v, u] = -Ma_inv @ ax.dense('stiffness')
    A0[v, v] = -Ma_inv @ ax.dense('damping')
    col_a = Ma_inv[:, -1] * model.psi * nb      # the bit: the chain's last DOF
    A0[v] -= np.outer(col_a, sel)
    A1[v] += np.outer(col_a, sel)
    labels = [f'u{i}' for i in range(na)] + [f'du{i}' for i in range(na)]
    if nt:
        Mt_inv = np.linalg.inv(tr.dense('mass'))
        p, w = slice(L.phi, L.phi + nt), slice(L.omega, L.omega + nt)
        A0[p, w] = np.eye(nt)
        A0[w, p] = -Mt_inv @ tr.dense('stiffness')
        A0[w, w] = -Mt_inv @ tr.dense('damping')
        col_t = Mt_inv[:, -1] * nb
        A0[w] -= np.outer(col_t, sel)
        A1[w] += np.outer(col_t, sel)
        labels += [f'phi{i}' for i in range(nt)] + [f'dphi{i}' for i in range(nt)]
        if wall is not None and wall.shape[1]:
            _add_wall_damping(A0, wall, kappa, groups, L, Ma_inv, Mt_inv)
    extra = []
    delay = groups.tau_10
    if groups.uneven:  # one delayed term per distinct blade gap, each 1/n_b of the force
        delays = {}
        for tau_b in groups.blade_delays:
            key = round(tau_b, 12)
            delays[key] = delays.get(key, 0) + 1
        (delay, count), *rest = sorted(delays.items())
        A1_total = A1
        A1 = A1_total * (count / nb)
        extra += [(A1_total * (k / nb), tau) for tau, k in rest]
    if model.motor_drive:
        A0, A1, extra = _with_motor_drive(model, A0, A1, extra)
        labels += ['drive_integral', 'torque_reference']
    if model.delayed_damping is not None:  # lumped model III (single masses)
        z_a, tau_a, z_t, tau_t = model.delayed_damping
        B = np.zeros((n, n))
        B[L.bit_v, L.bit_v] = -z_a / ax.dense('mass')[0, 0]
        extra.append((B, tau_a))
        B = np.zeros((n, n))
        B[L.bit_omega, L.bit_omega] = -z_t / tr.dense('mass')[0, 0]
        extra.append((B, tau_t))
    return LinearDDE(A0, A1, delay, labels, extra)


def _add_wall_damping(A0, wall, kappa, groups, L, Ma_inv, Mt_inv):
    """The sliding friction's Jacobian (module docstring) in the velocity rows of A0."""
    na, nt = Ma_inv.shape[0], Mt_inv.shape[0]
    for j in range(wall.shape[1]):
        ia, it = int(wall[WALL.axial_dof, j]), int(wall[WALL.torsional_dof, j])
        if ia == na - 1:
            continue                         # the bit: its own law while on bottom
        rho = wall[WALL.radius, j]
        ya, yt = groups.upsilon_o, rho * groups.omega_o
        speed = float(np.hypot(ya, yt))
        law = (wall[WALL.static, j], wall[WALL.dynamic, j], wall[WALL.stribeck, j], speed)
        F, dF = sliding_friction.py_func(*law), sliding_friction_slope(*law)
        ca, ct = ya / speed, yt / speed
        g = F / speed
        # ∂f/∂y of f = -F(|y|) y/|y|: -(F/|y|)(I - c cᵀ) - F'(|y|) c cᵀ, c = y/|y|
        jaa, jat, jtt = -g * ct * ct - dF * ca * ca, (g - dF) * ca * ct, -g * ca * ca - dF * ct * ct
        # force on the axial DOF and torque on the torsional DOF per unit δu', δφ'
        faa, fat = jaa, jat * rho
        tta, ttt = jat * rho / kappa, jtt * rho / kappa * rho
        A0[L.v:L.v + na, L.v + ia] += Ma_inv[:, ia] * faa
        A0[L.v:L.v + na, L.omega + it] += Ma_inv[:, ia] * fat
        A0[L.omega:L.omega + nt, L.v + ia] += Mt_inv[:, it] * tta
        A0[L.omega:L.omega + nt, L.omega + it] += Mt_inv[:, it] * ttt


def surface_torque_row(model: StringModel) -> np.ndarray:
    """``s_T`` with ``T_s = s_Tᵀ y``: torque in the first element of the torsional chain
    (units C) over the state ``[u, u', φ, φ']``."""
    na, tr = model.axial.n, model.torsional
    L = state_layout.py_func(na, tr.n)
    row = np.zeros(L.drive)
    k01, c01 = tr.stiffness[TRIPLE.upper, 0], tr.damping[TRIPLE.upper, 0]
    p0, w0 = L.top_phi, L.top_omega
    row[p0], row[p0 + 1] = -k01, k01
    row[w0], row[w0 + 1] = -c01, c01
    return row


def _with_motor_drive(model: StringModel, A0, A1, extra):
    """Append ϑ and T_ref to the linearisation (module docstring, 'Motor top drive')."""
    d = model.motor_drive
    n = A0.shape[0]
    na, nt = model.axial.n, model.torsional.n
    w0 = state_layout.py_func(na, nt).top_omega
    m = n + len(LINEAR_DRIVE)
    i_int, i_ref = n + LINEAR_DRIVE.integral, n + LINEAR_DRIVE.torque_reference

    def grow(M):
        out = np.zeros((m, m))
        out[:n, :n] = M
        return out
    A0, A1 = grow(A0), grow(A1)
    extra = [(grow(B), tau) for B, tau in extra]
    s_T = np.zeros(m)
    s_T[:n] = surface_torque_row(model)
    r_sel = -d['g_t'] * s_T
    r_sel[w0] -= 1.0
    # column of the motor torque in the velocity rows, plus the integral's row
    col = np.zeros(m)
    col[w0:w0 + nt] = np.linalg.inv(model.torsional.dense('mass'))[:, 0]
    r_col = d['kp'] * col
    r_col[i_int] += 1.0
    A0 += np.outer(d['ki'] * col, np.eye(m)[i_int])
    A0 += np.outer(r_col, d['g_t'] * np.eye(m)[i_ref])
    A0[i_ref, i_ref] -= 1.0 / d['t_filter']
    ref_col = np.eye(m)[i_ref] / d['t_filter']
    if d['t_delay'] > 0:
        extra += [(np.outer(r_col, r_sel), d['t_delay']), (np.outer(ref_col, s_T),
                                                          d['t_delay'])]
    else:
        A0 += np.outer(r_col, r_sel) + np.outer(ref_col, s_T)
    return A0, A1, extra


def linearize_semi_infinite(groups: BitRockGroups, psi: float, axial_impedance: float,
                            torsional_impedance: float) -> LinearDDE:
    """The semi-infinite drill string of §5.2 (massless bit on radiation boundaries).

    With no bit mass the momentum balances at the bit are ``z_u u' = -ψ (W - W_o)``
    and ``z_φ φ' = -(T - T_o)`` (eqs 5.2.1-5.2.6 in the chain units of
    :func:`drill_twin.physics.models.pipe_impedances`); linearised as above:
    ``y = [u, φ]``, ``y' = A0 y + A1 y(τ - τ_1,0)``.  This is the M → 0 limit of
    lumped model I; it is a stability model only (a stuck bit never restarts).
    """
    nb, al = groups.n_b, groups.alpha_o
    gain = np.array([psi / axial_impedance, 1.0 / torsional_impedance]) * nb
    sel = np.array([1.0, -al])
    A0 = -np.outer(gain, sel)
    A1 = np.outer(gain, sel)
    return LinearDDE(A0, A1, groups.tau_10, ['u', 'phi'])


def linearize_scenario(scenario, groups: BitRockGroups | None = None) -> LinearDDE:
    """Linearisation of a :class:`~drill_twin.config.scenario.Scenario` (at ``groups``)."""
    groups = groups or scenario.groups
    if scenario.stability_only:
        z = scenario.impedances()
        return linearize_semi_infinite(groups, scenario.model.psi, z['axial'], z['torsional'])
    wall = getattr(scenario, 'wall', None)
    kappa = rim_inertia_factor(scenario.scales) if wall is not None else 1.0
    return linearize(scenario.model, groups, wall, kappa)
