"""Bit/rock interface law of Detournay & Defourny (thesis eqs 2.2.4-2.2.9, 2.4.10-2.4.11).

Dimensionless, in total (not perturbed) quantities: depth of cut per blade
``δ`` (units d*), weight on bit ``W`` (units W*), torque on bit ``T`` (units
C, see :mod:`drill_twin.physics.parameters`):

    W = n_b δ⁺ + W_f,         T = n_b δ⁺ + β W_f,

where ``δ⁺ = δ`` while the blades engage rock (δ > 0) and 0 otherwise (bit
bounce / off bottom: no cutting, no wear-flat contact), and the wear-flat
force ``W_f`` is set-valued on the bit axial velocity V:

    V > 0: W_f = n_b λ;     V < 0: W_f = 0;     V = 0: W_f ∈ [0, n_b λ]

(the last from the axial force balance, thesis §3.3).  The torque of the
wear flats is ``β W_f`` because ``T_f/C = a μ γ W_f /(2C) = μγζ W_f/W*``.

These are tiny pure jitted functions used by the integrator kernel.
"""
from __future__ import annotations

from numba import njit

__all__ = ['cutting_force', 'wear_flat_force', 'bit_weight', 'bit_torque']


@njit(cache=True, nogil=True, inline='always')
def cutting_force(depth_of_cut, n_b, in_contact):
    """Cutting component n_b δ of both W (units W*) and T (units C); 0 off bottom."""
    return n_b * depth_of_cut if in_contact else 0.0


@njit(cache=True, nogil=True, inline='always')
def wear_flat_force(moving_down, in_contact, n_b, lam):
    """Wear-flat contact force W_f while sliding: n_b λ moving down, 0 moving up/off bottom."""
    return n_b * lam if (moving_down and in_contact) else 0.0


@njit(cache=True, nogil=True, inline='always')
def bit_weight(cutting, wear_flat):
    """Weight on bit W = W_c + W_f (eq. 2.2.4)."""
    return cutting + wear_flat


@njit(cache=True, nogil=True, inline='always')
def bit_torque(cutting, wear_flat, beta):
    """Torque on bit T = T_c + T_f = n_b δ + β W_f (eq. 2.2.5, units C)."""
    return cutting + beta * wear_flat
