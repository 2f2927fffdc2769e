"""SI parameter set, characteristic scales and dimensionless groups.

References: thesis Table D.1.1 (values quoted there for L_d = 200 m /
L_b = 100 m are rescaled by the length ratio, which is exact for C ∝ 1/L_d
and I, M ∝ L_b), §3.3 (ω_o = 3.74), Fig. 5.1.2 caption (ψ = 13.79), §3.2
(ξ_opt ≈ 0.06), and eqs 2.2.6-2.2.9, 2.3.4, 2.3.6 evaluated dimensionally here.
"""
import math

import pytest

from drill_twin.config.scenario import load_scenario
from drill_twin.errors import ParameterError
from drill_twin.physics.parameters import BitRockGroups, DrillStringSI, soft_torque_tuning


@pytest.fixture(scope='module')
def bench():
    return load_scenario('benchmark_fem')


def test_section_properties_match_table_d11(bench):
    s = bench.system
    assert s.bha_area_m2 == pytest.approx(0.0156, rel=0.01)
    assert s.pipe_area_m2 == pytest.approx(0.00351, rel=0.01)
    assert s.bha_polar_m4 == pytest.approx(5.19e-5, rel=0.01)
    assert s.pipe_polar_m4 == pytest.approx(1.22e-5, rel=0.01)
    # Table D.1.1: M_b = 12541 kg, I_b = 41.5 kg m^2 for L_b = 100 m
    assert s.bha_mass_kg == pytest.approx(12541 * s.bha_length_m / 100.0, rel=0.01)
    assert s.bha_inertia_kgm2 == pytest.approx(41.5 * s.bha_length_m / 100.0, rel=0.02)
    # Table D.1.1: C = 4700 N m for L_d = 200 m
    assert s.pipe_torsional_stiffness_Nm == pytest.approx(4700 * 200.0 / s.pipe_length_m,
                                                          rel=0.01)


def test_scales_match_thesis(bench):
    sc = bench.scales
    assert sc.time_s == pytest.approx(0.3, rel=0.01)        # Table D.1.1 t*
    assert sc.depth_m == pytest.approx(2.66e-3, rel=0.015)  # Table D.1.1 d*
    assert bench.groups.omega_o == pytest.approx(3.74, rel=0.002)  # §3.3
    assert bench.groups.psi == pytest.approx(13.79, rel=0.01)      # Fig. 5.1.2
    assert bench.groups.n_b * bench.groups.lam == pytest.approx(5.0, rel=0.002)  # §3.3
    assert bench.groups.upsilon_o == pytest.approx(0.47, rel=0.01)  # §3.3


def test_steady_state_equals_dimensional_bit_law(bench):
    """eqs 2.2.6-2.2.9, 2.3.4, 2.3.6 in SI against the dimensionless eqs 2.4.5-2.4.6."""
    s, g, sc = bench.system, bench.groups, bench.scales
    W = bench.raw['operating_point']['weight_on_bit_N']
    Omega = bench.raw['operating_point']['surface_speed_rad_s']
    nb, a, eps, zeta = s.blades, s.bit_radius_m, s.intrinsic_specific_energy_Pa, \
        s.cutting_force_ratio_zeta
    Wf = nb * a * s.wear_flat_length_m * s.contact_stress_Pa            # eq. 2.2.7
    d_o = (W - Wf) / (nb * zeta * a * eps)                               # eq. 2.3.6
    V_o = nb * d_o * Omega / (2 * math.pi)                               # eq. 2.3.4
    T_o = 0.5 * nb * eps * a ** 2 * d_o + 0.5 * nb * a ** 2 * s.friction_coefficient_mu \
        * s.bit_geometry_gamma * s.wear_flat_length_m * s.contact_stress_Pa  # eqs 2.2.8-9
    assert g.delta_o * sc.depth_m == pytest.approx(d_o, rel=1e-12)
    assert g.upsilon_o * sc.speed_m_s == pytest.approx(V_o, rel=1e-12)
    assert g.T_o * sc.torque_Nm == pytest.approx(T_o, rel=1e-12)
    assert g.W_o * sc.force_N == pytest.approx(W, rel=1e-12)
    assert g.tau_10 * sc.time_s == pytest.approx(2 * math.pi / (nb * Omega), rel=1e-12)


def test_rgd_psi_from_first_principles(bench):
    """ψ = ζεa t*²/M: the axial equation M U'' = W_o - W scaled by d*, t*, W*."""
    s, sc = bench.system, bench.scales
    psi = s.cutting_force_ratio_zeta * s.intrinsic_specific_energy_Pa * s.bit_radius_m \
        * sc.time_s ** 2 / s.bha_mass_kg
    assert bench.groups.psi == pytest.approx(psi, rel=1e-12)


def test_soft_torque_tuning(bench):
    s = bench.system
    I_DS = 18160 * (1.867 ** 2 + 1.722 ** 2) / 12  # §2.2.1
    assert s.drive_inertia_kgm2 == pytest.approx(I_DS, rel=1e-12)
    st = soft_torque_tuning(I_DS / s.bha_inertia_kgm2)
    assert st['xi_opt'] == pytest.approx(0.06, rel=0.1)  # §3.2: ξ_opt ≈ 0.06
    # the drive on its spring has the string's first frequency 1/t* (units: 1)
    assert math.sqrt(st['stiffness'] / st['inertia']) == pytest.approx(1.0, rel=1e-12)
    # damping ratio of the drive oscillator equals ξ_opt
    assert st['damping'] / (2 * math.sqrt(st['stiffness'] * st['inertia'])) == \
        pytest.approx(st['xi_opt'], rel=1e-12)


@pytest.mark.parametrize('changes, word', [
    ({'W_o': 4.0}, 'friction threshold'),
    ({'n_b': 0}, 'n_b'),
    ({'omega_o': float('nan')}, 'omega_o'),
    ({'psi': -1.0}, 'psi'),
    ({'lam': float('inf')}, 'lam'),
])
def test_bad_groups_raise_naming_the_parameter(changes, word):
    base = dict(n_b=6, lam=5 / 6, beta=0.3, W_o=7.0, omega_o=5.0, psi=50.0)
    base.update(changes)
    with pytest.raises(ParameterError, match=word):
        BitRockGroups(**base)


@pytest.mark.parametrize('field, value', [
    ('pipe_length_m', -1.0), ('young_modulus_Pa', 0.0), ('density_kg_m3', float('nan')),
    ('blades', 0)])
def test_bad_si_parameters_raise(field, value):
    with pytest.raises(ParameterError, match=field):
        DrillStringSI(**{field: value})


def test_overrides_and_bad_config(tmp_path):
    sc = load_scenario('rgd_stick_slip', ['groups.beta=1.3'])
    assert sc.groups.beta == 1.3
    bad = tmp_path / 'bad.yaml'
    bad.write_text('units: [si\n')
    with pytest.raises(ParameterError, match='malformed YAML'):
        load_scenario(bad)
    with pytest.raises(ParameterError, match='weight_on_bit_N'):
        load_scenario('benchmark_fem', ['operating_point.weight_on_bit_N=-5'])
    with pytest.raises(ParameterError, match='friction threshold'):
        load_scenario('benchmark_fem', ['operating_point.weight_on_bit_N=20000'])
    with pytest.raises(ParameterError, match='model.type .* must be one of'):
        load_scenario('rgd_stick_slip', ['model.type=banana'])


def test_rgd2_config_kappa_is_the_benchmark_value(bench):
    """config/rgd2_stick_slip.yaml states κ_d of the SI benchmark (to 2 digits)."""
    assert load_scenario('rgd2_stick_slip').kappa_d == pytest.approx(bench.kappa_d, abs=0.05)


def test_configuration_doc_is_generated_from_the_schema():
    """docs/configuration.md is `drill-twin config schema` (the schema is the one source)."""
    from pathlib import Path

    from drill_twin.config.schema import schema_markdown
    doc = Path(__file__).resolve().parents[1] / 'docs' / 'configuration.md'
    assert doc.read_text() == schema_markdown()


def test_every_shipped_configuration_validates_and_numbers_are_numbers():
    from drill_twin.config.lookup import CONFIG_DIR
    for path in CONFIG_DIR.glob('*.yaml'):
        sc = load_scenario(path)
        assert sc.raw['units'] in ('si', 'dimensionless')
    sc = load_scenario('benchmark_fem', ['simulation.time_step=5e-3', 'model.elements=116.0',
                                         'model.bha_elements=20'])
    assert sc.time_step == 5e-3 and sc.model.name == 'fem_116'   # 117 nodes, free top
