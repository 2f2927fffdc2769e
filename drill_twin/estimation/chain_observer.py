"""A Kalman filter on one axis of the drill string with the bit's force as an unknown input.

The string is linear (:mod:`drill_twin.physics.models`: a tridiagonal chain of masses,
springs and dash-pots); everything nonlinear happens at the bit.  Seen from the surface,
the bit's torque (or force) is an unknown boundary input, so it joins the state as a
random walk (an augmented-state Kalman filter, docs/estimation.md §2):

* **kinematic top** (torsion): the measured speed ``u`` of the top of the string
  drives the chain through its first element (``k_top``, ``c_top``); the measured torque
  at the top of the string is that element's torque ``y = k_top e_0 + c_top (u − v_0)``
  — the drive behind it does not enter;
* **force top** (axial): the hook load acts on the top node (down positive: ``−H``)
  beside the known weights ``w`` of the nodes; the measured block velocity is that
  node's velocity ``y = v_0``.

State ``x = [e, v, f]``: element deformations ``e`` (twists or stretches between
neighbouring nodes, and between the top drive and the first node for a kinematic
top), node velocities ``v`` (absolute), the bit's torque or force ``f``.  With
``K = Sᵀ diag(k) S`` (``S`` the difference operator, ``e = S x + b θ``):

    ė = S v + b u,        M v̇ = −Sᵀ diag(k) e − C v + c_top u e_0 − f e_bit

(kinematic top; the force top has ``+ F e_0 + w`` instead of the coupling terms).  The
state is bounded although the string turns and drills without end.  Sampled with a
zero-order hold on the inputs (exact: matrix exponential), with the steady-state gain
of the discrete Riccati equation, so one update is two small matrix-vector products.

Units: SI throughout (rad, rad/s, N·m; m, m/s, N); the model's dimensionless chains are
converted with the configuration's scales (eq. 2.4.1).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import expm, solve

from ..physics.models import Chain, StringModel

__all__ = ['AxisModel', 'torsional_axis', 'axial_axis', 'Lookahead', 'ChainObserver']


@dataclass
class AxisModel:
    """One axis of a finite-element string in SI, element by element (top to bottom).

    ``element_mass`` [kg or kg·m²] and ``element_stiffness`` [N/m or N·m/rad] of the
    linear elements (consistent mass ``m/6 [[2,1],[1,2]]``, stiffness ``k [[1,-1],[-1,1]]``,
    App. A); Rayleigh damping ``C = eta M + theta K`` (``eta`` [1/s], ``theta`` [s]);
    ``top_fixed``: the top node is driven kinematically and eliminated (stiff speed drive:
    the first element couples the driven top to DOF 0); otherwise the top node is a DOF
    carrying ``top_mass`` and, for a kinematic top, tied to the driven top by
    ``top_spring``/``top_dashpot`` (the Soft-Torque drive).  ``kinematic``: the input is
    the top speed (torsion) — else the top force (axial, hook load), with the nodes'
    known loads ``w`` (weights in mud).  ``bha``: mask of the BHA elements.
    """

    element_mass: np.ndarray
    element_stiffness: np.ndarray
    eta: float
    theta: float
    top_fixed: bool
    kinematic: bool
    top_mass: float = 0.0
    top_spring: float = 0.0
    top_dashpot: float = 0.0
    w: np.ndarray | None = None
    bha: np.ndarray | None = None

    def matrices(self):
        """``M, C, K`` of the DOFs and the coupling ``k_top, c_top`` of DOF 0 to the
        driven top (zero for a force top)."""
        m, k = self.element_mass, self.element_stiffness
        nodes = m.size + 1
        M = np.zeros((nodes, nodes))
        K = np.zeros((nodes, nodes))
        for e in range(m.size):
            M[e:e + 2, e:e + 2] += m[e] / 6.0 * np.array([[2.0, 1.0], [1.0, 2.0]])
            K[e:e + 2, e:e + 2] += k[e] * np.array([[1.0, -1.0], [-1.0, 1.0]])
        M[0, 0] += self.top_mass
        C = self.eta * M + self.theta * K
        if self.top_fixed:
            return M[1:, 1:], C[1:, 1:], K[1:, 1:], -K[1, 0], -C[1, 0]
        if self.kinematic:
            K[0, 0] += self.top_spring
            C[0, 0] += self.top_dashpot
            return M, C, K, self.top_spring, self.top_dashpot
        return M, C, K, 0.0, 0.0

    @property
    def n(self) -> int:
        return self.element_mass.size + (0 if self.top_fixed else 1)

    def scaled(self, bha_mass: float = 1.0, pipe_stiffness: float = 1.0,
               stiffness: float = 1.0, theta_add_s: float = 0.0) -> AxisModel:
        """The same string with the BHA elements' mass (inertia) times ``bha_mass``, the
        other elements' stiffness times ``pipe_stiffness``, every stiffness times
        ``stiffness`` and ``theta_add_s`` more stiffness-proportional damping."""
        bha = self.bha if self.bha is not None else np.zeros(self.element_mass.size, bool)
        m = np.where(bha, self.element_mass * bha_mass, self.element_mass)
        k = np.where(bha, self.element_stiffness, self.element_stiffness * pipe_stiffness)
        return replace(self, element_mass=m, element_stiffness=k * stiffness,
                       theta=self.theta + theta_add_s)


def _elements(chain: Chain, top_fixed: bool):
    """Element masses and stiffnesses of a linear-element chain (dimensionless), from its
    off-diagonals (``M_ij = m/6``, ``K_ij = -k``), and the top node's extra mass."""
    M, K = chain.dense('mass'), chain.dense('stiffness')
    n = chain.n
    m = [6.0 * M[i, i + 1] for i in range(n - 1)]
    k = [-K[i, i + 1] for i in range(n - 1)]
    if top_fixed:  # the eliminated top's coupling column: m_top = -M_10, k_top = -K_10
        return np.array([-6.0 * chain.m_top] + m), np.array([chain.k_top] + k), 0.0
    return np.array(m), np.array(k), M[0, 0] - m[0] / 3.0


def _bha_mask(model: StringModel, system) -> np.ndarray:
    counts = model.section_elements or []
    return np.concatenate([np.full(c, sec.bha) for c, sec in zip(counts, system.sections)])


def torsional_axis(scenario) -> AxisModel:
    """The torsional string of a finite-element scenario in SI (inertias × I, stiffnesses
    × C, time × t*), driven at its top node by the measured top-drive speed, whatever the
    drive: the drive itself (a stiff speed source, the Soft-Torque inertia on its spring,
    a controller) is not part of the model — the measured speed of the top of the string
    and the measured torque at the top of the string are the whole boundary condition.
    The coupling's inertia term ``m_top θ̈`` (the consistent mass of the first element,
    ~1e-3 of the BHA's) is left out: it would need the derivative of the measured speed."""
    model, s, raw = scenario.model, scenario.scales, scenario.raw['model']
    chain = model.torsional
    m, k, _ = _elements(chain, not chain.drive_node)
    return AxisModel(element_mass=m * s.inertia_kgm2, element_stiffness=k * s.torque_Nm,
                     eta=raw.get('eta_phi', 0.0) / s.time_s,
                     theta=raw.get('theta_phi', 0.0) * s.time_s, top_fixed=True,
                     kinematic=True, bha=_bha_mask(model, scenario.system))


def axial_axis(scenario, weight_N: float) -> AxisModel:
    """The axial string in SI with a force top: the hook load acts on the top node (the
    drill line of a hoist is cut there: the hook load is the force it transmits); the
    string's weight in mud ``weight_N`` is shared out over the nodes as the elements'
    masses (the block's mass excluded: the hook load is read with the block tared)."""
    model, s, raw = scenario.model, scenario.scales, scenario.raw['model']
    if raw.get('axial_top', 'hook_load') == 'velocity':
        raise ValueError('the axial estimate needs a hook-load or hoist top (the block '
                         'velocity of an imposed-velocity top carries no force information)')
    m, k, top = _elements(model.axial, False)
    m_si = m * s.mass_kg
    lumped = np.zeros(m.size + 1)
    lumped[:-1] += m_si / 2.0
    lumped[1:] += m_si / 2.0
    return AxisModel(element_mass=m_si, element_stiffness=k * s.mass_kg / s.time_s ** 2,
                     eta=raw.get('eta_u', 0.0) / s.time_s,
                     theta=raw.get('theta_u', 0.0) * s.time_s, top_fixed=False,
                     kinematic=False, top_mass=top * s.mass_kg,
                     w=weight_N * lumped / lumped.sum(), bha=_bha_mask(model, scenario.system))


def _spring_chain(axis: AxisModel, K: np.ndarray, k_top: float):
    """``S`` and ``k`` with ``K = Sᵀ diag(k) S`` (and the top row for a kinematic top)."""
    n = axis.n
    springs = [-K[i - 1, i] for i in range(1, n)]
    if axis.kinematic:
        S = np.zeros((n, n))
        S[0, 0] = -1.0
        for i in range(1, n):
            S[i, i - 1], S[i, i] = 1.0, -1.0
        k = np.array([k_top] + springs)
    else:
        S = np.zeros((n - 1, n))
        for r in range(n - 1):
            S[r, r], S[r, r + 1] = 1.0, -1.0
        k = np.array(springs)
    if not np.allclose(S.T @ (k[:, None] * S), K, rtol=1e-9, atol=1e-12 * np.abs(K).max()):
        raise ValueError('the stiffness matrix is not a chain of springs')
    return S, k


def filter_riccati(F: np.ndarray, H: np.ndarray, Q: np.ndarray, R: float,
                   tol: float = 1e-12, max_doublings: int = 64) -> np.ndarray:
    """Stabilising solution ``P`` (the a-priori covariance) of the filter's discrete
    algebraic Riccati equation ``P = F P Fᵀ − F P Hᵀ (H P Hᵀ + R)⁻¹ H P Fᵀ + Q`` for one
    measurement, by the structure-preserving doubling algorithm (Chu, Fan & Lin 2005):
    each doubling squares the closed loop, so ``k`` doublings equal ``2^k`` Riccati
    steps; it stays accurate when lightly damped string modes put eigenvalues of the
    symplectic pencil next to the unit circle (where the Schur method of
    ``scipy.linalg.solve_discrete_are`` fails its accuracy check)."""
    n = F.shape[0]
    A = F.T.copy()                       # the dual (control) form: A = Fᵀ, G = Hᵀ R⁻¹ H
    G = np.outer(H, H) / R
    X = Q.copy()
    eye = np.eye(n)
    for _ in range(max_doublings):
        W = eye + G @ X
        AW = solve(W.T, A.T).T           # A W⁻¹  (W⁻¹ applied from the right)
        X_new = X + A.T @ X @ solve(W, A)
        G = G + AW @ G @ A.T
        A = AW @ A
        X_new = 0.5 * (X_new + X_new.T)
        if np.abs(X_new - X).max() <= tol * max(np.abs(X_new).max(), 1e-300):
            return X_new
        X = X_new
    raise ArithmeticError('the filter Riccati equation did not converge (is the string '
                          'model observable from the surface torque?)')


@dataclass(frozen=True)
class Lookahead:
    """The predicted mean and standard deviation of one state at ``m`` instants
    ``t_k + jΔt/m`` (j = 1..m) of the coming sample period, given the posterior at
    ``t_k`` and the input held: ``mean_j = rows[j] · x + input[j] u + const[j]``."""

    rows: np.ndarray
    input: np.ndarray
    const: np.ndarray
    std: np.ndarray

    def lowest(self, x: np.ndarray, u: float, z: float) -> float:
        """Least ``mean_j − z std_j`` over the period."""
        return float(np.min(self.rows @ x + self.input * u + self.const - z * self.std))


class ChainObserver:
    """Steady-state Kalman filter of one axis at a fixed sample period.

    Parameters
    ----------
    axis : AxisModel
    period_s : float
        Sample period [s] of the measurements (and of the updates).
    input_std : float
        Standard deviation of the measured input (top speed [rad/s] or hook load [N]).
    output_std : float
        Standard deviation of the measured output (surface torque [N·m] or block
        velocity [m/s]).
    force_rate_std : float
        Random-walk intensity of the bit's torque/force: standard deviation of its change
        over one second [N·m/√s or N/√s].
    """

    def __init__(self, axis: AxisModel, period_s: float, input_std: float, output_std: float,
                 force_rate_std: float):
        if not (period_s > 0 and input_std >= 0 and output_std > 0 and force_rate_std > 0):
            raise ValueError('need period_s > 0, input_std >= 0, output_std > 0 and '
                             'force_rate_std > 0')
        self.axis = axis
        self.period_s = float(period_s)
        self.input_std, self.force_rate_std = float(input_std), float(force_rate_std)
        M, C, K, k_top, c_top = axis.matrices()
        self._M, self._C, self._k_top, self._c_top = M, C, k_top, c_top
        self._w = axis.w if axis.w is not None else np.zeros(axis.n)
        S, k = _spring_chain(axis, K, k_top)
        self._S, self._k = S, k
        n, ne = axis.n, S.shape[0]
        nx = ne + n + 1
        self.ne, self.nx = ne, nx
        Minv = np.linalg.inv(M)
        A = np.zeros((nx, nx))
        B = np.zeros((nx, 2))          # inputs: [top speed or top force, 1 (constant loads)]
        A[:ne, ne:ne + n] = S
        A[ne:ne + n, :ne] = -Minv @ (S.T * k)
        A[ne:ne + n, ne:ne + n] = -Minv @ C
        A[ne:ne + n, nx - 1] = -Minv[:, n - 1]
        H = np.zeros(nx)
        if axis.kinematic:
            B[0, 0] = 1.0
            B[ne:ne + n, 0] = Minv[:, 0] * c_top
            H[0], H[ne] = k_top, -c_top
            self.D = c_top
        else:
            B[ne:ne + n, 0] = Minv[:, 0]
            H[ne] = 1.0
            self.D = 0.0
        B[ne:ne + n, 1] = Minv @ self._w
        self.A, self.B, self.H = A, B, H
        self.F, self.G, Qd = self._discretise(A, B, force_rate_std ** 2, self.period_s)
        # The measured input's noise n (held over the next period) enters the process as
        # −G n and the measurement of this sample as −D n: the measurement noise is
        # n_y − D n with variance R, correlated with the next period's process noise
        # (cross-covariance N).  The Riccati equation with the cross term is the plain one
        # of F − N R⁻¹ H and Q − N R⁻¹ Nᵀ; the next prediction adds N S⁻¹ ν.
        Qd += input_std ** 2 * np.outer(self.G[:, 0], self.G[:, 0])
        self.Qd = Qd
        R = output_std ** 2 + (self.D * input_std) ** 2
        N = input_std ** 2 * self.D * self.G[:, 0]
        P = filter_riccati(self.F - np.outer(N, H) / R, H, Qd - np.outer(N, N) / R, R)
        s = float(H @ P @ H) + R
        self.gain = P @ H / s
        self.cross_gain = N / s
        self._nu = 0.0            # the last innovation, until the next prediction uses it
        self.innovation_var = s
        self.prior_P = P
        self.P = P - np.outer(self.gain, H @ P)            # after the update
        self.x = np.zeros(nx)
        self._u = 0.0
        self.bit_velocity = ne + n - 1
        self.top_velocity = ne
        self.bit_force = nx - 1

    @staticmethod
    def _discretise(A, B, q_force, dt):
        """Zero-order hold of the inputs and the covariance of the bit force's random walk
        (intensity ``q_force`` on the last state) over ``dt``: Van Loan's exponential over
        a short step ``h = dt / 2^k`` (``‖A‖ h ≤ 1``: the heavily damped high modes would
        overflow ``exp(−A dt)``), then doubled ``k`` times —
        ``F(2h) = F(h)²``, ``G(2h) = G(h) + F(h) G(h)``, ``Q(2h) = Q(h) + F(h) Q(h) F(h)ᵀ``."""
        nx, nu = B.shape
        k = max(0, int(np.ceil(np.log2(max(np.abs(A).sum(axis=1).max() * dt, 1.0)))))
        h = dt / 2 ** k
        big = np.zeros((nx + nu, nx + nu))
        big[:nx, :nx], big[:nx, nx:] = A, B
        E = expm(big * h)
        F, G = E[:nx, :nx], E[:nx, nx:]
        Qc = np.zeros((nx, nx))
        Qc[-1, -1] = q_force
        vl = np.zeros((2 * nx, 2 * nx))
        vl[:nx, :nx], vl[:nx, nx:], vl[nx:, nx:] = -A, Qc, A.T
        V = expm(vl * h)
        Qd = V[nx:, nx:].T @ V[:nx, nx:]
        for _ in range(k):
            G = G + F @ G
            Qd = Qd + F @ Qd @ F.T
            F = F @ F
        return F, G, 0.5 * (Qd + Qd.T)

    def start(self, u: float, force: float):
        """Start in equilibrium: turning steadily at the top speed ``u`` (kinematic top) or
        at rest under the hook load ``u`` (force top), the bit's torque/force ``force``
        balanced by the elements' deformations."""
        n, ne = self.axis.n, self.ne
        x = np.zeros(self.nx)
        x[-1] = force
        loads = np.zeros(n)
        loads[n - 1] = -force
        if self.axis.kinematic:      # −Sᵀ k e − C v + c_top u e_0 − f e_bit = 0 with v = u
            x[ne:ne + n] = u
            loads += -self._C @ x[ne:ne + n]
            loads[0] += self._c_top * u
        else:                        # −Sᵀ k e + u e_0 + w − f e_bit = 0 (weights balanced)
            loads += self._w
            loads[0] += u
        x[:ne] = np.linalg.lstsq(self._S.T * self._k, loads, rcond=None)[0]
        self.x = x
        self._u = float(u)
        self._nu = 0.0

    def continue_from(self, other: ChainObserver) -> ChainObserver:
        """Take over the state and held input of a filter of the same chain (re-tuned
        parameters, same elements); returns self."""
        if other.nx != self.nx:
            raise ValueError('the filters model different chains')
        self.x, self._u = other.x.copy(), other._u
        self._nu = other._nu
        return self

    def predict(self):
        """Advance one period with the input held (no measurement)."""
        self.x = (self.F @ self.x + self.G[:, 0] * self._u + self.G[:, 1]
                  + self.cross_gain * self._nu)
        self._nu = 0.0

    def update(self, u: float, y: float) -> float:
        """Advance one period with the input ``u`` held since the last sample, then correct
        with the measurement ``y``; returns the innovation."""
        self.predict()
        nu = y - (self.H @ self.x + self.D * u)
        self.x = self.x + self.gain * nu
        self._nu = nu             # the held input's noise, seen in ν, enters the next step
        self._u = float(u)
        return nu

    def lookahead(self, index: int, steps: int) -> Lookahead:
        """State ``index`` predicted at ``steps`` instants evenly spaced over the coming
        period (the last one the next sample's prior): the hold's transition over
        ``Δt/steps`` applied ``j`` times, the covariance grown from the steady posterior by
        the same steps (the bit force's random walk and the held input's noise).  The
        correlated-noise term of the next prediction (``cross_gain`` times the last
        innovation) is left out: it is known only as a lump over the whole period."""
        F, G, Q = self._discretise(self.A, self.B, self.force_rate_std ** 2,
                                   self.period_s / steps)
        Q = Q + self.input_std ** 2 * np.outer(G[:, 0], G[:, 0])
        row = np.eye(self.nx)[index]
        rows, held, const, std = [], [0.0], [0.0], []
        P = self.P
        for _ in range(steps):
            held.append(held[-1] + row @ G[:, 0])
            const.append(const[-1] + row @ G[:, 1])
            row = row @ F
            rows.append(row)
            P = F @ P @ F.T + Q
            std.append(np.sqrt(max(P[index, index], 0.0)))
        return Lookahead(np.array(rows), np.array(held[1:]), np.array(const[1:]),
                         np.array(std))

    def std(self, index: int) -> float:
        """Posterior standard deviation of state ``index``."""
        return float(np.sqrt(max(self.P[index, index], 0.0)))

    def clamp_below(self, index: int, value: float = 0.0) -> bool:
        """Project the estimate on ``x[index] >= value`` (the conditional mean given the
        constraint, with the filter's covariance); True if it was active."""
        gap = self.x[index] - value
        if gap >= 0.0:
            return False
        self.x -= self.P[:, index] * (gap / self.P[index, index])
        return True
