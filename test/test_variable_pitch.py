"""Uneven blade spacing (variable pitch, §6.2): the multi-delay linearisation against an
independent count of the characteristic roots in the right half-plane.

Reference: the argument principle on ``f(s) = s² + a - (b/2)(e^{-s τ1} + e^{-s τ2})``,
``τ1,2 = 1 ∓ δ/180°`` (the 1-DOF axial model of ch. 4 with two blades at 0° and
180° + δ, mean delay 1) — a winding number along a half-disc that holds every root with
Re s > 0 (there |e^{-sτ}| ≤ 1, so |s|² ≤ a + b); nothing of the package is used.
"""
import numpy as np
import pytest

from drill_twin.config.scenario import load_scenario
from drill_twin.stability.spectrum import rightmost_roots


def right_half_plane_roots(a, b, delta_deg, eps=1e-9, samples=400_001):
    t1, t2 = 1 - delta_deg / 180, 1 + delta_deg / 180

    def f(s):
        return s * s + a - 0.5 * b * (np.exp(-s * t1) + np.exp(-s * t2))

    radius = np.sqrt(abs(a) + b) + 3.0
    up = eps + 1j * np.linspace(-radius, radius, samples)
    around = eps + radius * np.exp(1j * np.linspace(np.pi / 2, -np.pi / 2, samples))
    phase = np.unwrap(np.angle(f(np.concatenate([up, around]))))
    return -round((phase[-1] - phase[0]) / (2 * np.pi))   # the contour runs clockwise


def abscissa(a, b, delta_deg):
    sc = load_scenario('axial_chain_2dof', [
        'model.n=1', 'model.damping=0.0', 'groups.n_b=2', f'groups.a={a}', f'groups.b={b}',
        f'bit.blade_angles_deg=[0, {180.0 + delta_deg}]'])
    return rightmost_roots(sc.model, sc.groups, count=2).abscissa


@pytest.mark.parametrize('a, b, delta', [
    (30.0, 6.0, 60.0), (30.0, 6.0, 0.0), (30.0, 6.0, 40.0), (25.0, 10.0, 60.0),
    (35.0, 2.0, 60.0), (15.0, 2.0, 60.0), (5.0, 2.0, 0.0), (5.0, 2.0, 60.0),
    (7.0, 5.0, 20.0), (3.0, 0.5, 40.0)])
def test_stability_of_uneven_blades_agrees_with_the_argument_principle(a, b, delta):
    count = right_half_plane_roots(a, b, delta)
    sigma = abscissa(a, b, delta)
    assert abs(sigma) > 1e-6  # not on the boundary: the sign is meaningful
    assert (count > 0) == (sigma > 0), (count, sigma)


def test_sixty_degrees_of_pitch_opens_a_stable_region_the_even_bit_lacks():
    """At a = 30 the even bit is unstable for every b in the chart; δ = 60° is stable."""
    for b in (1.0, 4.0, 8.0, 11.0):
        assert right_half_plane_roots(30.0, b, 0.0) > 0
        assert right_half_plane_roots(30.0, b, 60.0) == 0
        assert abscissa(30.0, b, 60.0) < 0 < abscissa(30.0, b, 0.0)
