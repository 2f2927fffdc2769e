"""Craig–Bampton reduction of finite-element strings (issue 18, docs/physics.md §5b).

References are independent of the code under test: eigenvalues and static solutions of
the full finite-element matrices with numpy/scipy, dense linear algebra for the kernel's
arrow solves, and the full chain integrated by the RK4 kernel (the reference method)."""
import numpy as np
import pytest
import scipy.linalg as sl
from helpers import roundoff_bound

from drill_twin.config.scenario import load_scenario
from drill_twin.errors import ConfigError, ParameterError
from drill_twin.physics.chain import accelerations, pack_chain
from drill_twin.physics.layout import CHAIN
from drill_twin.physics.reduction import reduce_chain, reduce_model
from drill_twin.physics.simulation import Simulation


@pytest.fixture(scope='module')
def fem():
    return load_scenario('benchmark_fem', ['simulation.time_step=auto',
                                           'simulation.reduction=none'])


def _frequencies(chain):
    lam = sl.eigh(chain.dense('stiffness'), chain.dense('mass'), eigvals_only=True)
    return np.sqrt(np.abs(lam))


@pytest.mark.parametrize('which', ['axial', 'torsional'])
def test_low_frequencies_converge_to_the_full_chain(fem, which):
    """The reduced chain's lowest natural frequencies approach the full chain's from above
    (Rayleigh–Ritz: the reduced basis is a subspace) and the error falls with the
    cut-off."""
    chain = getattr(fem.model, which)
    full = _frequencies(chain)[:6]
    errors = []
    for cutoff in (30.0, 60.0, 120.0):
        red = _frequencies(reduce_chain(chain, cutoff))[:6]
        assert np.all(red >= full - 1e-6 * full.max())   # rigid mode: eigen-solver noise
        errors.append(np.max((red - full)[full > 1e-6] / full[full > 1e-6]))
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 2e-4


@pytest.mark.parametrize('which', ['axial', 'torsional'])
def test_static_response_to_boundary_forces_is_exact(fem, which):
    """Forces on the top and bit DOFs (all the forces a chain carries): the reduced static
    solution expanded to the nodes equals the full finite-element solution."""
    chain = getattr(fem.model, which)
    red = reduce_chain(chain, 40.0)
    n = chain.n
    f = np.zeros(n)
    f[0], f[-1] = 0.7, -1.3
    Kf = chain.dense('stiffness')
    if which == 'axial':   # free top (hook load): pin the top to remove the rigid mode
        Kf = Kf + np.diag(np.r_[1.0, np.zeros(n - 1)])
    Kr = red.dense('stiffness') + (np.diag(np.r_[1.0, np.zeros(red.n - 1)])
                                   if which == 'axial' else 0.0)
    q = np.linalg.solve(Kr, np.r_[f[0], np.zeros(red.n - 2), f[-1]])
    # exact in exact arithmetic; two dense solves of condition κ(K) ~ n² = 3e3 (a chain of
    # 58 elements, pinned): round-off κ ε ~ 1e-12 relative, whatever the BLAS
    np.testing.assert_allclose(red.expand(q), np.linalg.solve(Kf, f), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(red.project(red.expand(q)), q, rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize('cutoff', [60.0, np.inf, None])
def test_kernel_accelerations_match_dense_algebra(fem, cutoff):
    """The kernel's chain accelerations M⁻¹(e_top f_top + e_bit f_bit − C q' − K q) against
    dense numpy, for a reduced chain, the complete modal form (``inf``) and the tridiagonal
    chain (None), and z = M⁻¹ e_bit (the stuck bit's Lagrange multiplier)."""
    model = fem.model if cutoff is None else reduce_model(fem.model, cutoff)
    rng = np.random.default_rng(3)
    for chain in (model.axial, model.torsional):
        packed = pack_chain(chain)
        q, qd = (rng.standard_normal(chain.n) for _ in range(2))
        f_top, f_bit = rng.standard_normal(2)
        out = np.empty(chain.n)
        accelerations(packed, q, qd, f_top, f_bit, out)
        force = -(chain.dense('damping') @ qd + chain.dense('stiffness') @ q)
        force[0] += f_top
        force[-1] += f_bit
        # the kernel's O(n) solve against a dense LU of the same mass matrix (κ(M) ~ 10 for
        # consistent masses; the modal form's Schur complement and modes come from LAPACK):
        # round-off ~ n κ ε ~ 1e-13
        np.testing.assert_allclose(out, np.linalg.solve(chain.dense('mass'), force),
                                   rtol=1e-10, atol=1e-10)
        e = np.zeros(chain.n)
        e[-1] = 1.0
        # with every mode kept, a mode without participation at the bit has z_j = 0 up to
        # round-off (~1e-12 of the largest entry): compared absolutely, at that scale
        z = packed[CHAIN.compliance]
        zero = 1e-12 * np.abs(z).max() if np.isinf(cutoff or 0.0) else 0.0
        np.testing.assert_allclose(z, np.linalg.solve(chain.dense('mass'), e), rtol=1e-10,
                                   atol=zero)


#: the benchmark's spectral abscissa at its operating point [1/t*] (docs/stability.md:
#: 0.1576, rounded up): how fast round-off committed on the smooth interval can grow
BENCHMARK_GROWTH_RATE = 0.16


def test_complete_modal_form_is_the_full_chain(fem):
    """Every mode kept, x = T q is a change of coordinates and RK4 is covariant under it:
    FEM-58 in modal coordinates (what ``time_step: auto`` integrates) follows the full
    tridiagonal chain at the same step to round-off on a smooth interval (τ < 30); through
    the first sticks (τ = 30 … 40) the two stay within 1e-4 (round-off decides whether a
    grazing contact registers: measured 3e-6).

    The smooth interval's tolerance is round-off, not a guess: 6000 steps that order their
    sums differently, each committing ~ε of the state's scale, grown at most by the
    unstable steady state's e^(0.16 τ) = 120 over τ = 30 (:func:`helpers.roundoff_bound`:
    1.6e-10).  Measured: 8e-13 (native BLAS), 1.3e-12 with OpenBLAS's SSE3 kernels
    (``OPENBLAS_CORETYPE=Prescott``) and 1.1e-12 on an AVX-512 Xeon — the modal basis comes
    from LAPACK, whose round-off differs by CPU; the former bound of 1e-12 was below it."""
    modal = load_scenario('benchmark_fem', ['simulation.time_step=auto'])
    assert modal.integrated_model.name == 'fem_58_modal'
    assert modal.integrated_model.torsional.n == fem.model.torsional.n
    runs = []
    for sc in (fem, modal):
        sim = Simulation.from_scenario(sc, time_step=0.005)
        runs.append((sim.run(30.0, 0.05), sim.run(10.0, 0.05), sim))
    (smooth_a, late_a, full), (smooth_b, late_b, red) = runs
    assert full.event_count == red.event_count > 0
    smooth = roundoff_bound(int(round(30.0 / 0.005)), BENCHMARK_GROWTH_RATE, 30.0)
    for a, b, tol in ((smooth_a, smooth_b, smooth), (late_a, late_b, 1e-4)):
        for channel in ('bit_angular_speed', 'bit_axial_speed', 'weight_on_bit',
                        'surface_torque'):
            x, y = getattr(a, channel), getattr(b, channel)
            assert np.max(np.abs(x - y)) <= tol * np.max(np.abs(x)), channel


def _tracking_error(scenario, cutoff):
    """Largest difference of the bit's angular speed, axial speed and weight (relative to
    the channel's largest value) between the reduced string at 0.005 t* and the full chain
    under RK4 at 0.00125 t*, both from the same smooth perturbation of steady drilling (the
    reduced perturbation expanded to the nodes), from τ = 2 to 5 (no stick)."""
    reduced = reduce_model(scenario.model, cutoff)
    red = Simulation(reduced, scenario.groups, 0.005)
    red.perturb(where='smooth', **scenario.initial_perturbation)
    full = Simulation(scenario.model, scenario.groups, 0.00125)
    rs = red.slices()
    full.set_perturbation_state(np.concatenate(
        [getattr(reduced, chain).expand(red.x[rs[name]])
         for name, chain in (('u', 'axial'), ('v', 'axial'), ('phi', 'torsional'),
                             ('omega', 'torsional'))]))
    runs = [sim.run(5.0, 0.05) for sim in (full, red)]
    assert full.event_count == red.event_count == 0
    late = runs[0].tau >= 2.0
    errors = []
    for channel in ('bit_angular_speed', 'bit_axial_speed', 'weight_on_bit'):
        a, b = (getattr(r, channel)[late] for r in runs)
        errors.append(np.max(np.abs(a - b)) / np.max(np.abs(a)))
    return max(errors)


def test_reduced_string_follows_the_full_string_on_a_smooth_interval():
    """FEM-256: the bit of the reduced string tracks the full chain's, and closer with a
    higher cut-off (what is dropped is the ringing of the interior modes above it)."""
    sc = load_scenario('benchmark_fem', ['model.elements=256', 'model.bha_elements=43',
                                         'simulation.time_step=auto',
                                         'simulation.reduction=none'])
    coarse, default = _tracking_error(sc, 100.0), _tracking_error(sc, 250.0)
    assert default < coarse
    assert default < 2e-3


def test_auto_step_picks_the_reduction_for_finite_element_strings():
    """``time_step: auto`` reduces a string whose mesh resolves more than the cut-off keeps
    (FEM-256); one whose every mode but one lies below it (FEM-58) runs in its complete
    modal coordinates; lumped models are not reduced; an explicit step or ``reduction:
    none`` integrates the full chain (the RK4 reference)."""
    fine = ['model.elements=256', 'model.bha_elements=43']
    sc = load_scenario('benchmark_fem', fine + ['simulation.time_step=auto'])
    assert sc.simulated_model is not None and sc.integrated_model.name == 'fem_256_cb250'
    assert sc.model.torsional.n == 256          # linear analyses keep the full chain
    assert sc.time_step == pytest.approx(5e-3)   # the RK4 limit of the full chain: 2.5e-3
    assert load_scenario('benchmark_fem', ['simulation.time_step=auto']) \
        .integrated_model.name == 'fem_58_modal'
    assert load_scenario('benchmark_fem', fine + ['simulation.time_step=1e-3']) \
        .simulated_model is None
    assert load_scenario('benchmark_fem', fine + ['simulation.time_step=auto',
                                                  'simulation.reduction=none']) \
        .simulated_model is None
    assert load_scenario('rgd_stick_slip', ['simulation.time_step=auto']).simulated_model \
        is None
    sim = Simulation.from_scenario(sc)
    assert sim.n_torsional == sc.simulated_model.torsional.n < 256


@pytest.mark.parametrize('bad', ['simulation.modal_cutoff=-1', 'simulation.modal_cutoff=nan',
                                 'simulation.reduction=modal'])
def test_bad_reduction_settings_are_refused(bad):
    with pytest.raises(ConfigError):
        load_scenario('benchmark_fem', [bad])


def test_reduction_of_a_lumped_model_is_refused_in_one_line(tmp_path):
    """`reduction: craig_bampton` on a model without finite elements: exit code 2 and one
    line naming the key."""
    import subprocess
    import sys
    proc = subprocess.run([sys.executable, '-m', 'drill_twin.cli', 'simulate', '--config',
                           'rgd_stick_slip', '--set', 'simulation.reduction=craig_bampton',
                           '--out', str(tmp_path / 'x.npz')], capture_output=True, text=True)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and 'simulation.reduction' in lines[0]


def test_reduce_chain_refuses_what_it_cannot_reduce(fem):
    with pytest.raises(ParameterError):
        reduce_chain(fem.model.torsional, 0.0)
    with pytest.raises(ParameterError):
        reduce_chain(load_scenario('rgd2_stick_slip').model.axial, 60.0)
