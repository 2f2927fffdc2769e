"""The wall's Coulomb friction on one node of the string: the implicit (Moreau–Jean)
impulse of one step, in closed form.

Derivation: docs/physics.md §9.  A node of lumped masses ``m_a`` (axial) and ``m_t``
(tangential, the torsional inertia seen at the contact radius) slides on the wall with
the velocity vector y = (y_a, y_t) (axial speed, rim speed r ω), dimensionless.  Over a
step h the wall gives it the impulse P ∈ -h F Sgn(y⁺) (F = μ n, Sgn the set-valued sign
of a vector: y/|y| for y ≠ 0, the closed unit disc at 0), taken at the step's *end*
velocity y⁺ (implicit, eq. 9.4).  With the momentum p = (m_a y*_a, m_t y*_t) that the
step's smooth forces alone would give (the predictor y*), eq. 9.4 is the optimality
condition of the strictly convex problem

    min_y ½ m_a (y_a - y*_a)² + ½ m_t (y_t - y*_t)² + h F |y|               (9.5)

whose one solution is (eqs 9.6-9.7)

* stick, y⁺ = 0, when |p| ≤ h F (the disc holds the impulse): exactly zero, no
  velocity threshold;
* slide otherwise, y⁺_k = p_k s / (m_k s + h F) for k = a, t, with s = |y⁺| > 0 the one
  root of G(s) = Σ_k (p_k / (m_k s + h F))² - 1, decreasing and convex in s, so Newton's
  method converges from any s₀ > 0 (from the right of the root its first step lands left
  of it, and from the left it rises monotonically).  s₀ = (|p| - h F)|p|²/Σ m_k p_k², the
  root of the problem with the momentum-weighted mass, is the root itself when the masses
  are equal or one component is zero; otherwise two or three steps reach round-off.

Static and dynamic friction: a node that stuck at the end of the previous step is
held while |p| ≤ h μ_s n (the static capacity); once it slides, the impulse is
h μ(|y|) n with the sliding coefficient of eq. 9.9, μ(v) = μ_d + (μ_s - μ_d) exp(-v/v_S)
(Stribeck's velocity weakening over the speed v_S; v_S = 0: μ_d at once, the two-level
law), taken at the speed of the step's start: the magnitude explicit, the direction and
the stick implicit, first order like the scheme.  At v = 0 the law is μ_s, the static
capacity: the stick set is the same disc for every v_S, and no speed below which a node
counts as stuck exists.  Everything here is compiled (numba), scalars in and out.
"""
from __future__ import annotations

import math

from .jit import kernel_jit

__all__ = ['project_node', 'sliding_friction', 'sliding_friction_slope']


@kernel_jit(inline='always')
def project_node(p_a, p_t, m_a, m_t, hold, slide):
    """The end-of-step velocity (y_a, y_t) of a node under the wall's friction, and
    whether it sticks (eqs 9.6-9.7).

    Parameters
    ----------
    p_a, p_t : float
        Momentum of the predictor velocity, m_a y*_a and m_t y*_t (dimensionless).
    m_a, m_t : float
        The node's axial and tangential masses (> 0).
    hold : float
        The impulse the wall can hold: h μ_s n for a node stuck at the step's start,
        h μ_d n for a sliding one.
    slide : float
        The impulse of sliding friction, h μ_d n (≤ ``hold``).

    Returns
    -------
    (y_a, y_t, stuck) : (float, float, bool)
    """
    pp = p_a * p_a + p_t * p_t
    p = math.sqrt(pp)
    if p <= hold:
        return 0.0, 0.0, True
    # Newton from the root of the isotropic problem with the momentum-weighted mass: the
    # root itself when one component is zero or the masses are equal (then one check)
    s = (p - slide) * pp / (m_a * p_a * p_a + m_t * p_t * p_t)
    for _ in range(40):
        da = m_a * s + slide
        dt = m_t * s + slide
        ga = p_a / da
        gt = p_t / dt
        g = ga * ga + gt * gt - 1.0
        dg = -2.0 * (m_a * ga * ga / da + m_t * gt * gt / dt)
        step = -g / dg if dg < 0.0 else 0.0
        s += step
        if not abs(step) > 1e-15 * s:
            break
    return p_a * s / (m_a * s + slide), p_t * s / (m_t * s + slide), False


@kernel_jit(inline='always')
def sliding_friction(static, dynamic, stribeck, speed):
    """The sliding friction force F(v) = F_d + (F_s - F_d) exp(-v/v_S) of a node sliding at
    ``speed`` v (eq. 9.9); F_d when ``stribeck`` v_S is 0 (the two-level law).

    Parameters
    ----------
    static, dynamic : float
        μ_s n and μ_d n (force units, F_d ≤ F_s).
    stribeck : float
        v_S ≥ 0, the speed over which the friction weakens (velocity units).
    speed : float
        v = |y| ≥ 0.
    """
    if stribeck > 0.0:
        return dynamic + (static - dynamic) * math.exp(-speed / stribeck)
    return dynamic


def sliding_friction_slope(static, dynamic, stribeck, speed):
    """dF/dv of eq. 9.9 at ``speed`` (the linearisation's velocity dependence; ≤ 0)."""
    if stribeck > 0.0:
        return -(static - dynamic) / stribeck * math.exp(-speed / stribeck)
    return 0.0
