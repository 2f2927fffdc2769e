"""Early growth of a small perturbation in the *nonlinear* simulation equals the real
part of the rightmost root of the model's own linearisation (within 2 %), at an
unstable and a stable operating point.

The simulation (RK4, bit/rock law, state-dependent delay search) and the
spectrum (Chebyshev collocation + Newton on the characteristic equation) share
only the model matrices, so agreement checks the nonlinear law, the delay
handling, the linearisation (incl. the α_o delay coupling) and the root solver.
"""
import math

import pytest
from helpers import measured_growth_rate

from drill_twin.config.scenario import load_scenario
from drill_twin.physics.models import (
    StringModel,
    axial_chain,
    coupled_chain,
    lumped_chain,
    rgd,
    rgd_k,
)
from drill_twin.physics.parameters import BitRockGroups
from drill_twin.stability.spectrum import rightmost_roots

RGD_POINT = dict(n_b=6, lam=5 / 6, beta=0.3, W_o=7.0, omega_o=5.0, psi=50.0)


def _ab(a, b):
    """(a, b) point of the axial chains: delay 1, n_b ψ = b, κ_d = a - b."""
    return BitRockGroups(n_b=1, lam=0.0, beta=0.0, W_o=1.0, omega_o=2 * math.pi, psi=b), a - b


def _check(model, g, window, h=1e-3):
    root = rightmost_roots(model, g, count=4).roots[0]
    rate = measured_growth_rate(model, g, root, window, h=h)
    assert rate == pytest.approx(root.real, rel=0.02), (model.name, root)
    return root


def test_rgd_unstable_axial_mode():
    g = BitRockGroups(**RGD_POINT)
    assert _check(rgd(50.0), g, (1.0, 4.0)).real > 0


def test_rgd_k_unstable():
    g = BitRockGroups(**RGD_POINT)
    assert _check(rgd_k(50.0, 2.5), g, (1.0, 4.0)).real > 0


def test_rgd_axial_stable_above_critical_speed():
    # constant rotation, ω_o = 1.3 ω_c: every root but the structural zero decays
    psi, n_b = 50.0, 6
    g = BitRockGroups(**dict(RGD_POINT, omega_o=1.3 * math.sqrt(8 * psi / n_b)))
    model = StringModel('rgd_axial', lumped_chain([1.0], [0.0], top_fixed=False), None, psi)
    assert _check(model, g, (0.2, 2.2)).real < 0


@pytest.mark.parametrize('ab, sign, window', [((6.9, 2.96), 1, (5.0, 40.0)),
                                              ((3.45, 2.96), 1, (5.0, 40.0)),
                                              ((0.35, 0.3), -1, (20.0, 100.0))])
def test_axial_two_dof_chain(ab, sign, window):
    g, kappa = _ab(*ab)
    root = _check(axial_chain(2, kappa, g.psi, eps=0.5), g, window)
    assert math.copysign(1, root.real) == sign


def test_rgd2_coupled_chain():
    g = BitRockGroups(**RGD_POINT)
    assert _check(coupled_chain(2, 2.5, 50.0), g, (1.0, 4.0)).real > 0


def test_fem_benchmark_unstable_axial_mode():
    sc = load_scenario('benchmark_fem')
    root = rightmost_roots(sc.model, sc.groups, count=4).roots
    # the second root is ~0.1 slower: wait ~20 t* for the first to dominate
    rate = measured_growth_rate(sc.model, sc.groups, root[0], (20.0, 45.0), h=2e-3,
                                amplitude=1e-9)
    assert rate == pytest.approx(root[0].real, rel=0.02)


def test_fem_stable_point_decays_at_the_root_rate():
    sc = load_scenario('benchmark_fem', ['model.elements=8', 'model.bha_elements=2',
                                         'model.theta_u=0.05', 'model.theta_phi=0.05',
                                         'operating_point.surface_speed_rad_s=60'])
    roots = rightmost_roots(sc.model, sc.groups, count=4).roots
    assert roots[0].real < 0
    rate = measured_growth_rate(sc.model, sc.groups, roots[0], (10.0, 60.0), h=2e-3)
    assert rate == pytest.approx(roots[0].real, rel=0.02)


@pytest.mark.parametrize('overrides, window', [(['model.type=lumped_I'], (5.0, 40.0)),
                                               (['model.type=lumped_II'], (3.0, 18.0)),
                                               (['model.type=lumped_III'], (4.0, 16.0)),
                                               (['model.axial_top=velocity'], (20.0, 45.0))])
def test_lumped_and_velocity_top_models(overrides, window):
    sc = load_scenario('benchmark_fem', overrides)
    roots = rightmost_roots(sc.model, sc.groups, count=4).roots
    rate = measured_growth_rate(sc.model, sc.groups, roots[0], window, h=2e-3,
                                amplitude=1e-9)
    assert rate == pytest.approx(roots[0].real, rel=0.02)


@pytest.mark.parametrize('config, overrides, window', [
    ('axial_chain_2dof', ['model.n=2', 'groups.b=4', 'groups.n_b=3',
                          'bit.blade_angles_deg=[0, 100, 230]'], (10.0, 40.0)),
    ('benchmark_fem', ['bit.blade_angles_deg=[0, 50, 120, 190, 250, 300]'], (20.0, 45.0)),
])
def test_uneven_blades_grow_at_the_rate_of_the_multi_delay_root(config, overrides, window):
    """Blades at uneven angles: each blade group of the bottom surface reads the rock of the
    blade ahead of it; the early growth of the nonlinear run equals the rightmost root of the
    multi-delay linearisation (one delay per blade gap)."""
    sc = load_scenario(config, overrides)
    assert sc.groups.uneven
    roots = rightmost_roots(sc.model, sc.groups, count=4).roots
    rate = measured_growth_rate(sc.model, sc.groups, roots[0], window, h=2e-3,
                                amplitude=1e-9)
    assert rate == pytest.approx(roots[0].real, rel=0.02)
