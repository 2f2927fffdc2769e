"""Linear stability: analytic D-curves, the RGD critical speed, thesis verdicts,
the corrected eq. 5.1.1 matrices, and convergence of the collocation."""
import math

import numpy as np
import pytest

from drill_twin.config.scenario import load_scenario
from drill_twin.physics.models import StringModel, axial_chain, coupled_chain, lumped_chain
from drill_twin.physics.parameters import BitRockGroups
from drill_twin.stability.linearize import LinearDDE, linearize
from drill_twin.stability.spectrum import (
    DEFAULT_ORDER,
    critical_speed,
    newton_root,
    rightmost_roots,
)


def scalar_dde(a, b, p=0.0):
    """u'' + p u' + a u - b u(t-1) = 0 (thesis Fig. 4.1.2)."""
    return LinearDDE(np.array([[0.0, 1.0], [-a, -p]]), np.array([[0.0, 0.0], [b, 0.0]]), 1.0,
                     ['u', 'du'])


@pytest.mark.parametrize('k', [1, 2, 3, 4])
@pytest.mark.parametrize('b', [0.3, 2.0, 7.5])
def test_d_curves_are_analytic(k, b):
    """On a = k²π² + (-1)^k b the DDE has the imaginary root ikπ.

    Substituting u = e^{iωt}: -ω² + a - b e^{-iω} = 0, so b sin ω = 0 (ω = kπ) and
    a = k²π² + (-1)^k b.  For k = 1 this is a = π² - b, the right boundary of the
    stable triangle quoted in thesis §4.3.  (The issue text writes -(-1)^k b: a sign
    slip; with it, a = π² + b carries no imaginary root.)
    """
    a = k ** 2 * math.pi ** 2 + (-1) ** k * b
    root, _, rel = newton_root(scalar_dde(a, b), 1j * k * math.pi + 0.01)
    assert abs(root.real) < 1e-10 and root.imag == pytest.approx(k * math.pi, rel=1e-12)
    assert rel < 1e-12


def test_zero_root_on_a_equals_b():
    res = rightmost_roots(scalar_dde(2.0, 2.0))
    assert res.zero_root and np.all(np.abs(res.roots) > 1e-6)


def test_rgd_axial_critical_speed_is_analytic():
    """ω_c = sqrt(8ψ/n_b): on a = b = 4π²ψ/(n_b ω²) the first crossing is a = π²/2."""
    for psi, n_b in ((50.0, 6), (13.79, 4)):
        g = BitRockGroups(n_b=n_b, lam=1.0 / n_b, beta=0.3, W_o=7.0, omega_o=5.0, psi=psi)
        model = StringModel('rgd_axial', lumped_chain([1.0], [0.0], top_fixed=False), None, psi)
        wc = critical_speed(model, g, 0.5, 60.0)
        assert wc == pytest.approx(math.sqrt(8 * psi / n_b), rel=1e-6)


def _chain(n, a, b, eps):
    g = BitRockGroups(n_b=1, lam=0.0, beta=0.0, W_o=1.0, omega_o=2 * math.pi, psi=b)
    return axial_chain(n, a - b, b, eps=eps), g


@pytest.mark.parametrize('ab, stable', [((0.35, 0.3), True), ((3.45, 2.96), False),
                                        ((6.9, 2.96), False)])
def test_two_dof_verdicts_of_the_thesis(ab, stable):
    """§4.2.3 / Fig. 4.2.5: ε = 0.5 chain."""
    model, g = _chain(2, *ab, 0.5)
    assert (rightmost_roots(model, g).abscissa < 0) == stable


def test_point_is_inside_the_one_dof_stable_region():
    model, g = _chain(1, 6.9, 2.96, None)
    assert rightmost_roots(model, g).abscissa < 0
    # and the same point seen as u'' + a u - b u(t-1): same spectrum
    assert rightmost_roots(scalar_dde(6.9, 2.96)).abscissa == pytest.approx(
        rightmost_roots(model, g).abscissa, abs=1e-10)


def test_rgd2_matrices_are_eq_5_1_1_with_its_sign_errors_corrected():
    kd, psi, nb = 2.5, 50.0, 6
    g = BitRockGroups(n_b=nb, lam=5 / 6, beta=0.3, W_o=7.0, omega_o=5.0, psi=psi)
    al = g.alpha_o
    dde = linearize(coupled_chain(2, kd, psi), g)
    acc = [2, 3, 6, 7]      # rows of u1'', u2'', φ1'', φ2''
    pos = [0, 1, 4, 5]      # columns of u1, u2, φ1, φ2
    A0 = dde.A0[np.ix_(acc, pos)]
    A1 = dde.A1[np.ix_(acc, pos)]
    # eq. 5.1.1 as printed, except A0[3,3] = -4 + 2 n_b α_o and A1[1,3] = -2 n_b ψ α_o
    A0_ref = np.array([[-8 * kd, 4 * kd, 0, 0],
                       [4 * kd, -2 * (2 * kd + nb * psi), 0, 2 * nb * psi * al],
                       [0, 0, -8, 4],
                       [0, -2 * nb, 4, -4 + 2 * nb * al]])
    A1_ref = np.array([[0, 0, 0, 0],
                       [0, 2 * nb * psi, 0, -2 * nb * psi * al],
                       [0, 0, 0, 0],
                       [0, 2 * nb, 0, -2 * nb * al]])
    np.testing.assert_allclose(A0, A0_ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(A1, A1_ref, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize('name', ['rgd', 'chain2', 'rgd2', 'fem58'])
def test_roots_converge_with_collocation_order(name):
    """The raw collocation eigenvalue approaches the Newton-refined root spectrally;
    at DEFAULT_ORDER the distance is below 1e-8 (this justifies the default)."""
    if name == 'fem58':
        sc = load_scenario('benchmark_fem')
        model, g = sc.model, sc.groups
    elif name == 'chain2':
        model, g = _chain(2, 6.9, 2.96, 0.5)
    else:
        sc = load_scenario('rgd_stick_slip' if name == 'rgd' else 'rgd2_stick_slip')
        model, g = sc.model, sc.groups
    errs = [rightmost_roots(model, g, count=2, order=N).error_estimate for N in (6, 12)]
    final = rightmost_roots(model, g, count=2, order=DEFAULT_ORDER)
    assert final.error_estimate < 1e-8
    assert final.error_estimate < errs[0]
    higher = rightmost_roots(model, g, count=2, order=DEFAULT_ORDER + 16)
    assert higher.roots[0] == pytest.approx(final.roots[0], abs=1e-8)


def test_chart_of_the_one_dof_system_is_the_analytic_triangle():
    """Fig. 4.1.2 (p = 0): stable iff b < a < π² - b (D-curves k = 0, 1)."""
    from drill_twin.stability.charts import stability_chart
    raw = load_scenario('axial_chain_2dof', ['model.n=1']).raw
    xs, ys = np.linspace(0.5, 12.0, 24), np.linspace(0.2, 6.0, 15)
    chart = stability_chart(raw, 'groups.a', xs, 'groups.b', ys, workers=2)
    A, B = np.meshgrid(xs, ys)
    np.testing.assert_array_equal(chart.unstable == 0, (B < A) & (A < math.pi ** 2 - B))


def test_pontryagin_count_agrees_with_the_spectral_count():
    """App. C: independent root counting for the 2-DOF chain on a grid (away from
    D-curves, |abscissa| > 0.01)."""
    from drill_twin.stability.pontryagin import unstable_root_count
    checked = 0
    for eps in (0.2, 0.5, 0.8):
        for a in np.linspace(0.5, 40.0, 12):
            for b in np.linspace(0.2, 12.0, 7):
                if a - b < 1e-3:
                    continue
                model, g = _chain(2, a, b, eps)
                res = rightmost_roots(model, g, count=20)
                if abs(res.abscissa) < 0.01:
                    continue
                assert unstable_root_count(model, g) == int(np.sum(res.roots.real > 0))
                checked += 1
    assert checked > 150


@pytest.mark.parametrize('omega, upsilon', [(5.0, 0.05), (10.0, 0.5), (30.0, 2.0)])
def test_undamped_rgd_torsional_growth_scales_with_upsilon_over_psi_squared(omega, upsilon):
    """Reference: the large-ψ asymptote derived in docs/stability.md,
    Re λ = α_o cot(τ_1,0/2)/(4 n_b ψ²) (≈ υ_o/(4πψ²)); at ψ = 200 the torsional root of the
    collocation agrees to 1 %."""
    import math

    from drill_twin.physics.models import rgd
    psi, n_b, n_b_lam = 200.0, 4, 4.0
    g = load_scenario('rgd_stick_slip').groups.replace(
        psi=psi, n_b=n_b, lam=n_b_lam / n_b, omega_o=omega,
        W_o=n_b_lam + 2 * math.pi * upsilon / omega)
    roots = rightmost_roots(rgd(psi), g, count=12).roots
    torsional = min(roots, key=lambda z: abs(abs(z.imag) - 1.0))
    tau, alpha = 2 * math.pi / (n_b * omega), upsilon / omega
    assert torsional.real == pytest.approx(alpha / math.tan(tau / 2) / (4 * n_b * psi ** 2),
                                           rel=0.01)
