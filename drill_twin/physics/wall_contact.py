"""The wall's contact along a finite-element string in a well: what each node presses
on the wall and how it rubs, packed for the kernel (docs/physics.md §9).

Every node i of the mesh (measured depth s_i) carries the wall contact of its tributary
length, half of each element beside it: the resultant normal force

    n_i = ∫ N(s) ds over [s_i - h_{i-1}/2, s_i + h_i/2]                       (9.1)

with N [N/m] the soft-string contact force per unit length (docs/torque_drag.md eq. 11)
of the string rotating in place at the given weight on bit, and the radius r_i at which
it acts, r_i = ∫ N r ds / n_i (the pipe's outer radius; at a section joint, the mean of
the two sections weighted by their share of the contact).  Both come from the statics'
torque integral (eq. 14, Simpson's weights on the Runge–Kutta stages), split at the
joints: ∫ N r ds over a piece of one section is the torque change of the rotating string
with μ = 1, and ∫ N ds that change divided by the section's radius.  The bit node
(the last half element) rubs on the wall while the bit is off bottom; while a blade is
on the rock the bit's own event-located law holds it, unchanged, and the kernel leaves
that half element's wall friction out (an error of h/2 of contact that vanishes with the
mesh).

The friction capacities μ_s n_i, μ_d n_i and the velocities are made dimensionless with
the scales of eq. 2.4.1: forces in M d*/t*², radii in d*, and the torsional inertia seen
at the rim as the tangential mass κ m_t/ρ², κ = C t*²/(M d*²) (eq. 9.3).
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError
from .layout import WALL
from .torque_drag import ROTATING, torque_drag
from .well_path import WellPath

__all__ = ['node_contact', 'pack_wall', 'NO_WALL', 'rim_inertia_factor']

#: the kernel's wall array of a string that touches nothing (a vertical well)
NO_WALL = np.zeros((len(WALL), 0))


def node_depths_m(element_lengths_m) -> np.ndarray:
    """Measured depth of every node of the mesh [m], the top node at 0."""
    return np.concatenate([[0.0], np.cumsum(np.asarray(element_lengths_m, float))])


def node_contact(path: WellPath, sections, element_lengths_m, mud_density_kg_m3: float,
                 weight_on_bit_N: float = 0.0, **statics) -> tuple[np.ndarray, np.ndarray]:
    """Normal force n_i [N] and contact radius r_i [m] of every node (eq. 9.1).

    Parameters
    ----------
    path : WellPath
        The well; the string's bit is at its length below MD 0.
    sections : sequence of StringSection
        The string, top to bottom (the mesh's sections).
    element_lengths_m : array_like
        The mesh, top to bottom [m]; section joints are nodes.
    mud_density_kg_m3 : float
        Mud density for the buoyed weight [kg/m³].
    weight_on_bit_N : float
        Weight on bit of the statics [N] (0: off bottom).
    **statics
        ``gravity_m_s2``, ``max_step_m`` of :func:`~drill_twin.physics.torque_drag.
        torque_drag`.
    """
    s = node_depths_m(element_lengths_m)
    depth = float(s[-1])
    if depth > path.total_depth_m * (1.0 + 1e-12):
        raise ParameterError(f'the well path ends at {path.total_depth_m:g} m, above the bit '
                             f'of the {depth:g} m string')
    depth = min(depth, path.total_depth_m,              # the mesh's round-off
                sum(sec.length_m for sec in sections))
    s[-1] = depth
    mid = 0.5 * (s[:-1] + s[1:])
    marks = np.sort(np.concatenate([s, mid]))          # node, midpoint, node, ...
    profile = torque_drag(path, sections, depth, 1.0, ROTATING, mud_density_kg_m3,
                          weight_on_bit_N, 0.0, nodes_m=marks[1:-1], **statics)
    torque = np.interp(marks, profile.measured_depth_m, profile.torque_Nm)
    pieces = torque[:-1] - torque[1:]                  # ∫ N r ds of each half element
    radius = _piece_radius(sections, marks, depth)
    force = pieces / radius
    # piece 2i-1 and 2i belong to node i (piece 2i-1 above it, 2i below it)
    n = np.zeros(s.size)
    nr = np.zeros(s.size)
    owner = np.repeat(np.arange(s.size - 1), 2)
    owner[1::2] += 1
    np.add.at(n, owner, force)
    np.add.at(nr, owner, pieces)
    r = np.divide(nr, n, out=np.zeros_like(n), where=n > 0.0)
    return n, r


def _piece_radius(sections, marks, depth) -> np.ndarray:
    """Outer radius [m] of the section each half element lies in."""
    lengths = np.array([sec.length_m for sec in sections])
    bottoms = depth - (lengths.sum() - np.cumsum(lengths))
    centre = 0.5 * (marks[:-1] + marks[1:])
    index = np.minimum(np.searchsorted(bottoms, centre), len(sections) - 1)
    return np.array([0.5 * sections[k].outer_diameter_m for k in index])


def rim_inertia_factor(scales) -> float:
    """κ = C t*²/(M d*²) of eq. 9.3: a node's torsional inertia m_t [I] seen at the rim is the
    tangential mass κ m_t/ρ² [M] of its sliding velocity."""
    return scales.torque_Nm * scales.time_s ** 2 / (scales.mass_kg * scales.depth_m ** 2)


def pack_wall(normal_N, radius_m, static_friction: float, dynamic_friction: float,
              axial_mass, torsional_mass, axial_offset: int, torsional_offset: int,
              scales, stribeck_speed_m_s: float = 0.0) -> np.ndarray:
    """The kernel's wall array (:data:`~drill_twin.physics.layout.WALL` rows, one column
    per node in contact) of a mesh whose node k is axial DOF ``k - axial_offset`` and
    torsional DOF ``k - torsional_offset``.

    Parameters
    ----------
    normal_N, radius_m : array_like
        n_i [N] and r_i [m] per node (:func:`node_contact`).
    static_friction, dynamic_friction : float
        μ_s ≥ μ_d ≥ 0.
    axial_mass, torsional_mass : array_like
        The diagonal of the lumped mass matrices per DOF (dimensionless: / M, / I).
    axial_offset, torsional_offset : int
        Eliminated top nodes of each chain (0 or 1).
    scales : Scales
        Eq. 2.4.1 (t*, d*, C, M).
    stribeck_speed_m_s : float
        v_S [m/s] of eq. 9.9, the sliding speed over which the friction falls from μ_s to
        μ_d (0: at once).
    """
    mu_s, mu_d = float(static_friction), float(dynamic_friction)
    v_s = float(stribeck_speed_m_s)
    if not (math.isfinite(v_s) and v_s >= 0.0):
        raise ParameterError(f'the Stribeck speed must be finite and >= 0 m/s, not {v_s:g}')
    if not (math.isfinite(mu_s) and math.isfinite(mu_d) and 0.0 <= mu_d <= mu_s):
        raise ParameterError(f'wall friction needs 0 <= dynamic ({mu_d:g}) <= static '
                             f'({mu_s:g}) coefficient')
    n = np.asarray(normal_N, float)
    r = np.asarray(radius_m, float)
    force = scales.mass_kg * scales.depth_m / scales.time_s ** 2       # M d*/t*² [N]
    kappa = rim_inertia_factor(scales)
    nodes = [k for k in range(n.size) if k - axial_offset >= 0 and k - torsional_offset >= 0
             and n[k] > 0.0 and mu_s > 0.0]          # not a prescribed node, and in contact
    out = np.zeros((len(WALL), len(nodes)))
    for j, k in enumerate(nodes):
        ia, it = k - axial_offset, k - torsional_offset
        rho = r[k] / scales.depth_m
        out[WALL.axial_dof, j], out[WALL.torsional_dof, j] = ia, it
        out[WALL.static, j], out[WALL.dynamic, j] = mu_s * n[k] / force, mu_d * n[k] / force
        out[WALL.radius, j] = rho
        out[WALL.axial_mass, j] = axial_mass[ia]
        out[WALL.tangential_mass, j] = kappa * torsional_mass[it] / rho ** 2
        out[WALL.stribeck, j] = v_s * scales.time_s / scales.depth_m
    return out
