"""The cubic Hermite interpolant of one integration step (the dense output of the
kernel's steps): value and slope at both ends of a step of length ``h`` give the value
at the fraction ``s`` in [0, 1] of the step.  Shared by the bottom-hole surface (blade
angles, heights) and the velocity time history of model III."""
from __future__ import annotations

from .jit import kernel_jit

__all__ = ['hermite', 'hermite_slope']


@kernel_jit(inline='always')
def hermite(y0, y1, d0, d1, h, s):
    """Value at ``s`` of the cubic with values ``y0, y1`` and slopes ``d0, d1`` (per unit
    of the step variable) at the ends of a step of length ``h``."""
    s2 = s * s
    s3 = s2 * s
    return ((2 * s3 - 3 * s2 + 1) * y0 + (s3 - 2 * s2 + s) * h * d0
            + (-2 * s3 + 3 * s2) * y1 + (s3 - s2) * h * d1)


@kernel_jit(inline='always')
def hermite_slope(y0, y1, d0, d1, h, s):
    """d/ds of :func:`hermite` (s in [0, 1])."""
    s2 = s * s
    return ((6 * s2 - 6 * s) * y0 + (3 * s2 - 4 * s + 1) * h * d0
            + (-6 * s2 + 6 * s) * y1 + (3 * s2 - 2 * s) * h * d1)
