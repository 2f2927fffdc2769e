"""Characteristic roots of ``y' = A0 y + A1 y(τ - h)`` by Chebyshev collocation.

Method (Breda, Maset & Vermiglio, the IG approach)
--------------------------------------------------
The DDE is the abstract ODE ``z' = 𝒜 z`` on functions over [-h, 0], with
``𝒜 z = z'`` and the domain condition ``z'(0) = A0 z(0) + A1 z(-h)``.  Collocate
``z`` at the N+1 Chebyshev points ``θ_j = h (cos(jπ/N) - 1)/2`` (θ_0 = 0,
θ_N = -h): block row 0 is ``[A0, 0, …, 0, A1]`` and block rows 1…N are the
Chebyshev differentiation matrix ``(2/h) D ⊗ I``.  Eigenvalues of this
n(N+1) matrix converge spectrally to the rightmost characteristic roots.
Each candidate is then refined by Newton on
``Δ(λ) v = 0, cᴴ v = 1`` with ``Δ(λ) = λI - A0 - A1 e^{-λh}``,
``Δ'(λ) = I + h A1 e^{-λh}``; ``error_estimate`` is the largest Newton
correction of the returned roots (distance collocation → root), and the
returned roots satisfy ``σ_min(Δ(λ)) / ||Δ(λ)|| < 1e-10``.
Every drill-string model has a rank-one delay matrix ``A1 = col selᵀ`` (the
delay acts only through the scalar depth of cut), so only that scalar needs
a delay line: the collocation matrix shrinks from n(N+1) to n+N and the
refinement is a scalar Newton iteration on ``1 - e^{-λh} G(λ) = 0`` with the
modal transfer function ``G(λ) = selᵀ(λI - A0)⁻¹col`` (matrix determinant
lemma: det Δ(λ) = det(λI - A0) (1 - e^{-λh} G(λ))).  This is what makes FEM
models with hundreds of elements cheap.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from numba import njit

from ..physics.models import StringModel
from ..physics.parameters import BitRockGroups
from .linearize import LinearDDE, linearize

__all__ = ['cheb', 'collocation_matrix', 'newton_root', 'rightmost_roots', 'RootsResult',
           'adaptive_order',
           'spectral_abscissa', 'critical_speed', 'DEFAULT_ORDER']

#: default collocation order; justified by test_stability.py::test_roots_converge
DEFAULT_ORDER = 24


@functools.lru_cache(maxsize=64)
def cheb(N: int):
    """Chebyshev points ``x_j = cos(jπ/N)`` and differentiation matrix (Trefethen).

    Cached (a chart asks for the same order at every point): read-only arrays."""
    if N == 0:
        D, x = np.zeros((1, 1)), np.ones(1)
    else:
        x = np.cos(np.pi * np.arange(N + 1) / N)
        c = np.hstack([2.0, np.ones(N - 1), 2.0]) * (-1.0) ** np.arange(N + 1)
        X = np.tile(x, (N + 1, 1)).T
        dX = X - X.T
        D = np.outer(c, 1.0 / c) / (dX + np.eye(N + 1))
        D -= np.diag(D.sum(axis=1))
    D.setflags(write=False)
    x.setflags(write=False)
    return D, x


def collocation_matrix(dde: LinearDDE, N: int) -> np.ndarray:
    """The n(N+1) square IG collocation matrix (general delay matrix A1)."""
    n = dde.size
    D, _ = cheb(N)
    D = D * (2.0 / dde.delay)
    A = np.zeros((n * (N + 1), n * (N + 1)))
    A[:n, :n] = dde.A0
    A[:n, n * N:] = dde.A1
    A[n:] = np.kron(D[1:], np.eye(n))
    return A


def rank_one_factors(A1: np.ndarray, rtol: float = 1e-12):
    """``(col, sel)`` with ``A1 = col selᵀ`` if A1 has rank one, else None.

    Every drill-string model has a rank-one delay matrix: the delay enters
    only through the scalar depth-of-cut combination ``s = u_b - α_o φ_b``.
    """
    u, sv, vh = np.linalg.svd(A1)
    if sv[0] == 0.0 or (sv.size > 1 and sv[1] > rtol * sv[0]):
        return None
    return u[:, 0] * sv[0], vh[0]


def reduced_collocation_matrix(dde: LinearDDE, N: int, col, sel) -> np.ndarray:
    """IG collocation for a rank-one delay: state ``[y(0), s(θ_1..θ_N)]``.

    ``y' = A0 y + col s(-h)`` with the scalar ``s = selᵀ y`` stored on the
    Chebyshev grid: size n + N instead of n (N + 1), same spectral accuracy.
    """
    n = dde.size
    D, _ = cheb(N)
    D = D * (2.0 / dde.delay)
    A = np.zeros((n + N, n + N))
    A[:n, :n] = dde.A0
    A[:n, n + N - 1] = col
    A[n:, :n] = np.outer(D[1:, 0], sel)
    A[n:, n:] = D[1:, 1:]
    return A


class _TransferFunction:
    """``G(λ) = selᵀ (λI - A0)⁻¹ col`` in modal form; roots solve e^{-λh} G(λ) = 1."""

    def __init__(self, dde: LinearDDE, col, sel):
        mu, V = dde.modes()
        left = sel @ V
        right = np.linalg.solve(V, col)
        self.mu = mu
        self.p = left * right
        self.h = dde.delay
        scale = np.max(np.abs(self.p)) if self.p.size else 1.0
        # modes that the delay neither excites nor sees are roots by themselves
        self.uncoupled = mu[np.abs(self.p) <= 1e-13 * max(scale, 1e-300)]

    def newton_batch(self, lam0, tol=1e-14, maxit=15):
        """Newton from many starting points (compiled, one candidate at a time); returns the
        roots (NaN where an iterate left the finite plane or the far left half-plane), their
        distances from the starts and the relative residuals |1 - e^{-λh}G| / max(1, |e^{-λh}G|)."""
        start = np.array(lam0, complex).ravel()
        lam = np.empty_like(start)
        rel = np.empty(start.size)
        _newton_scalar(start, self.mu.astype(complex), self.p.astype(complex), float(self.h),
                       tol, maxit, lam, rel)
        return lam, np.abs(lam - start), rel


@njit(cache=True, error_model='numpy')
def _transfer(z, mu, p, h):
    """1 - e^{-zh} G(z), its derivative and e^{-zh} G(z) (G = Σ p_j / (z - μ_j))."""
    g = 0j
    dg = 0j
    for j in range(mu.size):
        d = z - mu[j]
        if d == 0:          # on a pole: no finite value (rejected by the caller)
            nan = complex(np.nan, np.nan)
            return nan, nan, nan
        g += p[j] / d
        dg -= p[j] / (d * d)
    e = np.exp(-z * h)
    return 1.0 - e * g, e * (h * g - dg), e * g


@njit(cache=True, error_model='numpy')
def _newton_scalar(start, mu, p, h, tol, maxit, lam, rel):
    """Newton on 1 - e^{-λh} G(λ) = 0 from each start (see ``newton_batch``)."""
    for k in range(start.size):
        z = start[k]
        ok = np.isfinite(z.real) and np.isfinite(z.imag)
        if ok:
            for _ in range(maxit):
                fv, dfv, _ = _transfer(z, mu, p, h)
                if dfv == 0:
                    ok = False
                    break
                step = -fv / dfv
                z = z + step
                if not (np.isfinite(z.real) and np.isfinite(z.imag)) or z.real * h < -700:
                    ok = False
                    break
                if abs(step) <= tol * max(1.0, abs(z)):
                    break
        if not ok:
            lam[k] = complex(np.nan, np.nan)
            rel[k] = np.inf
            continue
        lam[k] = z
        fv, _, eg = _transfer(z, mu, p, h)
        rel[k] = abs(fv) / max(1.0, abs(eg))
        if not np.isfinite(rel[k]):
            rel[k] = np.inf


def newton_root(dde: LinearDDE, lam0: complex, tol: float = 1e-13, maxit: int = 30):
    """Refine a characteristic root by Newton on (Δ(λ)v = 0, cᴴv = 1).

    Returns ``(root, correction, relative_residual)``; ``correction`` is the
    distance from ``lam0``.
    """
    n = dde.size
    h = max(tau for _, tau in dde.terms())
    lam = complex(lam0)
    if not (np.isfinite(lam) and lam.real * h > -700):
        return complex(np.nan, np.nan), np.inf, np.inf
    M = dde.characteristic_matrix(lam)
    _, s, vh = np.linalg.svd(M)
    v = vh[-1].conj()
    c = v.copy()
    v = v / (c.conj() @ v)
    for _ in range(maxit):
        Dl = dde.characteristic_matrix(lam)
        dDl = np.eye(n, dtype=complex)
        for B, tau in dde.terms():
            dDl = dDl + tau * B * np.exp(-lam * tau)
        J = np.zeros((n + 1, n + 1), complex)
        J[:n, :n] = Dl
        J[:n, n] = dDl @ v
        J[n, :n] = c.conj()
        rhs = -np.concatenate([Dl @ v, [c.conj() @ v - 1.0]])
        try:
            step = np.linalg.solve(J, rhs)
        except np.linalg.LinAlgError:
            break
        v = v + step[:n]
        lam = lam + step[n]
        if not (np.isfinite(lam) and lam.real * h > -700):
            return complex(np.nan, np.nan), np.inf, np.inf
        if abs(step[n]) <= tol * max(1.0, abs(lam)):
            break
    M = dde.characteristic_matrix(lam)
    smin = np.linalg.svd(M, compute_uv=False)[-1]
    rel = smin / max(np.linalg.norm(M, 2), 1e-300)
    return lam, abs(lam - lam0), rel


@dataclass
class RootsResult:
    """Rightmost characteristic roots (sorted by decreasing real part)."""

    roots: np.ndarray
    abscissa: float
    error_estimate: float
    order: int
    zero_root: bool


def multi_delay_collocation_matrix(dde: LinearDDE, N: int) -> np.ndarray:
    """IG collocation for several rank-one delayed terms ``col_k sel_kᵀ y(τ - τ_k)``.

    Each scalar ``s_k = sel_kᵀ y`` gets its own Chebyshev grid on [-τ_k, 0]:
    size n + K N (the K = 1 case is :func:`reduced_collocation_matrix`).
    """
    n = dde.size
    terms = dde.terms()
    A = np.zeros((n + len(terms) * N, n + len(terms) * N))
    A[:n, :n] = dde.A0
    D0, _ = cheb(N)
    for k, (B, tau) in enumerate(terms):
        col, sel = rank_one_factors(B)
        o = n + k * N
        D = D0 * (2.0 / tau)
        A[:n, o + N - 1] += col
        A[o:o + N, :n] = np.outer(D[1:, 0], sel)
        A[o:o + N, o:o + N] = D[1:, 1:]
    return A


def _collocation_eigs(dde: LinearDDE, N: int, factors):
    if dde.extra:
        return sla.eigvals(multi_delay_collocation_matrix(dde, N))
    if factors is not None:
        return sla.eigvals(reduced_collocation_matrix(dde, N, *factors))
    return sla.eigvals(collocation_matrix(dde, N))


def adaptive_order(dde: LinearDDE, minimum: int = DEFAULT_ORDER, cap: int = 1024) -> int:
    """Collocation order whose resolved band |Im λ| < πN/(2h) covers the fastest mode.

    The band limit is that of the candidate filter in :func:`rightmost_roots`;
    the fastest mode is the largest |Im| of the eigenvalues of A0, with 30 % margin.
    """
    w_max = float(np.max(np.abs(dde.modes()[0].imag), initial=0.0))
    need = int(np.ceil(1.3 * 2.0 * max(t for _, t in dde.terms()) * w_max / np.pi))
    return int(min(max(minimum, need), cap))


def rightmost_roots(model_or_dde, groups: BitRockGroups | None = None, count: int = 6,
                    order: int | None = None, seeds=None) -> RootsResult:
    """Rightmost characteristic roots of a model's linearisation (or of a LinearDDE).

    The structural zero root (hook-load top: a rigid axial shift is a
    solution; on a = b in the (a, b) chains) is detected through the
    singularity of Δ(0) and left out of ``abscissa`` and ``roots``.
    ``seeds`` (e.g. the roots at a neighbouring parameter point) are refined
    by Newton along with the collocation eigenvalues.  ``order=None`` picks
    :func:`adaptive_order`, so that no mode of the model lies outside the
    resolved frequency band.
    """
    dde = model_or_dde if isinstance(model_or_dde, LinearDDE) else linearize(model_or_dde,
                                                                             groups)
    if order is None:
        order = adaptive_order(dde)
    factors = None if dde.extra else rank_one_factors(dde.A1)
    eig = _collocation_eigs(dde, order, factors)
    eig = eig[np.isfinite(eig)]
    # keep candidates well resolved by the collocation: |Im| below the grid resolution
    limit = 0.5 * np.pi * order / max(tau for _, tau in dde.terms())
    cand = eig[np.abs(eig.imag) < limit]
    cand = cand[np.argsort(-cand.real)][:count + 8]
    if seeds is not None and len(seeds):
        cand = np.concatenate([np.asarray(seeds, complex), cand])
    M0 = dde.characteristic_matrix(0.0)
    s0 = np.linalg.svd(M0, compute_uv=False)
    zero_root = s0[-1] <= 1e-10 * max(s0[0], 1.0)
    tf = _TransferFunction(dde, *factors) if factors is not None else None
    if tf is not None and tf.uncoupled.size:
        cand = np.concatenate([cand, tf.uncoupled])
        cand = cand[np.argsort(-cand.real)]
    cand = cand[cand.imag >= -1e-9]  # conjugates are added back below
    if tf is not None:
        near = np.abs(cand[:, None] - tf.uncoupled[None, :]) < \
            1e-12 * np.maximum(1.0, np.abs(cand))[:, None]
        coupled = ~near.any(axis=1)
        refined = np.empty(cand.size, complex)
        corrs = np.zeros(cand.size)
        rels = np.zeros(cand.size)
        refined[coupled], corrs[coupled], rels[coupled] = tf.newton_batch(cand[coupled])
        refined[~coupled] = cand[~coupled]
        results = list(zip(refined, corrs, rels))
    else:
        results = [newton_root(dde, z) for z in cand]
    roots, errs = [], []
    for r, corr, rel in results:
        if rel > 1e-8 or not np.isfinite(r):
            continue
        if zero_root and abs(r) < 1e-7:
            continue
        if any(abs(r - q) < 1e-8 * max(1.0, abs(r)) for q in roots):
            continue
        roots.append(r.real + 1j * abs(r.imag) if abs(r.imag) > 1e-12 else complex(r.real))
        errs.append(corr)
    full = []
    for r, e in zip(roots, errs):
        full.append((r, e))
        if r.imag > 0:
            full.append((r.conjugate(), e))
    full = sorted(full, key=lambda item: (-item[0].real, -item[0].imag))[:count]
    out = np.array([r for r, _ in full])
    abscissa = float(out[0].real) if out.size else float('-inf')
    err = float(max(e for _, e in full)) if full else float('nan')
    return RootsResult(out, abscissa, err, order, bool(zero_root))


def spectral_abscissa(model: StringModel, groups: BitRockGroups,
                      order: int | None = None) -> float:
    """Largest real part of the characteristic roots (zero root excluded)."""
    return rightmost_roots(model, groups, count=2, order=order).abscissa


def critical_speed(model: StringModel, groups: BitRockGroups, omega_min: float = 0.5,
                   omega_max: float = 50.0, hold: str = 'W_o', samples: int = 60,
                   rtol: float = 1e-10):
    """Lowest ω_o above which steady drilling stays stable up to ``omega_max``.

    ω_o is swept with ``W_o`` held (``hold='W_o'``) or with ``υ_o`` held
    (``hold='upsilon_o'``); the last stable→unstable change going down from
    ``omega_max`` is bisected to ``rtol``.  Returns None if ``omega_max`` is
    itself unstable.
    """
    def groups_at(w):
        if hold == 'W_o':
            return groups.replace(omega_o=w)
        W = groups.n_b * groups.lam + 2 * np.pi * groups.upsilon_o / w
        return groups.replace(omega_o=w, W_o=W)

    def stable(w):
        return spectral_abscissa(model, groups_at(w)) < 0.0

    grid = np.geomspace(omega_min, omega_max, samples)[::-1]
    if not stable(grid[0]):
        return None
    hi = grid[0]
    lo = None
    for w in grid[1:]:
        if not stable(w):
            lo = w
            break
        hi = w
    if lo is None:
        return float(omega_min)
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        if stable(mid):
            hi = mid
        else:
            lo = mid
    return float(0.5 * (lo + hi))
