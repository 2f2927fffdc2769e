"""Scenarios: a model, an operating point and run settings, loaded from YAML.

Two kinds of configuration files live in ``config/``:

``units: si``
    A physical drilling system (:class:`DrillStringSI` fields under
    ``drill_string``), an operating point ``operating_point.surface_speed_rad_s``
    [rad/s] and ``operating_point.weight_on_bit_N`` [N]; every dimensionless
    group is derived in code.  Times in ``simulation`` are in seconds.
``units: dimensionless``
    The research configurations of thesis ch. 4-5: ``groups`` holds ψ, n_b,
    λ (or ``n_b_lambda``), β, W_o, ω_o (or ``a``, ``b`` for the axial chains:
    delay 1, κ_d = a - b, n_b ψ = b) and ``kappa_d``; times are in t*.

Overrides use dotted keys (``groups.beta=1.3``, ``model.elements=128``).
Every key is checked against :mod:`drill_twin.config.schema` (types, units,
ranges, required keys, unknown keys with the nearest valid name); every error
is one line naming the file (or ``--set``), the key, the value and the rule.
"""
from __future__ import annotations

import copy
import functools
import json
import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..control.tuning import tune_gains
from ..errors import ConfigError, ParameterError
from ..physics.models import (
    StringModel,
    axial_chain,
    coupled_chain,
    fem_drill_string,
    lumped_bha,
    lumped_chain,
    max_stable_step,
    pipe_impedances,
    rgd,
    rgd_k,
)
from ..physics.parameters import BitRockGroups, DrillStringSI, Scales, StringSection
from ..physics.reduction import DEFAULT_CUTOFF, reduce_model
from ..physics.top_drive import DriveGains, TopDrive, mode_gains
from .lookup import resolve_config
from .schema import DRIVE, validate
from .well import wall_of, well_of
from .yaml_bounds import MAX_YAML_DEPTH, parse_yaml, read_yaml, shown

__all__ = ['Scenario', 'load_scenario', 'scenario_from_dict', 'apply_overrides', 'with_values',
           'read_config']


@dataclass
class Scenario:
    """Everything needed to run one simulation."""

    model: StringModel
    groups: BitRockGroups
    time_step: float
    duration: float
    record_interval: float
    initial_perturbation: dict
    perturb_where: str = 'bit'
    scales: Scales | None = None
    system: DrillStringSI | None = None
    kappa_d: float | None = None
    raw: dict = field(default_factory=dict)
    #: the model the time integration runs when it is not ``model`` itself: the
    #: Craig–Bampton reduction of a finite-element string (:mod:`~drill_twin.physics.
    #: reduction`), chosen with ``time_step: auto``; linear analyses use ``model``
    simulated_model: StringModel | None = None
    #: the nodes of a finite-element string in contact with the wall of a deviated well
    #: (:func:`~drill_twin.physics.wall_contact.pack_wall`), the contact forces those of
    #: the statics at the operating point's weight on bit (:meth:`wall_at` for another);
    #: None in a vertical well
    wall: object | None = None
    #: the surveyed well path of a string with wall friction (``well.survey``, read once);
    #: None otherwise (:func:`~drill_twin.config.well.scenario_well` gives the path then)
    well_path: object | None = None

    @property
    def integrated_model(self) -> StringModel:
        """The model :class:`~drill_twin.physics.simulation.Simulation` integrates."""
        return self.simulated_model or self.model

    def wall_at(self, weight_on_bit_N: float):
        """The wall contact (as ``wall``) with the contact forces of the statics at another
        weight on bit [N] (0: off bottom); None in a vertical well."""
        if self.wall is None:
            return None
        return wall_of(self.raw, self.system, self.model, self.scales, weight_on_bit_N,
                       self.well_path)

    @property
    def is_si(self) -> bool:
        return self.scales is not None

    @property
    def stability_only(self) -> bool:
        """The semi-infinite string of §5.2 has no bit mass: linear analysis only."""
        return self.model.name == 'semi_infinite'

    def impedances(self) -> dict:
        """Pipe radiation impedances (chain units) of lumped/semi-infinite models."""
        return _impedances(self.raw.get('model') or {}, self.system)

    @property
    def time_unit_s(self) -> float:
        return self.scales.time_s if self.scales else 1.0


def _set_key(out: dict, key: str, value, label: str):
    """Set the dotted ``key`` of ``out`` to ``value`` (sections created as needed); a key
    deeper than :data:`MAX_YAML_DEPTH` levels is refused, as in a file."""
    node = out
    parts = key.split('.')
    if not key or any(not part for part in parts):
        raise ConfigError(f'{label}: {key!r} is not a dotted key (e.g. model.elements)')
    if len(parts) > MAX_YAML_DEPTH:
        raise ConfigError(f'{label}: the key has {len(parts)} levels, more than '
                          f'{MAX_YAML_DEPTH} (no configuration key is deeper than 4)')
    for i, part in enumerate(parts[:-1]):
        node = node.setdefault(part, {})
        if not isinstance(node, dict):
            raise ConfigError(f'{label}: {".".join(parts[:i + 1])} is not a section')
    node[parts[-1]] = value


def apply_overrides(raw: dict, overrides, origin: dict | None = None,
                    label: str = '--set') -> dict:
    """Return a copy of ``raw`` with ``KEY=VALUE`` strings (dotted keys) applied; the
    values are YAML, read with the bounds of a file (:func:`parse_yaml`).  ``origin`` (if
    given) records ``{key: '--set KEY=VALUE'}`` for error messages."""
    out = copy.deepcopy(raw) if isinstance(raw, dict) else raw
    for item in overrides or ():
        if not isinstance(item, str) or '=' not in item:
            raise ConfigError(f'{label} {shown(item)}: not KEY=VALUE (e.g. '
                              'model.elements=128)')
        key, value = item.split('=', 1)
        key = key.strip()
        where = f'{label} {shown(item, 60)}'
        parsed = parse_yaml(value, where, 'the value is not valid YAML')
        if not isinstance(out, dict):
            raise ConfigError(f'{where}: the configuration is not a mapping')
        _set_key(out, key, parsed, where)
        if origin is not None:
            origin[key] = where
    return out


def with_values(raw: dict, values: dict) -> dict:
    """A copy of ``raw`` with ``{dotted key: value}`` set (values as Python objects, not
    YAML text: what a sweep assigns at each point)."""
    out = copy.deepcopy(raw)
    for key, value in values.items():
        _set_key(out, key, value, f'{key}={value!r}')
    return out


def _groups_from(g: dict, where: str):
    """BitRockGroups and κ_d from a validated ``groups`` section (either of its two forms)."""
    if 'a' in g or 'b' in g:
        extra = sorted(set(g) & {'psi', 'omega_o', 'n_b_lambda', 'kappa_d'})
        if 'a' not in g or 'b' not in g:
            raise ConfigError(f'{where}: groups needs both a and b (the axial-chain plane)')
        if extra:
            raise ConfigError(f'{where}: groups.{extra[0]} does not go with groups.a/b (the '
                              'axial-chain plane fixes the delay to 1, ω_o = 2π/n_b, '
                              'κ_d = a - b, n_b ψ = b)')
        n_b = g.get('n_b', 1)
        lam = g.get('lambda', 0.0)
        groups = BitRockGroups(n_b=n_b, lam=lam, beta=g.get('beta', 0.0),
                               W_o=g.get('W_o', n_b * (lam + 1.0)),
                               omega_o=2.0 * math.pi / n_b, psi=g['b'] / n_b)
        return groups, g['a'] - g['b']
    if ('lambda' in g) == ('n_b_lambda' in g):
        raise ConfigError(f'{where}: groups needs exactly one of lambda and n_b_lambda')
    for key in ('psi', 'n_b', 'beta', 'W_o', 'omega_o'):
        if key not in g:
            raise ConfigError(f'{where}: missing required key groups.{key}')
    lam = g['lambda'] if 'lambda' in g else g['n_b_lambda'] / g['n_b']
    groups = BitRockGroups(n_b=g['n_b'], lam=lam, beta=g['beta'], W_o=g['W_o'],
                           omega_o=g['omega_o'], psi=g['psi'])
    return groups, g.get('kappa_d')


def _system_from(cfg: dict) -> DrillStringSI:
    """The SI drilling system of a validated configuration: its sections (materials
    defaulting to the string's) or the two-section pipe + BHA, and the bit's blade angles."""
    ds = dict(cfg['drill_string'])
    sections = ds.pop('sections', None)
    if sections:
        material = {k: ds[k] for k in ('density_kg_m3', 'young_modulus_Pa', 'shear_modulus_Pa')}
        ds['sections'] = tuple(StringSection(**{**material, **sec}) for sec in sections)
        if not any(sec.get('bha') for sec in sections):
            ds['sections'] = ds['sections'][:-1] + (
                replace(ds['sections'][-1], bha=True),)
    angles = (cfg.get('bit') or {}).get('blade_angles_deg')
    if angles:
        ds['blade_angles_rad'] = tuple(math.radians(a) for a in angles)
    return DrillStringSI(**ds)


def _top_drive(cfg: dict, system, groups: BitRockGroups):
    """The :class:`~drill_twin.physics.top_drive.TopDrive` of ``drive`` (model.top_drive:
    motor; absent keys take the schema's defaults); a ``stability_tuned`` controller gets
    its gains from the stability module, explicit gains replace the mode's."""
    d = {k.name: k.default for k in DRIVE.keys}
    d.update({k: v for k, v in (cfg.get('drive') or {}).items() if v is not None})
    J = d['motor_inertia_kgm2'] or system.drive_inertia_kgm2
    mode, bandwidth = d['controller'], d['speed_loop_bandwidth_rad_s']
    drive = TopDrive(mode, J, d['torque_limit_Nm'], bandwidth, d['sensor_delay_s'],
                     d['torque_filter_s'], mode_gains(mode, system, J, bandwidth))
    explicit = ('proportional_gain_Nms_rad', 'integral_gain_Nm_rad', 'torque_feedback_rad_s_Nm')
    if mode == 'stability_tuned' and all(d[k] is None for k in explicit):
        drive = drive.with_gains(_stability_tuned_gains(cfg))
    g = drive.gains
    mode_values = (g.proportional_Nms_rad, g.integral_Nm_rad, g.torque_feedback_rad_s_Nm)
    return drive.with_gains(DriveGains(*(v if d[k] is None else d[k]
                                         for k, v in zip(explicit, mode_values))))


def _stability_tuned_gains(cfg: dict) -> DriveGains:
    """The gains that :func:`drill_twin.control.tuning.tune_gains` finds for the string of
    ``cfg`` with the Soft-Torque controller as its start (computed once per configuration
    and operating point in a process)."""
    start = copy.deepcopy(cfg)
    d = start.setdefault('drive', {})
    d['controller'] = 'soft_torque'
    for key in ('proportional_gain_Nms_rad', 'integral_gain_Nm_rad',
                'torque_feedback_rad_s_Nm'):
        d.pop(key, None)
    return _tuned_gains(json.dumps(start, sort_keys=True, default=str))


@functools.lru_cache(maxsize=16)
def _tuned_gains(key: str) -> DriveGains:
    sc = scenario_from_dict(json.loads(key), 'stability tuning')
    gains, _ = tune_gains(sc.model, sc.groups, sc.system)
    return gains


def _build_model(m: dict, groups: BitRockGroups, kappa_d, system, rig=None, drive=None,
                 well=None, lumped=False):
    kind = m['type']
    if m.get('axial_top') == 'hoist' and (kind != 'fem' or system is None):
        raise ParameterError('model.axial_top: hoist needs model.type fem and units: si')
    if kind == 'rgd':
        return rgd(groups.psi)
    if kind == 'rgd_axial':
        return StringModel('rgd_axial', lumped_chain([1.0], [0.0], top_fixed=False), None,
                           groups.psi)
    if kind in ('rgd_k', 'axial_chain', 'coupled_chain', 'lumped_II'):
        if kappa_d is None:
            raise ParameterError(f'model {kind} needs groups.kappa_d (or a, b)')
        if kappa_d <= 0:
            raise ParameterError(f'model {kind} needs kappa_d > 0, got {kappa_d:g}')
    if kind == 'rgd_k':
        return rgd_k(groups.psi, kappa_d)
    if kind == 'axial_chain':
        return axial_chain(m['n'], kappa_d, groups.psi, eps=m.get('eps'), eps2=m.get('eps2'),
                           top_damping=m.get('damping', 0.0))
    if kind == 'coupled_chain':
        return coupled_chain(m['n'], kappa_d, groups.psi,
                             axial_top=m.get('axial_top') or 'velocity')
    if kind in ('lumped_I', 'lumped_II', 'lumped_III', 'semi_infinite'):
        z = _impedances(m, system)
        variant = 'I' if kind == 'semi_infinite' else kind.split('_')[1]
        delays = (z.get('axial_round_trip'), z.get('torsional_round_trip')) \
            if variant == 'III' else None
        model = lumped_bha(groups.psi, variant, z['axial'], z['torsional'], kappa_d=kappa_d,
                           delays=delays)
        if kind == 'semi_infinite':  # massless limit of lumped model I (§5.2)
            model.name = 'semi_infinite'
        return model
    if system is None:
        raise ParameterError('model fem needs units: si and a drill_string section')
    if m.get('bha_elements', 0) >= m['elements']:
        raise ParameterError(f"model.bha_elements = {m['bha_elements']} must be below "
                             f"model.elements = {m['elements']}")
    rig = rig or {}
    well = well or {}
    return fem_drill_string(
        system, elements=m['elements'], bha_elements=m.get('bha_elements'),
        theta_u=m['theta_u'], theta_phi=m['theta_phi'], eta_u=m['eta_u'],
        eta_phi=m['eta_phi'], top_drive=m['top_drive'], drive=drive,
        axial_top=m.get('axial_top') or 'hook_load',
        block_mass_kg=rig.get('block_mass_kg', 20000.0),
        line_stiffness_N_m=rig.get('line_stiffness_N_m', 2.5e7), lumped=lumped,
        mud_damping_N_s_m2=well.get('mud_damping_N_s_m2', 0.0) if well.get('survey') else 0.0)


def _impedances(m: dict, system) -> dict:
    """Pipe radiation impedances: derived for SI configs, given otherwise."""
    if system is not None:
        return pipe_impedances(system)
    out = {}
    for key in ('axial_impedance', 'torsional_impedance', 'axial_round_trip',
                'torsional_round_trip'):
        if key in m:
            out[key.replace('_impedance', '')] = m[key]
    for key in ('axial', 'torsional'):
        if key not in out:
            raise ParameterError(f'model {m["type"]} needs model.{key}_impedance '
                                 '(dimensionless configurations)')
    return out


def _fill_defaults(cfg: dict, units: str):
    """Defaults of the simulation section (the resolved configuration is complete)."""
    sim = cfg.setdefault('simulation', {})
    if units == 'si':
        sim.setdefault('duration_s', 75.0)
        sim.setdefault('record_interval_s', 0.01)
    else:
        sim.setdefault('duration', 100.0)
        sim.setdefault('record_interval', 0.01)
    sim.setdefault('time_step', 'auto')
    sim.setdefault('perturb', 'bit')
    pert = sim.setdefault('initial_perturbation', {})
    for key in ('u', 'v', 'phi', 'omega'):
        pert.setdefault(key, 0.0)
    if cfg['model']['type'] == 'fem':
        m = cfg['model']
        for key, value in (('elements', 58), ('theta_u', 5e-4), ('theta_phi', 1e-4),
                           ('eta_u', 0.0), ('eta_phi', 0.0), ('top_drive', 'speed')):
            m.setdefault(key, value)
        if 'sections' not in (cfg.get('drill_string') or {}):
            m.setdefault('bha_elements', 10)   # the thesis's mesh of pipe + BHA
    if units == 'si':
        cfg['drill_string'].setdefault('mud_density_kg_m3', 1200.0)


def _check_step(dt: float, model, groups):
    """A configured step must resolve the delay and lie in the RK4 stability region."""
    if dt > 0.25 * groups.min_delay:
        raise ParameterError(f'simulation.time_step = {dt:g} t*: too large for the delay '
                             f'{groups.min_delay:.4g} t* (at most a quarter of it, '
                             f'{0.25 * groups.min_delay:.4g} t*)')
    if model.name == 'semi_infinite':
        return
    limit = max_stable_step(model, cap=max(dt, 5e-3))
    if dt > limit:
        raise ParameterError(f'simulation.time_step = {dt:g} t*: outside the RK4 stability '
                             f'region of model {model.name} (largest stable step '
                             f'{limit:.3g} t*; or use time_step: auto)')


def scenario_from_dict(raw: dict, source: str = 'configuration',
                       origin: dict | None = None, check_step: bool = True) -> Scenario:
    """Validate a configuration mapping (:mod:`~drill_twin.config.schema`) and build the
    :class:`Scenario`.  Errors are :class:`ConfigError`, one line, prefixed by ``source``.
    ``check_step=False`` skips the check of a configured time step against the RK4
    stability limit, and with ``time_step: auto`` its computation (the step is then the
    5e-3 cap): for linear analyses and checks, which never integrate."""
    cfg = validate(raw, source, origin)
    units = cfg['units']
    _fill_defaults(cfg, units)
    sim = cfg['simulation']
    try:
        system = scales = None
        if units == 'si':
            system = _system_from(cfg)
            op = cfg['operating_point']
            groups = system.groups(op['surface_speed_rad_s'], op['weight_on_bit_N'])
            scales = system.scales()
            kappa_d = system.kappa_d
            dur = sim['duration_s'] / scales.time_s
            rec = sim['record_interval_s'] / scales.time_s
        else:
            groups, kappa_d = _groups_from(cfg['groups'], source)
            angles = (cfg.get('bit') or {}).get('blade_angles_deg')
            if angles:
                groups = groups.replace(blade_angles=tuple(math.radians(a) for a in angles))
            dur, rec = sim['duration'], sim['record_interval']
        drive = _top_drive(cfg, system, groups) \
            if cfg['model'].get('top_drive') == 'motor' and system is not None else None
        path = _surveyed_path(cfg, system)
        rubs = _rubs(path, system)
        model = _build_model(cfg['model'], groups, kappa_d, system, cfg.get('rig'), drive,
                             cfg.get('well'), lumped=rubs)
        wall = _wall(cfg, system, model, scales, groups, path) if rubs else None
        # linear analyses (check_step False) never integrate: no reduction to build; the
        # wall's friction acts on the nodes, which a reduction does not keep
        simulated = _simulated_model(model, sim) if check_step and wall is None else None
        if sim['time_step'] == 'auto' and not check_step:
            # a linear analysis never integrates: the step is the cap, unchecked (the RK4
            # limit's eigenvalues cost O(n³), 80 ms at 500 elements, for nothing)
            dt = min(5e-3, 0.25 * groups.min_delay)
        elif sim['time_step'] == 'auto':  # 80 % of the RK4 limit, at most 5e-3
            dt = min(0.8 * max_stable_step(simulated or model, cap=5e-3 / 0.8),
                     0.25 * groups.min_delay)
        else:
            dt = sim['time_step']
            if check_step:
                _check_step(dt, simulated or model, groups)
    except ConfigError:
        raise
    except ParameterError as exc:
        raise ConfigError(f'{source}: {exc}') from None
    return Scenario(model=model, groups=groups, time_step=dt, duration=dur,
                    record_interval=max(rec, dt),
                    initial_perturbation=dict(sim['initial_perturbation']),
                    perturb_where=sim['perturb'], scales=scales, system=system,
                    kappa_d=kappa_d, raw=cfg, simulated_model=simulated, wall=wall,
                    well_path=path)


def _surveyed_path(cfg, system):
    """The well path of an SI configuration whose string may rub on the wall (a survey and
    friction), read once for the scenario; None otherwise (the vertical well, built when
    asked: :func:`~drill_twin.config.well.scenario_well`)."""
    well = cfg.get('well') or {}
    if system is None or well.get('survey') is None or not well.get('friction_factor', 0.25):
        return None
    return well_of(cfg, system)


def _rubs(path, system) -> bool:
    """The string touches the wall somewhere: its surveyed ``path``
    (:func:`_surveyed_path`) leaves the vertical above the bit (its finite elements then
    have lumped masses)."""
    if path is None:
        return False
    stations = np.searchsorted(path.measured_depth_m, system.total_length_m) + 1
    return bool(np.any(path.inclination_rad[:stations] > 0.0))   # to the leg of the bit


def _wall(cfg, system, model, scales, groups, path):
    """The wall contact of a finite-element string rubbing on the wall of the configured
    well (:func:`_rubs`); the statics at the operating point's weight on bit."""
    if model.element_lengths_m is None:
        raise ParameterError(f"well.survey: model.type {cfg['model']['type']} has no nodes for "
                             "the wall's friction in a deviated well; use model.type fem")
    return wall_of(cfg, system, model, scales, groups.W_o * scales.force_N, path)


#: a reduction that keeps more than this fraction of the DOFs is not worth its truncation:
#: the complete modal coordinates (every mode, no truncation) run instead
_USEFUL_REDUCTION = 0.75


def _simulated_model(model: StringModel, sim: dict) -> StringModel | None:
    """The Craig–Bampton form of a finite-element string that ``simulation.reduction`` asks
    for, else None (the model itself).  ``auto`` (with ``time_step: auto``): the reduction
    at the cut-off when it removes at least a quarter of the DOFs, else the string's
    complete modal coordinates (every mode kept: the same trajectory, fewer sequential
    operations per step; docs/physics.md §5b)."""
    mode = sim.get('reduction', 'auto')
    if mode == 'craig_bampton' and model.element_lengths_m is None:
        raise ParameterError(f'simulation.reduction = craig_bampton: model {model.name} is '
                             'not a finite-element string (model.type: fem); use auto or none')
    if model.element_lengths_m is None or mode == 'none' or (
            mode == 'auto' and sim['time_step'] != 'auto'):
        return None
    reduced = reduce_model(model, sim.get('modal_cutoff', DEFAULT_CUTOFF))
    dofs = [(c.n, getattr(c, 'full', c).n) for c in (reduced.axial, reduced.torsional)
            if c is not None]
    if mode == 'auto' and sum(r for r, _ in dofs) > _USEFUL_REDUCTION * sum(f for _, f in dofs):
        complete = reduce_model(model, math.inf)
        if complete.axial is model.axial and complete.torsional is model.torsional:
            return None                 # chains too small for the arrow form
        return complete
    return reduced


def read_config(path) -> dict:
    """The YAML mapping of a configuration file (one-line errors; bounded: see
    :func:`parse_yaml`)."""
    raw = read_yaml(path)
    if raw is None:
        raise ConfigError(f'{path}: empty configuration (needs at least units and model)')
    return raw


def load_scenario(path, overrides=(), label: str = '--set',
                  check_step: bool = True) -> Scenario:
    """Load a YAML configuration (a path, or a name of a file in ``config/``) with
    ``KEY=VALUE`` overrides (``label`` names where they came from in error messages).
    The file and the values are read with bounds (:func:`parse_yaml`); ``check_step``
    as :func:`scenario_from_dict`."""
    path = resolve_config(path)
    origin: dict = {}
    raw = apply_overrides(read_config(path), overrides, origin, label)
    return scenario_from_dict(raw, str(path), origin, check_step=check_step)
