"""Craig–Bampton reduction of a finite-element chain: the string's step set by accuracy.

Explicit RK4 on a finite-element string must resolve the mesh's stiffest element mode
(ω_max ~ N), although the drilling dynamics live in the string's lowest modes.  All the
forces of a chain act on two DOFs: the top (drive, hook load, block) and the bit (the
interface law).  The Craig–Bampton reduction keeps those two DOFs as physical coordinates
and replaces the interior by its *fixed-interface* modes below a cut-off frequency
(docs/physics.md §5b):

    x = Ψ q_b + Φ η,    Ψ = -K_ii⁻¹ K_ib  (static constraint modes),
    K_ii Φ = M_ii Φ Λ,  Φᵀ M_ii Φ = I      (interior modes, top and bit held),

so the reduced matrices ``Tᵀ M T``, ``Tᵀ C T``, ``Tᵀ K T`` (T = [Ψ Φ] with the boundary
identity) are *arrow* matrices: full rows and columns for the two boundary DOFs, diagonal
among the modes (the constraint modes are K-orthogonal to the fixed-interface modes, and
the damping is Rayleigh inside the string).  The static response to any boundary force is
exact (it lies in the span of Ψ); what is dropped is the dynamic response of the interior
modes above the cut-off.  The kernel integrates the reduced chain with the same RK4, the
same interface law and event location: a stuck bit is still a clamp of a coordinate.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sl

from ..errors import ParameterError
from .models import Chain, StringModel

__all__ = ['ReducedChain', 'reduce_chain', 'reduce_model', 'DEFAULT_CUTOFF',
           'MIN_REDUCED_DOFS']

#: default cut-off of the retained interior modes [rad per t*]: the convergence study of
#: docs/physics.md §5b (stick-slip statistics of FEM-256 within 1 % of the full chain at
#: 250; 2 % at 150, 4 % at 100)
DEFAULT_CUTOFF = 250.0
#: the kernel's arrow solve needs the two boundary DOFs and at least two modes
MIN_REDUCED_DOFS = 4


@dataclass
class ReducedChain:
    """A chain in Craig–Bampton coordinates ``q = [top DOF, η_1 … η_m, bit DOF]``.

    Duck-types :class:`~drill_twin.physics.models.Chain` for the kernel and the linear
    analyses: ``n`` reduced DOFs, :meth:`dense` reduced matrices, the same top couplings.

    Attributes
    ----------
    full : Chain
        The finite-element chain that was reduced.
    basis : ndarray (n_full, n)
        ``T``: physical DOFs = ``basis @ q``.
    frequencies : ndarray (m,)
        Fixed-interface natural frequencies of the retained modes [rad per t*].
    cutoff : float
        The cut-off frequency [rad per t*].
    """

    full: Chain
    basis: np.ndarray
    mass: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray
    frequencies: np.ndarray
    cutoff: float
    form = 'arrow'

    @property
    def n(self) -> int:
        return self.basis.shape[1]

    @property
    def k_top(self) -> float:
        return self.full.k_top

    @property
    def c_top(self) -> float:
        return self.full.c_top

    @property
    def m_top(self) -> float:
        return self.full.m_top

    @property
    def drive_node(self) -> bool:
        return self.full.drive_node

    def dense(self, which: str) -> np.ndarray:
        return getattr(self, which).copy()

    def expand(self, q: np.ndarray) -> np.ndarray:
        """Physical DOF values of reduced coordinates ``q`` (last axis)."""
        return np.asarray(q, float) @ self.basis.T

    def project(self, x: np.ndarray) -> np.ndarray:
        """Reduced coordinates nearest to physical DOF values ``x`` in the kinetic-energy
        norm (exact for any static shape under boundary forces)."""
        M = self.full.dense('mass')
        return np.linalg.solve(self.mass, self.basis.T @ (M @ np.asarray(x, float)))


def _arrow(matrix: np.ndarray, name: str) -> np.ndarray:
    """Check that ``matrix`` couples the modes only through the two boundary DOFs, and
    clean the round-off off the arrow."""
    out = matrix.copy()
    inner = out[1:-1, 1:-1]
    scale = np.sqrt(np.abs(np.outer(np.diag(inner), np.diag(inner)))) + 1e-300
    off = inner - np.diag(np.diag(inner))
    if np.any(np.abs(off) > 1e-8 * scale):
        raise ParameterError(f'reduced {name} matrix is not an arrow matrix: the chain\'s '
                             'damping is not Rayleigh inside the string')
    out[1:-1, 1:-1] = np.diag(np.diag(inner))
    return 0.5 * (out + out.T)


def reduce_chain(chain: Chain, cutoff: float = DEFAULT_CUTOFF) -> ReducedChain:
    """Craig–Bampton reduction of ``chain`` keeping its top and bit DOFs and the interior
    modes with fixed-interface frequency ≤ ``cutoff`` [rad per t*] (at least two).
    ``cutoff = inf`` keeps every mode: the chain's *complete* modal coordinates, an exact
    change of coordinates (``basis`` square and invertible) whose arrow matrices the kernel
    steps with independent per-mode loops instead of the sequential Thomas recurrences."""
    if not cutoff > 0:
        raise ParameterError(f'modal cut-off must be > 0, got {cutoff!r}')
    n = chain.n
    if n < MIN_REDUCED_DOFS:
        raise ParameterError(f'a chain of {n} DOFs is too small to reduce')
    M, C, K = (chain.dense(w) for w in ('mass', 'damping', 'stiffness'))
    inner, ends = np.arange(1, n - 1), np.array([0, n - 1])
    Kii, Mii = K[np.ix_(inner, inner)], M[np.ix_(inner, inner)]
    lam, phi = sl.eigh(Kii, Mii)
    m = max(2, int(np.searchsorted(lam, cutoff ** 2, side='right')))
    m = min(m, inner.size)
    psi = -np.linalg.solve(Kii, K[np.ix_(inner, ends)])
    T = np.zeros((n, m + 2))
    T[0, 0] = T[n - 1, m + 1] = 1.0
    T[1:-1, 0] = psi[:, 0]
    T[1:-1, m + 1] = psi[:, 1]
    T[1:-1, 1:m + 1] = phi[:, :m]
    reduced = [_arrow(T.T @ A @ T, name) for A, name in ((M, 'mass'), (C, 'damping'),
                                                         (K, 'stiffness'))]
    return ReducedChain(chain, T, *reduced, np.sqrt(lam[:m]), float(cutoff))


def reduce_model(model: StringModel, cutoff: float = DEFAULT_CUTOFF) -> StringModel:
    """``model`` with every chain of more than :data:`MIN_REDUCED_DOFS` DOFs reduced
    (:func:`reduce_chain`); the name says the cut-off (``_modal``: every mode kept)."""
    def red(chain):
        if chain is None or chain.n <= MIN_REDUCED_DOFS + 2:
            return chain
        return reduce_chain(chain, cutoff)
    suffix = 'modal' if np.isinf(cutoff) else f'cb{cutoff:g}'
    return dataclasses.replace(model, name=f'{model.name}_{suffix}',
                               axial=red(model.axial), torsional=red(model.torsional))
