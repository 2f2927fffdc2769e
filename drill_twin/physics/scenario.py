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
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field, fields
from pathlib import Path

import yaml

from .models import (
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
from .parameters import BitRockGroups, DrillStringSI, ParameterError, Scales

__all__ = ['Scenario', 'load_scenario', 'scenario_from_dict', 'apply_overrides',
           'CONFIG_DIR']

CONFIG_DIR = Path(__file__).resolve().parents[2] / 'config'


def config_dirs() -> list[Path]:
    """Where named configurations are looked up: the source tree, then the
    installed ``share/drill_twin/config`` (pip data_files or a colcon install)."""
    import sys
    dirs = [CONFIG_DIR, Path(sys.prefix) / 'share' / 'drill_twin' / 'config']
    try:
        from ament_index_python.packages import get_package_share_directory
        dirs.append(Path(get_package_share_directory('drill_twin')) / 'config')
    except Exception:  # noqa: BLE001 - ament index absent or package not installed
        pass
    return dirs


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


def _number(section: dict, key: str, default=None, where='') -> float:
    if key not in section:
        if default is None:
            raise ParameterError(f'missing parameter {where}{key}')
        return default
    value = section[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ParameterError(f'parameter {where}{key} must be a number, got {value!r}')
    if not math.isfinite(value):
        raise ParameterError(f'parameter {where}{key} must be finite, got {value!r}')
    return float(value)


def apply_overrides(raw: dict, overrides) -> dict:
    """Return a copy of ``raw`` with ``KEY=VALUE`` strings (dotted keys) applied."""
    out = copy.deepcopy(raw)
    for item in overrides or ():
        if '=' not in item:
            raise ParameterError(f'override {item!r} is not KEY=VALUE')
        key, value = item.split('=', 1)
        node = out
        parts = key.strip().split('.')
        for part in parts[:-1]:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise ParameterError(f'override {key!r}: {part} is not a section')
        try:
            node[parts[-1]] = yaml.safe_load(value)
        except yaml.YAMLError as exc:
            raise ParameterError(f'override {item!r}: cannot parse value: {exc}') from exc
    return out


def _groups_dimensionless(g: dict, model_type: str):
    where = 'groups.'
    if 'a' in g or 'b' in g:
        a = _number(g, 'a', where=where)
        b = _number(g, 'b', where=where)
        n_b = int(_number(g, 'n_b', 1.0, where))
        if b <= 0:
            raise ParameterError('groups.b must be > 0')
        kappa_d = a - b
        omega_o = 2.0 * math.pi / n_b  # delay τ_1,0 = 1
        lam = _number(g, 'lambda', 0.0, where)
        groups = BitRockGroups(n_b=n_b, lam=lam, beta=_number(g, 'beta', 0.0, where),
                               W_o=_number(g, 'W_o', n_b * (lam + 1.0), where),
                               omega_o=omega_o, psi=b / n_b)
        return groups, kappa_d
    n_b = _number(g, 'n_b', where=where)
    if n_b < 1:
        raise ParameterError(f'groups.n_b must be >= 1 blade, got {n_b:g}')
    if 'n_b_lambda' in g:
        lam = _number(g, 'n_b_lambda', where=where) / n_b
    else:
        lam = _number(g, 'lambda', where=where)
    groups = BitRockGroups(n_b=n_b, lam=lam, beta=_number(g, 'beta', where=where),
                           W_o=_number(g, 'W_o', where=where),
                           omega_o=_number(g, 'omega_o', where=where),
                           psi=_number(g, 'psi', where=where))
    kappa_d = _number(g, 'kappa_d', 0.0, where) if 'kappa_d' in g else None
    return groups, kappa_d


def _build_model(m: dict, groups: BitRockGroups, kappa_d, system):
    kind = m.get('type')
    if kind == 'rgd':
        return rgd(groups.psi)
    if kind == 'rgd_axial':
        return StringModel('rgd_axial', lumped_chain([1.0], [0.0], top_fixed=False), None,
                           groups.psi)
    if kind in ('rgd_k', 'axial_chain', 'coupled_chain', 'lumped_II'):
        if kappa_d is None:
            raise ParameterError(f'model {kind} needs groups.kappa_d (or a, b)')
        if kappa_d <= 0:
            raise ParameterError(f'kappa_d must be > 0, got {kappa_d!r}')
    if kind == 'rgd_k':
        return rgd_k(groups.psi, kappa_d)
    if kind == 'axial_chain':
        n = int(_number(m, 'n', where='model.'))
        eps = m.get('eps')
        return axial_chain(n, kappa_d, groups.psi, eps=eps, eps2=m.get('eps2'),
                           top_damping=_number(m, 'damping', 0.0, 'model.'))
    if kind == 'coupled_chain':
        return coupled_chain(int(_number(m, 'n', where='model.')), kappa_d, groups.psi,
                             axial_top=m.get('axial_top', 'velocity'))
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
    if kind == 'fem':
        if system is None:
            raise ParameterError('model fem needs units: si and a drill_string section')
        return fem_drill_string(
            system, elements=int(_number(m, 'elements', 58.0, 'model.')),
            bha_elements=int(_number(m, 'bha_elements', 10.0, 'model.')),
            theta_u=_number(m, 'theta_u', 5e-4, 'model.'),
            theta_phi=_number(m, 'theta_phi', 1e-4, 'model.'),
            eta_u=_number(m, 'eta_u', 0.0, 'model.'), eta_phi=_number(m, 'eta_phi', 0.0, 'model.'),
            top_drive=m.get('top_drive', 'speed'), axial_top=m.get('axial_top', 'hook_load'))
    raise ParameterError(f'unknown model.type {kind!r} (rgd, rgd_axial, rgd_k, axial_chain, '
                         'coupled_chain, lumped_I, lumped_II, lumped_III, semi_infinite, '
                         'fem)')


def _impedances(m: dict, system) -> dict:
    """Pipe radiation impedances: derived for SI configs, given otherwise."""
    if system is not None:
        return pipe_impedances(system)
    out = {'axial': _number(m, 'axial_impedance', where='model.'),
           'torsional': _number(m, 'torsional_impedance', where='model.')}
    for key in ('axial_round_trip', 'torsional_round_trip'):
        if key in m:
            out[key] = _number(m, key, where='model.')
    return out


def scenario_from_dict(raw: dict) -> Scenario:
    """Validate a configuration mapping and build the :class:`Scenario`."""
    if not isinstance(raw, dict):
        raise ParameterError('configuration must be a mapping')
    units = raw.get('units')
    model_section = raw.get('model') or {}
    if not isinstance(model_section, dict):
        raise ParameterError('model must be a mapping')
    sim = raw.get('simulation') or {}
    system = scales = None
    if units == 'si':
        ds = raw.get('drill_string') or {}
        known = {f.name for f in fields(DrillStringSI)} - {'extra'}
        unknown = set(ds) - known
        if unknown:
            raise ParameterError(f'unknown drill_string parameters: {sorted(unknown)}')
        system = DrillStringSI(**ds)
        op = raw.get('operating_point') or {}
        groups = system.groups(_number(op, 'surface_speed_rad_s', where='operating_point.'),
                               _number(op, 'weight_on_bit_N', where='operating_point.'))
        scales = system.scales()
        kappa_d = system.kappa_d
        t_unit = scales.time_s
        dur = _number(sim, 'duration_s', 75.0, 'simulation.') / t_unit
        rec = _number(sim, 'record_interval_s', 0.01, 'simulation.') / t_unit
    elif units == 'dimensionless':
        groups, kappa_d = _groups_dimensionless(raw.get('groups') or {}, model_section.get('type'))
        dur = _number(sim, 'duration', 100.0, 'simulation.')
        rec = _number(sim, 'record_interval', 0.01, 'simulation.')
    else:
        raise ParameterError(f"units must be 'si' or 'dimensionless', got {units!r}")
    model = _build_model(model_section, groups, kappa_d, system)
    if sim.get('time_step', 'auto') == 'auto':  # 80 % of the RK4 limit, at most 5e-3
        dt = min(0.8 * max_stable_step(model, cap=5e-3 / 0.8), 0.25 * groups.tau_10)
    else:
        dt = _number(sim, 'time_step', where='simulation.')
    pert = sim.get('initial_perturbation') or {}
    if not isinstance(pert, dict):
        raise ParameterError('simulation.initial_perturbation must map u, v, phi, omega')
    pert = {k: _number(pert, k, 0.0, 'simulation.initial_perturbation.')
            for k in ('u', 'v', 'phi', 'omega')}
    where = sim.get('perturb', 'bit')
    if where not in ('bit', 'all', 'smooth'):
        raise ParameterError("simulation.perturb must be 'bit', 'all' or 'smooth'")
    return Scenario(model=model, groups=groups, time_step=dt, duration=dur,
                    record_interval=max(rec, dt), initial_perturbation=pert,
                    perturb_where=where, scales=scales, system=system, kappa_d=kappa_d,
                    raw=raw)


def load_scenario(path, overrides=()) -> Scenario:
    """Load a YAML configuration (a path, or a name of a file in ``config/``)."""
    path = Path(path)
    if not path.exists():
        for folder in config_dirs():
            for candidate in (folder / path, folder / f'{path}.yaml'):
                if candidate.exists():
                    path = candidate
                    break
            if path.exists():
                break
    try:
        text = path.read_text()
    except OSError as exc:
        raise ParameterError(f'cannot read configuration {path}: {exc.strerror}') from exc
    try:
        raw = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ParameterError(f'malformed YAML in {path}: {exc}') from exc
    return scenario_from_dict(apply_overrides(raw, overrides))
