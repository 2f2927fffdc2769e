"""A chain's mass, damping and stiffness packed for the kernel, and its accelerations.

Every external force on a chain acts on its top DOF (drives, hook load) or its bit DOF
(the interface law), so the kernel needs one operation of a chain: the accelerations
``a = M⁻¹ (e_top f_top + e_bit f_bit − C q̇ − K q)`` (:func:`accelerations`), in O(n):

* a tridiagonal chain (:class:`~drill_twin.physics.models.Chain`): the Thomas recurrences
  with the factors of M, computed once (:func:`pack_chain`);
* an arrow chain (the Craig–Bampton or complete modal form of
  :mod:`~drill_twin.physics.reduction`: the top and bit rows full, the modes diagonal):
  each mode on its own, and the 2 x 2 Schur complement of the top and bit DOFs.

The packed array (``CHAIN.size`` x n, rows named by
:data:`~drill_twin.physics.layout.CHAIN`) also holds ``z = M⁻¹ e_bit`` (the compliance of
the bit: the Lagrange multiplier of a stuck bit) and, for an arrow chain, what the torque
in the string's first element needs (its couplings and node 1 in chain coordinates).
"""
from __future__ import annotations

import numpy as np

from .jit import kernel_jit
from .layout import CHAIN, CHAIN_FORMS, FORM, TRIPLE, indices

__all__ = ['pack_chain', 'accelerations', 'SCHUR']

#: entries of the inverse 2 x 2 boundary Schur complement of an arrow chain, row-major,
#: in ``chain[CHAIN.thomas, :4]``
SCHUR = indices('Schur', ('top_top', 'top_bit', 'bit_top', 'bit_bit'))


def pack_chain(chain) -> np.ndarray:
    """Pack a :class:`~drill_twin.physics.models.Chain` (tridiagonal) or a
    :class:`~drill_twin.physics.reduction.ReducedChain` (arrow) for the kernel
    (``CHAIN.size`` x n), with ``z = M⁻¹ e_last`` (the compliance of the last DOF, for the
    Lagrange multiplier of a stuck bit)."""
    if chain is None:
        return np.zeros((CHAIN.size, 0))
    n = chain.n
    out = np.zeros((CHAIN.size, n))
    if getattr(chain, 'form', 'tridiagonal') == 'arrow':
        _pack_arrow(chain, out)
    else:
        _pack_tridiagonal(chain, out)
    z = np.empty(n)
    rest = np.zeros(n)
    accelerations(out, rest, rest, 0.0, 1.0, z)
    out[CHAIN.compliance] = z
    return out


def _pack_tridiagonal(chain, out):
    n = chain.n
    out[CHAIN.mass:CHAIN.mass + len(TRIPLE)] = chain.mass
    out[CHAIN.damping:CHAIN.damping + len(TRIPLE)] = chain.damping
    out[CHAIN.stiffness:CHAIN.stiffness + len(TRIPLE)] = chain.stiffness
    lo, d, up = chain.mass
    cp = out[CHAIN.thomas]
    inv = out[CHAIN.inverse]
    for i in range(n):
        den = d[i] - (lo[i] * cp[i - 1] if i > 0 else 0.0)
        if not den > 0:
            raise ValueError('mass matrix is not positive definite')
        inv[i] = 1.0 / den
        cp[i] = up[i] * inv[i] if i < n - 1 else 0.0
    lumped = not (np.any(lo[1:]) or np.any(up[:-1]))
    out[CHAIN.form, FORM.kind] = CHAIN_FORMS.diagonal if lumped else CHAIN_FORMS.tridiagonal


def _pack_arrow(chain, out):
    n = chain.n
    for row, A in ((CHAIN.mass, chain.mass), (CHAIN.damping, chain.damping),
                   (CHAIN.stiffness, chain.stiffness)):
        out[row + TRIPLE.lower] = A[0]              # the top row
        out[row + TRIPLE.diagonal] = np.diag(A)
        out[row + TRIPLE.upper] = A[-1]             # the bit row
    M = chain.mass
    d = np.diag(M)[1:-1]
    if not np.all(d > 0):
        raise ValueError('mass matrix is not positive definite')
    P = M[np.ix_([0, n - 1], range(1, n - 1))]
    schur = M[np.ix_([0, n - 1], [0, n - 1])] - (P / d) @ P.T
    if not np.all(np.linalg.eigvalsh(schur) > 0):
        raise ValueError('mass matrix is not positive definite')
    out[CHAIN.thomas, 0:len(SCHUR)] = np.linalg.inv(schur).ravel()
    out[CHAIN.inverse, 1:-1] = 1.0 / d
    out[CHAIN.form, FORM.kind] = CHAIN_FORMS.arrow
    full = chain.full
    out[CHAIN.form, FORM.top_stiffness] = full.stiffness[TRIPLE.upper, 0]
    out[CHAIN.form, FORM.top_damping] = full.damping[TRIPLE.upper, 0]
    out[CHAIN.node1] = chain.basis[1]


@kernel_jit(inline='always')
def accelerations(ch, q, qd, f_top, f_bit, out):
    """The chain's accelerations ``out = M⁻¹ (e_top f_top + e_bit f_bit − C q̇ − K q)``.
    A single mass (RGD): a few multiply-adds, inlined where they are used; a longer
    chain: :func:`_accelerations_chain`, compiled once and called (its O(n) loops outweigh
    a call, and inlining them at each of the four call sites of the right-hand side
    multiplied the kernel's compile time)."""
    n = q.size
    if n == 0:
        return
    if n == 1:      # a lumped mass (RGD): top and bit are the one DOF
        c = ch[CHAIN.damping + TRIPLE.diagonal, 0]
        k = ch[CHAIN.stiffness + TRIPLE.diagonal, 0]
        out[0] = ((-(c * qd[0] + k * q[0]) + f_top) + f_bit) * ch[CHAIN.inverse, 0]
        return
    _accelerations_chain(ch, q, qd, f_top, f_bit, out)


@kernel_jit
def _accelerations_chain(ch, q, qd, f_top, f_bit, out):
    """:func:`accelerations` of a chain of n >= 2 DOFs: the Thomas recurrences with the
    precomputed factors of a tridiagonal chain, or :func:`_accelerations_arrow`."""
    if ch[CHAIN.form, FORM.kind] == CHAIN_FORMS.arrow:
        _accelerations_arrow(ch, q, qd, f_top, f_bit, out)
        return
    n = q.size
    c_lo, c_d, c_up = (ch[CHAIN.damping + TRIPLE.lower], ch[CHAIN.damping + TRIPLE.diagonal],
                       ch[CHAIN.damping + TRIPLE.upper])
    k_lo, k_d, k_up = (ch[CHAIN.stiffness + TRIPLE.lower],
                       ch[CHAIN.stiffness + TRIPLE.diagonal],
                       ch[CHAIN.stiffness + TRIPLE.upper])
    for i in range(n):
        s = c_d[i] * qd[i] + k_d[i] * q[i]
        if i > 0:
            s += c_lo[i] * qd[i - 1] + k_lo[i] * q[i - 1]
        if i < n - 1:
            s += c_up[i] * qd[i + 1] + k_up[i] * q[i + 1]
        out[i] = -s
    out[0] += f_top
    out[n - 1] += f_bit
    inv = ch[CHAIN.inverse]
    if ch[CHAIN.form, FORM.kind] == CHAIN_FORMS.diagonal:    # lumped masses: M⁻¹ is inv
        for i in range(n):
            out[i] *= inv[i]
        return
    lo = ch[CHAIN.mass + TRIPLE.lower]
    cp = ch[CHAIN.thomas]
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
    m_top, m_bit = ch[CHAIN.mass + TRIPLE.lower], ch[CHAIN.mass + TRIPLE.upper]
    inv = ch[CHAIN.inverse]
    c_top, c_diag, c_bit = (ch[CHAIN.damping + TRIPLE.lower],
                            ch[CHAIN.damping + TRIPLE.diagonal],
                            ch[CHAIN.damping + TRIPLE.upper])
    k_top, k_diag, k_bit = (ch[CHAIN.stiffness + TRIPLE.lower],
                            ch[CHAIN.stiffness + TRIPLE.diagonal],
                            ch[CHAIN.stiffness + TRIPLE.upper])
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
    schur = ch[CHAIN.thomas]
    a0 = schur[SCHUR.top_top] * r0 + schur[SCHUR.top_bit] * rb
    ab = schur[SCHUR.bit_top] * r0 + schur[SCHUR.bit_bit] * rb
    out[0] = a0
    out[b] = ab
    for j in range(1, b):
        out[j] -= (m_top[j] * a0 + m_bit[j] * ab) * inv[j]
