"""The configuration schema: every key of a configuration file, its type, unit, range,
default and whether it is required — the single source of truth for validation,
for error messages and for docs/configuration.md (``drill-twin config schema``).

A configuration is a YAML mapping (``config/*.yaml``) with keys overridden by
``--set KEY=VALUE`` (CLI) or the ``overrides`` parameter (twin node).
:func:`validate` checks the merged mapping against the schema and returns it
normalised: numbers are numbers (YAML 1.1 reads ``5e-3`` as a string: a string
that is a finite number is taken as one), integers are checked as integers
(``2.0`` is 2, ``2.5`` is refused), unknown keys are refused with the nearest
valid name, missing required keys are named.  Every error is one line: where the
value came from (the file, or ``--set``), the key, the value with its unit, and
what is allowed.

Keys of ``model`` that belong to another model type (``model.elements`` when
``model.type`` is ``rgd``) are ignored, so that ``--set model.type=...`` can switch
the model of a file; a key that belongs to no model type is an error.
"""
from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field

from ..errors import ConfigError
from .yaml_bounds import MAX_INT_DIGITS, MAX_YAML_BYTES, MAX_YAML_DEPTH, MAX_YAML_NODES

__all__ = ['ConfigError', 'Key', 'Section', 'SCHEMA', 'validate', 'REQUIRED',
           'MODEL_TYPES', 'schema_markdown']


REQUIRED = object()


@dataclass(frozen=True)
class Key:
    """One configuration key.

    ``kind``: ``'float'``, ``'int'``, ``'str'``, ``'choice'`` (one of ``choices``),
    ``'float_or_auto'``.  ``low``/``high`` bound numbers (``open_low``/``open_high``:
    the bound itself is excluded).  ``default``: :data:`REQUIRED`, a value, or None
    (optional, no default).  ``models``: the model types the key applies to (empty:
    all).
    """

    name: str
    kind: str
    doc: str
    unit: str = ''
    low: float | None = None
    high: float | None = None
    open_low: bool = False
    open_high: bool = False
    default: object = None
    choices: tuple = ()
    models: tuple = ()

    def range_text(self) -> str:
        if self.kind == 'choice':
            return 'one of ' + ', '.join(self.choices)
        if self.kind == 'bool':
            return 'true or false'
        if self.low is None and self.high is None:
            return ''
        lo = '(' if self.open_low else '['
        hi = ')' if self.open_high else ']'
        unit = f' {self.unit}' if self.unit and self.unit != '1' else ''
        what = {'int': 'an integer', 'float_list': 'numbers'}.get(self.kind, 'a number')
        extra = " or 'auto'" if self.kind == 'float_or_auto' else ''
        return f'{what} in {lo}{self.low:g}, {self.high:g}{hi}{unit}{extra}'


@dataclass(frozen=True)
class Section:
    """A mapping of keys.  ``units``: the ``units`` values it belongs to (empty: all);
    ``many``: the value is a list of such mappings (``drill_string.sections``)."""

    name: str
    doc: str
    keys: tuple
    required: bool = False
    units: tuple = ()
    subsections: tuple = field(default=())
    many: bool = False

    def key(self, name):
        return next((k for k in self.keys if k.name == name), None)


MODEL_TYPES = ('rgd', 'rgd_axial', 'rgd_k', 'axial_chain', 'coupled_chain', 'lumped_I',
               'lumped_II', 'lumped_III', 'semi_infinite', 'fem')
_CHAINS = ('axial_chain', 'coupled_chain')
_LUMPED = ('lumped_I', 'lumped_II', 'lumped_III', 'semi_infinite')


def _pos(name, doc, unit, high, default=REQUIRED, kind='float', low=0.0, open_low=True, **kw):
    return Key(name, kind, doc, unit, low, high, open_low=open_low, default=default, **kw)


MODEL = Section('model', 'the drill-string model', required=True, keys=(
    Key('type', 'choice', 'model (docs/physics.md)', choices=MODEL_TYPES, default=REQUIRED),
    _pos('elements', 'finite elements of the whole string', '1', 4096, 58, kind='int', low=2,
         open_low=False, models=('fem',)),
    _pos('bha_elements', 'elements in the BHA (< elements)', '1', 4095, 10, kind='int', low=1,
         open_low=False, models=('fem',)),
    _pos('theta_u', 'axial stiffness-proportional (Rayleigh) damping', 't*', 1.0, 5e-4,
         open_low=False, models=('fem',)),
    _pos('theta_phi', 'torsional stiffness-proportional (Rayleigh) damping', 't*', 1.0, 1e-4,
         open_low=False, models=('fem',)),
    _pos('eta_u', 'axial mass-proportional (Rayleigh) damping', '1/t*', 100.0, 0.0,
         open_low=False, models=('fem',)),
    _pos('eta_phi', 'torsional mass-proportional (Rayleigh) damping', '1/t*', 100.0, 0.0,
         open_low=False, models=('fem',)),
    Key('top_drive', 'choice', 'torsional top: a motor behind a PI speed loop (section '
        'drive, docs/control.md), the ideal stiff speed source, or the ideal Soft-Torque '
        'spring and dash-pot of §3.2', choices=('motor', 'speed', 'soft_torque'),
        default='motor', models=('fem',)),
    Key('axial_top', 'choice', 'axial top: constant hook load, imposed block velocity, or a '
        'hoist (block mass on the drill line, SI)', choices=('hook_load', 'velocity', 'hoist'),
        default=None, models=('fem', 'coupled_chain')),
    _pos('n', 'number of oscillators', '1', 1000, REQUIRED, kind='int', low=1, open_low=False,
         models=_CHAINS),
    _pos('eps', 'mass fraction ε1 of the upper oscillators (eq. 4.4.1)', '1', 1.0, None,
         open_high=True, models=('axial_chain',)),
    _pos('eps2', 'stiffness fraction ε2 of the upper oscillators (eq. 4.4.1)', '1', 1.0, None,
         open_high=True, models=('axial_chain',)),
    _pos('damping', 'dash-pot beside the top spring', 'M/t*', 1e6, 0.0, open_low=False,
         models=('axial_chain',)),
    _pos('axial_impedance', 'axial radiation impedance of the pipe (dimensionless configs)',
         'M/t*', 1e6, None, models=_LUMPED),
    _pos('torsional_impedance', 'torsional radiation impedance of the pipe (dimensionless '
         'configs)', 'I/t*', 1e6, None, models=_LUMPED),
    _pos('axial_round_trip', 'axial wave round trip 2L/c (lumped III, dimensionless configs)',
         't*', 1e6, None, models=_LUMPED),
    _pos('torsional_round_trip', 'torsional wave round trip 2L/c (lumped III, dimensionless '
         'configs)', 't*', 1e6, None, models=_LUMPED),
))

SECTIONS = Section('sections', 'the string from top to bottom, one mapping per section '
                   '(replaces the two-section pipe_*/bha_* keys)', many=True, keys=(
    Key('name', 'str', 'what it is (drill pipe, heavy-weight pipe, collars ...)',
        default=REQUIRED),
    _pos('length_m', 'section length', 'm', 20000.0),
    _pos('outer_diameter_m', 'outer diameter (OD)', 'm', 2.0),
    _pos('inner_diameter_m', 'inner diameter (ID, < OD; 0 = solid)', 'm', 2.0, open_low=False),
    _pos('density_kg_m3', 'steel density (default: drill_string.density_kg_m3)', 'kg/m^3',
         30000.0, None),
    _pos('young_modulus_Pa', "Young's modulus (default: drill_string's)", 'Pa', 1e13, None),
    _pos('shear_modulus_Pa', "shear modulus (default: drill_string's)", 'Pa', 1e13, None),
    Key('bha', 'bool', 'part of the BHA (default: only the last section)', default=None),
    _pos('elements', 'finite elements of this section (default: shared out by length)',
         '1', 4096, None, kind='int', low=1, open_low=False),
))

_LEGACY_GEOMETRY = {'pipe_length_m', 'bha_length_m', 'pipe_outer_radius_m',
                    'pipe_inner_radius_m', 'bha_outer_radius_m', 'bha_inner_radius_m'}

DRILL_STRING = Section('drill_string', 'the physical drilling system (SI)', required=True,
                       units=('si',), keys=(
    _pos('pipe_length_m', 'drill-pipe length', 'm', 20000.0),
    _pos('bha_length_m', 'BHA length', 'm', 5000.0),
    _pos('pipe_outer_radius_m', 'drill-pipe outer radius', 'm', 1.0),
    _pos('pipe_inner_radius_m', 'drill-pipe inner radius (< outer)', 'm', 1.0),
    _pos('bha_outer_radius_m', 'BHA outer radius', 'm', 1.0),
    _pos('bha_inner_radius_m', 'BHA inner radius (< outer)', 'm', 1.0),
    _pos('density_kg_m3', 'steel density', 'kg/m^3', 30000.0),
    _pos('young_modulus_Pa', "Young's modulus E", 'Pa', 1e13),
    _pos('shear_modulus_Pa', 'shear modulus G', 'Pa', 1e13),
    _pos('bit_radius_m', 'bit radius a', 'm', 1.0),
    _pos('blades', 'number of blades n_b', '1', 64, kind='int', low=1, open_low=False),
    _pos('intrinsic_specific_energy_Pa', 'intrinsic specific energy ε', 'Pa', 1e11),
    _pos('contact_stress_Pa', 'contact stress σ_f', 'Pa', 1e11),
    _pos('wear_flat_length_m', 'wear-flat length ℓ', 'm', 0.1),
    _pos('cutting_force_ratio_zeta', 'ratio ζ of vertical to horizontal cutting force', '1',
         10.0),
    _pos('friction_coefficient_mu', 'wear-flat friction coefficient μ', '1', 10.0,
         open_low=False),
    _pos('bit_geometry_gamma', 'bit geometry number γ', '1', 10.0),
    _pos('drive_mass_kg', 'top-drive mass M_DS (§2.2.1)', 'kg', 1e6),
    _pos('drive_width_m', 'top-drive width l1 (§2.2.1)', 'm', 100.0),
    _pos('drive_depth_m', 'top-drive depth l2 (§2.2.1)', 'm', 100.0),
    _pos('mud_density_kg_m3', 'mud density (buoyancy: hook load <-> WOB)', 'kg/m^3', 3000.0,
         1200.0, open_low=False),
), subsections=(SECTIONS,))

RIG = Section('rig', 'the hoisting system of model.axial_top: hoist (SI; defaults assumed, '
              'docs/operations.md)', units=('si',), keys=(
    _pos('block_mass_kg', 'travelling block and hook mass', 'kg', 1e6, 20000.0),
    _pos('line_stiffness_N_m', 'drill line stiffness seen at the hook (n² EA / L of the '
         'reeving)', 'N/m', 1e12, 2.5e7),
))

DRIVE = Section('drive', 'the motor top drive of model.top_drive: motor (SI; '
                'docs/control.md)', units=('si',), keys=(
    Key('controller', 'choice', 'controller mode', choices=(
        'stiff_pi', 'soft_torque', 'z_torque', 'stability_tuned'), default='stiff_pi'),
    _pos('motor_inertia_kgm2', 'motor and gearbox inertia at the quill (default: the '
         'drive block of §2.2.1)', 'kg m^2', 1e7, None),
    _pos('torque_limit_Nm', 'motor torque limit', 'N m', 1e7, 50.0e3),
    _pos('speed_loop_bandwidth_rad_s', 'bandwidth of the stiff speed loop (stiff_pi, '
         'z_torque)', 'rad/s', 1e4, 30.0),
    _pos('sensor_delay_s', 'delay of the speed and torque measurements', 's', 10.0, 0.0,
         open_low=False),
    _pos('torque_filter_s', 'time constant of the torque reference (torque feedback)', 's',
         1e4, 20.0),
    _pos('proportional_gain_Nms_rad', 'K_p instead of the mode\'s tuning', 'N m s/rad', 1e9,
         None),
    _pos('integral_gain_Nm_rad', 'K_i instead of the mode\'s tuning', 'N m/rad', 1e10, None,
         open_low=False),
    _pos('torque_feedback_rad_s_Nm', 'g_T instead of the mode\'s tuning', 'rad/s/(N m)',
         1.0, None, open_low=False),
))

BIT = Section('bit', 'blade layout of the bit', keys=(
    Key('blade_angles_deg', 'float_list', 'angular position of every blade (n_b entries; '
        'default evenly spaced)', 'deg', -360.0, 720.0, default=None),
))

OPERATING_POINT = Section('operating_point', 'the steady operating point (SI)', required=True,
                          units=('si',), keys=(
    _pos('surface_speed_rad_s', 'surface (rotary) speed Ω_o', 'rad/s', 100.0),
    _pos('weight_on_bit_N', 'weight on bit W_o', 'N', 1e8),
))

GROUPS = Section('groups', 'dimensionless groups (ch. 4-5); either (psi, n_b, lambda or '
                 'n_b_lambda, beta, W_o, omega_o[, kappa_d]) or the axial-chain plane (a, b)',
                 required=True, units=('dimensionless',), keys=(
    _pos('psi', 'axial force scale ψ', '1', 1e6, None),
    _pos('n_b', 'number of blades', '1', 64, None, kind='int', low=1, open_low=False),
    _pos('lambda', 'bluntness λ', '1', 1e6, None, open_low=False),
    _pos('n_b_lambda', 'n_b λ (instead of lambda)', '1', 1e6, None, open_low=False),
    _pos('beta', 'bit/rock interaction number β', '1', 100.0, None, open_low=False),
    _pos('W_o', 'weight on bit W_o/W*', '1', 1e6, None),
    _pos('omega_o', 'surface speed Ω_o t*', '1', 1e4, None),
    _pos('kappa_d', 'axial stiffness κ_d of the pipe', '1', 1e8, None),
    Key('a', 'float', 'axial-chain plane: a = κ_d + n_b ψ (delay 1)', '1', -1e6, 1e6),
    _pos('b', 'axial-chain plane: b = n_b ψ (delay 1)', '1', 1e6, None),
))

PERTURBATION = Section('initial_perturbation', 'initial perturbation from the steady state',
                       keys=(
    Key('u', 'float', 'axial displacement', 'd*', -1e6, 1e6, default=0.0),
    Key('v', 'float', 'axial velocity', 'd*/t*', -1e6, 1e6, default=0.0),
    Key('phi', 'float', 'angle', 'rad', -1e6, 1e6, default=0.0),
    Key('omega', 'float', 'angular velocity', 'rad/t*', -1e6, 1e6, default=0.0),
))

SIMULATION = Section('simulation', 'run settings', keys=(
    Key('time_step', 'float_or_auto', "integration step ('auto': 80 % of the RK4 stability "
        'limit, at most 5e-3; a finite-element string is then reduced: see reduction)', 't*',
        1e-6, 1.0, default='auto'),
    _pos('duration', 'simulated time (dimensionless configs)', 't*', 1e7, 100.0),
    _pos('duration_s', 'simulated time (SI configs)', 's', 1e7, 75.0),
    _pos('record_interval', 'recording interval (dimensionless configs)', 't*', 1e4, 0.01),
    _pos('record_interval_s', 'recording interval (SI configs)', 's', 1e4, 0.01),
    Key('reduction', 'choice', "time integration of a finite-element string: 'auto' = "
        "the Craig-Bampton reduction when time_step is auto (the complete modal coordinates "
        "when the cut-off keeps over 3/4 of the DOFs), 'craig_bampton' always, 'none' "
        'the full chain (the RK4 reference)', choices=('auto', 'craig_bampton', 'none'),
        default='auto'),
    _pos('modal_cutoff', 'highest fixed-interface frequency of the interior modes a '
         'reduced string keeps', 'rad/t*', 1e6, 250.0),
    Key('perturb', 'choice', 'where the perturbation goes: bit DOFs, every DOF, or a field '
        'compatible with the top boundary', choices=('bit', 'all', 'smooth'), default='bit'),
), subsections=(PERTURBATION,))

WELL = Section('well', 'the well path (SI; absent: a vertical well to the string length). '
               'The torque-and-drag statics use it (drill-twin well; docs/torque_drag.md), '
               'and a finite-element string in it feels the wall\'s Coulomb friction at every '
               'node (docs/physics.md §9)', units=('si',), keys=(
    Key('survey', 'str', 'survey file: CSV with columns measured_depth_m, inclination_deg, '
        'azimuth_deg (a header line, one station per line, the first at 0 m); a path '
        '(absolute or from the working directory) or a name in config/wells/', default=None),
    _pos('friction_factor', 'Coulomb friction factor of the string on the wall (the static '
         'coefficient μ_s of the dynamics)', '1', 2.0, 0.25, low=0.0, open_low=False),
    _pos('dynamic_friction_ratio', 'sliding over static friction coefficient μ_d/μ_s of the '
         'dynamics', '1', 1.0, 1.0, open_low=True),
    _pos('stribeck_speed_m_s', 'sliding speed over which the friction falls from the static '
         'to the dynamic coefficient, μ_d + (μ_s - μ_d) exp(-v/v_S) (docs/physics.md eq. 9.9; '
         '0: at once, the two-level law)', 'm/s', 10.0, 0.0, open_low=False),
    _pos('mud_damping_N_s_m2', "the mud's viscous drag on the string per unit length and unit "
         'sliding speed (axially c, torsionally c r²)', 'N*s/m^2', 1e5, 0.0, open_low=False),
))

TOP = (MODEL, DRILL_STRING, OPERATING_POINT, GROUPS, RIG, DRIVE, BIT, SIMULATION, WELL)
SCHEMA = Section('', 'a drill_twin configuration', keys=(
    Key('units', 'choice', 'si: a physical system, SI in and out; dimensionless: the '
        'research groups of ch. 4-5', choices=('si', 'dimensionless'), default=REQUIRED),
), subsections=TOP)

#: simulation keys that belong to one kind of configuration only
_UNIT_KEYS = {'duration': 'dimensionless', 'record_interval': 'dimensionless',
              'duration_s': 'si', 'record_interval_s': 'si'}


def _where(origin: dict, path: str, source: str) -> str:
    """Where the value at ``path`` came from: the override that set it (or set a key
    below it, or the section above it), else the file."""
    if path in origin:
        return origin[path]
    for key, where in origin.items():
        if key.startswith(path + '.') or path.startswith(key + '.'):
            return where
    return source


#: longest value shown in an error line [characters] (a 400-digit number, a 1 MB string
#: or a list of 20,000 items is cut to its start and its length)
_SHOWN = 60


def _fail(where: str, path: str, value, key: Key | None, problem: str):
    text = '' if value is _MISSING else repr(value)
    if len(text) > _SHOWN:
        text = f'{text[:_SHOWN]}...({len(text)} characters)'
    shown = '' if value is _MISSING else f' = {text}'
    if key is not None and key.unit and key.unit != '1' and value is not _MISSING:
        shown += f' {key.unit}'
    raise ConfigError(f'{where}: {path}{shown}: {problem}')


_MISSING = object()


def _number(value):
    """A finite float from a YAML number or a numeric string, else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, str):
        try:
            value = float(value.strip())
        except ValueError:
            return None
    try:  # an int beyond a float's range (10**400) is no number of any key either
        if isinstance(value, (int, float)) and math.isfinite(value):
            return value
    except OverflowError:
        pass
    return None


def _check(key: Key, value, path: str, where: str):
    if key.kind == 'float_or_auto' and value == 'auto':
        return 'auto'
    if key.kind == 'bool':
        if not isinstance(value, bool):
            _fail(where, path, value, key, 'must be true or false')
        return value
    if key.kind == 'float_list':
        if not isinstance(value, list) or not value:
            _fail(where, path, value, key, f'must be a list of numbers ({key.doc})')
        item = Key(key.name, 'float', key.doc, key.unit, key.low, key.high, key.open_low,
                   key.open_high)
        return [_check(item, v, f'{path}[{i}]', where) for i, v in enumerate(value)]
    if key.kind == 'choice':
        if value not in key.choices:
            close = difflib.get_close_matches(str(value), key.choices, n=1)
            hint = f' (did you mean {close[0]}?)' if close else ''
            _fail(where, path, value, key, f'must be {key.range_text()}{hint}')
        return value
    if key.kind == 'str':
        if not isinstance(value, str):
            _fail(where, path, value, key, 'must be a string')
        return value
    number = _number(value)
    if number is None:
        _fail(where, path, value, key, f'must be {key.range_text() or "a finite number"}')
    if key.kind == 'int':
        if float(number) != int(number):
            _fail(where, path, value, key, f'must be {key.range_text()}')
        number = int(number)
    else:
        number = float(number)
    low_bad = key.low is not None and (number < key.low or (key.open_low and number == key.low))
    high_bad = key.high is not None and (number > key.high or
                                         (key.open_high and number == key.high))
    if low_bad or high_bad:
        _fail(where, path, value, key, f'must be {key.range_text()}')
    return number


def _unknown(where, path, name, valid):
    close = difflib.get_close_matches(name, valid, n=1, cutoff=0.6)
    hint = f' (did you mean {(path + "." if path else "") + close[0]}?)' if close else ''
    full = f'{path}.{name}' if path else name
    if len(full) > _SHOWN:
        full = f'{full[:_SHOWN]}...({len(full)} characters)'
    raise ConfigError(f'{where}: unknown key {full}{hint}')


def _section(section: Section, data, path: str, ctx: dict):
    where = _where(ctx['origin'], path, ctx['source'])
    if data is None:
        data = {}
    if not isinstance(data, dict):
        _fail(where, path or 'the configuration', data, None, 'must be a mapping of keys')
    out = {}
    subs = {s.name: s for s in section.subsections}
    model_type = ctx.get('model_type')
    for name, value in data.items():
        full = f'{path}.{name}' if path else str(name)
        origin = _where(ctx['origin'], full, ctx['source'])
        if not isinstance(name, str):
            _fail(origin, full, value, None, 'keys must be names')
        if name in subs:
            sub = subs[name]
            if sub.units and ctx['units'] not in sub.units:
                raise ConfigError(f'{origin}: {full} does not apply to units: {ctx["units"]} '
                                  f'(only to units: {", ".join(sub.units)})')
            if sub.many:
                if not isinstance(value, list) or not value:
                    _fail(origin, full, value, None, f'must be a list of mappings ({sub.doc})')
                out[name] = [_section(sub, item, f'{full}[{i}]', ctx)
                             for i, item in enumerate(value)]
            else:
                out[name] = _section(sub, value, full, ctx)
            continue
        key = section.key(name)
        if key is None:
            _unknown(origin, path, name, [k.name for k in section.keys] + list(subs))
        if section is SIMULATION and name in _UNIT_KEYS and _UNIT_KEYS[name] != ctx['units']:
            other = {'duration': 'duration_s', 'record_interval': 'record_interval_s'}
            alt = other.get(name) or next(k for k, v in other.items() if v == name)
            raise ConfigError(f'{origin}: {full} is for units: {_UNIT_KEYS[name]} '
                              f'configurations; this one has units: {ctx["units"]}: use '
                              f'simulation.{alt}')
        if key.models and model_type is not None and model_type not in key.models:
            continue  # a key of another model type: ignored (see module docstring)
        out[name] = _check(key, value, full, origin)
    alternative = section.name == 'drill_string' and 'sections' in out
    if alternative:
        legacy = sorted(set(out) & _LEGACY_GEOMETRY)
        if legacy:
            raise ConfigError(f'{where}: give drill_string.sections or the two-section keys '
                              f'(pipe_*/bha_*), not both: {", ".join(legacy)}')
    for key in section.keys:
        applies = not key.models or model_type is None or model_type in key.models
        if alternative and key.name in _LEGACY_GEOMETRY:
            continue
        if key.default is REQUIRED and key.name not in out and applies:
            full = f'{path}.{key.name}' if path else key.name
            raise ConfigError(f'{ctx["source"]}: missing required key {full} '
                              f'({key.doc}{", " + key.unit if key.unit not in ("", "1") else ""})')
    for sub in section.subsections:
        if sub.required and sub.name not in out and (not sub.units or ctx['units'] in sub.units):
            full = f'{path}.{sub.name}' if path else sub.name
            raise ConfigError(f'{ctx["source"]}: missing required section {full} ({sub.doc})')
    return out


def validate(raw, source: str = 'configuration', origin: dict | None = None) -> dict:
    """Check a configuration mapping against :data:`SCHEMA`; return it normalised.

    Parameters
    ----------
    raw : dict
        The configuration (after overrides).
    source : str
        Where it came from (a file path), for error messages.
    origin : dict
        ``{dotted key: where}`` for values that came from elsewhere (``--set ...``).
    """
    origin = origin or {}
    if not isinstance(raw, dict):
        raise ConfigError(f'{source}: a configuration must be a mapping of keys, got '
                          f'{type(raw).__name__}')
    units = raw.get('units', _MISSING)
    if units is _MISSING:
        raise ConfigError(f'{source}: missing required key units (si or dimensionless)')
    ctx = {'source': source, 'origin': origin, 'units': None}
    ctx['units'] = _check(SCHEMA.key('units'), units, 'units', _where(origin, 'units', source))
    model = raw.get('model')
    if isinstance(model, dict) and 'type' in model:
        ctx['model_type'] = _check(MODEL.key('type'), model['type'], 'model.type',
                                   _where(origin, 'model.type', source))
    return _section(SCHEMA, raw, '', ctx)


def _markdown_rows(section: Section, path: str):
    for key in section.keys:
        full = f'{path}.{key.name}' if path else key.name
        default = 'required' if key.default is REQUIRED else (
            '–' if key.default is None else f'`{key.default}`')
        models = f" ({', '.join(key.models)})" if key.models else ''
        yield (f'| `{full}` | {key.doc}{models} | {key.unit or "–"} | '
               f'{key.range_text() or "–"} | {default} |')
    for sub in section.subsections:
        yield from _markdown_rows(sub, f'{path}.{sub.name}' if path else sub.name)


_INTRO = """# Configuration files

Generated by `drill-twin config schema > docs/configuration.md` from
`drill_twin/physics/schema.py`, the single source of truth of what a configuration
may contain (a test checks that this page is up to date).

A configuration is a YAML mapping (`config/*.yaml`, or any file given to
`--config`); `--set KEY=VALUE` (CLI) and the twin node's `overrides` parameter
change dotted keys.  Rules:

* an unknown key is an error, with the nearest valid name; a required key that
  is missing is named;
* numbers may be written `5e-3` (YAML 1.1 reads that as a string; a string that is
  a finite number is taken as one); integers must be integers (`58.0` is 58,
  `58.5` is an error); NaN and infinities are refused;
* `units: si` configurations take `drill_string` and `operating_point` (SI, the
  dimensionless groups are derived); `units: dimensionless` ones take `groups`;
  a section of the other kind is an error;
* keys of `model` that belong to another model type are ignored (so that
  `--set model.type=rgd` works on the FEM file); other unknown `model` keys are
  errors;
* every error is one line: the file (or the `--set` / `overrides` item), the key,
  the value with its unit (a long value cut to its start and its length), and what
  is allowed; `drill-twin config check --config FILE` prints the resolved
  configuration;
* a file, a scenario file and a `--set` value are read with bounds: at most
  {bytes} bytes (1 MiB), collections nested at most {depth} levels deep, at most
  {nodes} YAML nodes with the aliases expanded (an anchor may be reused within that;
  an alias inside the node it names is refused), integers of at most {digits} digits
  (write a larger number as a float, `1e25`); a scalar its tag cannot read
  (`!!int abc`, the date `2001-02-30`) is an error like malformed YAML.  Each bound
  is one line naming the file, the line and column, and the bound.

Physical consistency is checked when the model is built (inner radius below
outer, WOB above the wear-flat friction threshold n_b λ W*, a time step inside
the RK4 stability region and at most a quarter of the delay, ...), with the same
one-line errors.

"""


def schema_markdown() -> str:
    """docs/configuration.md: the rules and the schema as a Markdown table."""
    lines = ['| key | meaning | unit | allowed | default |', '|---|---|---|---|---|']
    lines += list(_markdown_rows(SCHEMA, ''))
    intro = _INTRO.format(bytes=MAX_YAML_BYTES, depth=MAX_YAML_DEPTH, nodes=MAX_YAML_NODES,
                          digits=MAX_INT_DIGITS)
    return intro + '\n'.join(lines) + '\n'
