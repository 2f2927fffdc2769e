"""``drill-twin config`` (the schema, a check) and ``params`` (derived scales and groups)."""
from __future__ import annotations

import json
import math

from ..errors import ParameterError
from .scenario import load_scenario


def add_config_arguments(sp, required: bool = True):
    """``--config`` (a file or a name in config/) and repeatable ``--set KEY=VALUE``."""
    sp.add_argument('--config', required=required,
                    help='YAML file, or a name in config/ (e.g. benchmark_fem)')
    sp.add_argument('--set', action='append', default=[], metavar='KEY=VALUE',
                    help='override a configuration value (dotted key), repeatable')


def cmd_config(args) -> int:
    """``config schema``: the configuration keys as Markdown; ``config check``: validate a
    configuration with its overrides and print it resolved (YAML)."""
    if args.action == 'schema':
        from .schema import schema_markdown
        print(schema_markdown(), end='')
        return 0
    if not args.config:
        raise ParameterError('config check needs --config FILE')
    import yaml
    scenario = load_scenario(args.config, args.set)
    print(yaml.safe_dump(scenario.raw, sort_keys=False), end='')
    return 0


#: field units: pound-force [N], foot [m], foot-pound-force [N m], pounds per US gallon
#: [kg/m^3]
LBF, FT, FT_LBF, PPG = 4.4482216152605, 0.3048, 1.3558179483314, 119.826427


def cmd_params(args) -> int:
    scenario = load_scenario(args.config, args.set)
    g = scenario.groups
    out = {'n_b': g.n_b, 'lambda': g.lam, 'n_b_lambda': g.n_b * g.lam, 'beta': g.beta,
           'psi': g.psi, 'W_o': g.W_o, 'omega_o': g.omega_o, 'upsilon_o': g.upsilon_o,
           'delta_o': g.delta_o, 'T_o': g.T_o, 'tau_10': g.tau_10, 'alpha_o': g.alpha_o,
           'kappa_d': scenario.kappa_d}
    if scenario.is_si:
        s, sys_ = scenario.scales, scenario.system
        out.update({'t_star_s': s.time_s, 'd_star_m': s.depth_m, 'W_star_N': s.force_N,
                    'torque_scale_C_Nm': s.torque_Nm, 'T_star_zetaC_Nm': s.force_N *
                    sys_.bit_radius_m / 2, 'bha_mass_kg': s.mass_kg,
                    'bha_inertia_kgm2': s.inertia_kgm2,
                    'drive_inertia_kgm2': sys_.drive_inertia_kgm2,
                    'rate_of_penetration_m_s': g.upsilon_o * s.speed_m_s,
                    'rate_of_penetration_m_h': g.upsilon_o * s.speed_m_s * 3600,
                    'G_u': (sys_.pipe_length_m + sys_.bha_length_m) ** 2 / s.time_s ** 2
                    * sys_.density_kg_m3 / sys_.young_modulus_Pa,
                    'G_phi': (sys_.pipe_length_m + sys_.bha_length_m) ** 2 / s.time_s ** 2
                    * sys_.density_kg_m3 / sys_.shear_modulus_Pa})
        # the same operating point in the units a driller reads (API field units)
        rop = g.upsilon_o * s.speed_m_s
        out['field_units'] = {
            'surface_speed_rpm': g.omega_o / s.time_s * 60.0 / (2.0 * math.pi),
            'weight_on_bit_klbf': g.W_o * s.force_N / LBF / 1e3,
            'torque_on_bit_kft_lbf': g.T_o * s.torque_Nm / FT_LBF / 1e3,
            'rate_of_penetration_ft_h': rop * 3600.0 / FT,
            'string_weight_in_mud_klbf': sys_.buoyed_weight_N() / LBF / 1e3,
            'string_length_ft': sys_.total_length_m / FT,
            'mud_density_ppg': sys_.mud_density_kg_m3 / PPG}
    print(json.dumps(out, indent=None if args.json else 2))
    return 0


def register(sub):
    """Add ``config``, ``params`` to the ``drill-twin`` sub-parsers ``sub``."""
    s = sub.add_parser('config', help='the configuration schema, or check a configuration')
    s.add_argument('action', choices=['schema', 'check'])
    s.add_argument('--config', help='check: YAML file, or a name in config/')
    s.add_argument('--set', action='append', default=[], metavar='KEY=VALUE')
    s.set_defaults(func=cmd_config)
    s = sub.add_parser('params', help='print derived scales and dimensionless groups')
    add_config_arguments(s)
    s.add_argument('--json', action='store_true')
    s.set_defaults(func=cmd_params)
