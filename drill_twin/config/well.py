"""The well path of a configuration: ``well.survey`` (a survey file) → a
:class:`~drill_twin.physics.well_path.WellPath`; no survey: the vertical well.

A survey file is CSV text: a header line, then one station per line, ``measured depth
[m], inclination [deg], azimuth [deg]``, the first station at 0 m, depths increasing.
It is looked up as given (absolute, or relative to the working directory), then in
``config/wells/`` of each configuration directory (:func:`~drill_twin.config.lookup.
config_dirs`).  Every problem is one :class:`~drill_twin.errors.ConfigError` line naming
the file and the line.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import ConfigError, ParameterError
from ..physics.torque_drag import ROTATING, torque_drag
from ..physics.wall_contact import node_contact, pack_wall
from ..physics.well_path import WellPath
from .lookup import config_dirs, is_file
from .yaml_bounds import read_text, shown

__all__ = ['read_survey', 'scenario_well', 'resolve_survey', 'well_of', 'wall_of',
           'string_weight_N',
           'MAX_SURVEY_BYTES', 'MAX_STATIONS']

#: largest survey file read [bytes] and most stations (a station every 1 m over 20 km is
#: 20,000 lines of ~30 bytes)
MAX_SURVEY_BYTES = 1 << 20
MAX_STATIONS = 100_000


def resolve_survey(name) -> Path:
    """The file a ``well.survey`` value names (see the module docstring)."""
    path = Path(name)
    if is_file(path):
        return path
    for folder in config_dirs():
        for candidate in (folder / 'wells' / path, folder / 'wells' / f'{path}.csv'):
            if is_file(candidate):
                return candidate
    known = sorted({p.name for d in config_dirs() if (d / 'wells').is_dir()
                    for p in (d / 'wells').glob('*.csv')})
    raise ConfigError(f'well.survey = {shown(str(name))!r}: no such survey file (in config/wells/: '
                      f'{", ".join(known) or "none"})')


def read_survey(path) -> WellPath:
    """The well path of a survey file (module docstring)."""
    path = Path(path)
    lines = read_text(path, MAX_SURVEY_BYTES, 'survey file').splitlines()
    content = [(number, line) for number, line in enumerate(lines, start=1)
               if line.strip() and not line.lstrip().startswith('#')]
    rows = [_station(path, number, line) for number, line in content[1:]]   # after the header
    if len(rows) < 2 or len(rows) > MAX_STATIONS:
        raise ConfigError(f'{path}: {len(rows)} stations; a survey needs 2 to {MAX_STATIONS} '
                          '(after a header line: measured_depth_m, inclination_deg, '
                          'azimuth_deg)')
    md, inc, azi = np.array(rows).T
    try:
        return WellPath(md, np.radians(inc), np.radians(azi))
    except ParameterError as exc:
        raise ConfigError(f'{path}: {exc}') from None


def _station(path: Path, number: int, line: str) -> tuple:
    parts = [p.strip() for p in line.split(',')]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise ConfigError(f'{path}: line {number}: {line[:60]!r} is not three finite numbers '
                          '(measured depth m, inclination deg, azimuth deg)')
    return values


def scenario_well(scenario) -> WellPath:
    """The well path of an SI scenario: its ``well.survey``, else the vertical well to the
    string's length (read once, when the scenario is built: ``scenario.well_path``).  A
    survey shorter than the string is refused."""
    path = getattr(scenario, 'well_path', None)
    return path if path is not None else well_of(scenario.raw, scenario.system)


def well_of(cfg: dict, system) -> WellPath:
    """The well path of a resolved SI configuration ``cfg`` for the string ``system``
    (:func:`scenario_well`)."""
    length = system.total_length_m
    survey = (cfg.get('well') or {}).get('survey')
    if survey is None:
        return WellPath.vertical(length)
    path = read_survey(resolve_survey(survey))
    if path.total_depth_m < length:
        raise ConfigError(f'well.survey {survey}: ends at {path.total_depth_m:g} m, above the '
                          f'bit of the {length:g} m string')
    return path


def wall_of(cfg: dict, system, model, scales, weight_on_bit_N: float = 0.0,
            path: WellPath | None = None):
    """The kernel's wall array (:func:`~drill_twin.physics.wall_contact.pack_wall`) of a
    finite-element ``model`` in the configured well (``path``: its well path, if already
    read), or None in a vertical well (no survey) or without friction.  The contact forces
    are the statics' of the string rotating in place at ``weight_on_bit_N`` [N]
    (docs/physics.md §9)."""
    well = cfg.get('well') or {}
    if well.get('survey') is None:
        return None
    mu_s = well.get('friction_factor', 0.25)
    if mu_s == 0.0:
        return None
    path = well_of(cfg, system) if path is None else path
    n, r = node_contact(path, system.sections, model.element_lengths_m,
                        system.mud_density_kg_m3, weight_on_bit_N)
    nodes = len(model.element_lengths_m) + 1
    return pack_wall(n, r, mu_s, mu_s * well.get('dynamic_friction_ratio', 1.0),
                     model.axial.mass[1], model.torsional.mass[1],
                     nodes - model.axial.n, nodes - model.torsional.n, scales,
                     well.get('stribeck_speed_m_s', 0.0))


def string_weight_N(scenario, mud_density_kg_m3: float | None = None) -> float:
    """What the string of an SI ``scenario`` weighs on the hook rotating off bottom [N]:
    its buoyed weight in a vertical well, the soft string's frictionless hook load
    ∫ w cos I ds on a deviated path (docs/torque_drag.md eq. 13 with μ = 0; rotation takes
    the axial drag away).  ``mud_density_kg_m3``: another mud than the configuration's."""
    system = scenario.system
    if getattr(scenario, 'wall', None) is None:
        return system.buoyed_weight_N(mud_density_kg_m3)
    mud = system.mud_density_kg_m3 if mud_density_kg_m3 is None else mud_density_kg_m3
    system.buoyed_weight_N(mud)                  # the same checks of the mud
    path = scenario_well(scenario)
    length = min(system.total_length_m, path.total_depth_m)
    return torque_drag(path, system.sections, length, 0.0, ROTATING, mud).hook_load_N
