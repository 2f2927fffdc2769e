"""Pontryagin/Stépán root counting for axial chains (thesis App. C), independent of
the spectral method.

For ``M u'' + C u' + K u + ψ n_b e (u_b - u_b(τ-h)) = 0`` the characteristic
quasi-polynomial is ``D(λ) = det(λ² M + λ C + K + ψ n_b (1 - e^{-λh}) e eᵀ)``,
of degree n = 2m in λ with the principal term ``det(M) λ^{2m}``.  Write
``D(iω) = R(ω) + i S(ω)`` and let ``ρ_1 > ρ_2 > … > ρ_r ≥ 0`` be the
non-negative real zeros of R.  Pontryagin's theorem, in the counting form of
Stépán (Retarded dynamical systems, 1989, Thm 2.19), gives the number of
characteristic roots with positive real part

    N = m - (-1)^m Σ_k (-1)^k sgn S(ρ_k)

(the argument principle applied to D along the imaginary axis), valid when
S(ρ_k) ≠ 0, i.e. away from the D-curves.  For the 2-DOF case this is the
thesis's Pontryagin check; here it works for any chain without torsion.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from ..physics.models import StringModel
from ..physics.parameters import BitRockGroups

__all__ = ['unstable_root_count']


def _matrices(model: StringModel, groups: BitRockGroups):
    if model.torsional is not None:
        raise ValueError('the Pontryagin count is implemented for axial chains only')
    ch = model.axial
    M, C, K = ch.dense('mass'), ch.dense('damping'), ch.dense('stiffness')
    E = np.zeros_like(K)
    E[-1, -1] = model.psi * groups.n_b
    return M, C, K, E, groups.tau_10


def _D(omega, M, C, K, E, h):
    """D(iω) for a scalar or an array of ω (stacked determinants)."""
    lam = 1j * np.asarray(omega, float)[..., None, None]
    return np.linalg.det(lam ** 2 * M + lam * C + K + (1 - np.exp(-lam * h)) * E)


def unstable_root_count(model: StringModel, groups: BitRockGroups, samples: int = 8000):
    """Number of characteristic roots with Re > 0 (Stépán's formula); None on a D-curve.

    Models with a structural zero root (D(0) = 0, e.g. a free top: no axial
    spring) are rejected with ValueError: the formula needs S(ρ) ≠ 0 at ρ = 0.
    """
    M, C, K, E, h = _matrices(model, groups)
    m = M.shape[0]
    if abs(_D(0.0, M, C, K, E, h)) < 1e-12 * max(1.0, np.abs(K).max()) ** m:
        raise ValueError('D(0) = 0: structural zero root, Stépán count not applicable')
    scale = np.sqrt(np.abs(np.linalg.eigvals(np.linalg.solve(M, K + 2 * E))).max())
    w_max = 20.0 * scale + 20.0 * np.abs(np.linalg.eigvals(np.linalg.solve(M, C))).max() + 50.0
    w = np.linspace(0.0, w_max, samples)
    R = _D(w, M, C, K, E, h).real
    rho = []
    for i in range(len(w) - 1):
        if R[i] == 0.0:
            rho.append(w[i])
        elif R[i] * R[i + 1] < 0:
            rho.append(brentq(lambda x: _D(x, M, C, K, E, h).real, w[i], w[i + 1],
                              xtol=1e-14))
    rho = sorted(rho, reverse=True)
    total = 0
    for k, r in enumerate(rho, start=1):
        s = _D(r, M, C, K, E, h).imag
        if abs(s) < 1e-9 * max(1.0, abs(_D(r + 1e-3, M, C, K, E, h))):
            return None
        total += (-1) ** k * np.sign(s)
    return int(round(m - (-1) ** m * total))
