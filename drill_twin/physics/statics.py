"""Static states of the drill string: at rest off bottom, and the tension along it.

The equations of motion (:mod:`drill_twin.physics.models`) are written for the
perturbation about steady drilling: zero perturbation is the string compressed
at the bit by the nominal WOB W_o and twisted by the nominal torque T_o, moving
at υ_o, ω_o.  A string **at rest** is therefore a particular perturbation,
found here from the static balance ``K q = f`` (the damping and mass terms vanish):

* axial, bit off bottom (W = 0): ``K_a u = ψ W_o e_bit + ψ F_top e_0 + k_a z_p e_0``.
  The hook carries the whole buoyed weight.  With a constant-hook-load top the
  chain has a rigid mode: the top force must balance (``F_top = -W_o``: hook load =
  buoyed weight) and the shape is fixed up to a shift, chosen to put the bit
  ``gap`` above the rock.  With a hoist or an imposed top the block position
  ``z_p`` is solved for instead (two unit solutions, superposed);
* torsional, untwisted (T = 0): ``K_t φ = T_o e_bit + k_t θ_p e_0`` with the motor
  angle θ_p = 0; a free top node (the motor of a PI top drive) holds no torque either,
  ``K_t φ = T_o (e_bit - e_0)`` with its angle pinned, and the PI loop's integral is
  the one that makes the motor torque zero at zero speed error;
* velocities: all total velocities zero (perturbations -υ_o and -ω_o), the motor and
  the block commanded to rest;
* the rock: a flat bottom (never cut by these blades) at the origin of U.

Element tension (positive in tension, N) along the string: the reference
tension of steady drilling, ``buoyed weight below - W_o``, plus the elastic
change ``k_e (u_{i+1} - u_i)`` of every element (chain force units ``M d*/t*²``,
divided by ψ to W*).
"""
from __future__ import annotations

import numpy as np

from .bottom_surface import fill_flat
from .layout import ANGULAR, AXIAL, INPUT, MODE

__all__ = ['rest_state', 'element_tension_N', 'element_weights_below_N']


def _static_solve(chain, rhs, pin=None):
    """``K q = rhs``; with a rigid mode (free chain) the first DOF is pinned to 0."""
    Kd = chain.dense('stiffness')
    if pin is None:
        return np.linalg.solve(Kd, rhs)
    q = np.zeros(chain.n)
    q[1:] = np.linalg.solve(Kd[1:, 1:], rhs[1:])
    return q


def rest_state(sim, gap: float):
    """Put a :class:`~drill_twin.physics.simulation.Simulation` at rest, its bit ``gap``
    (units d*) above a flat bottom, at its current time; returns the block position
    perturbation used (d*)."""
    model, top, g = sim.model, sim.top, sim.groups
    na, nt = sim.n_axial, sim.n_torsional
    sl = sim.slices()
    tau = sim.time
    x = sim.x
    # --- axial: the whole buoyed weight on the hook
    e_bit = np.zeros(na)
    e_bit[-1] = 1.0
    e_top = np.zeros(na)
    e_top[0] = 1.0
    ax = model.axial
    u_target = -gap - g.upsilon_o * tau       # the bit at U = -gap (the rock at 0)
    if top.k_a > 0.0:                          # hoist or imposed top: solve for z_p
        base = _static_solve(ax, top.psi * g.W_o * e_bit)
        unit = _static_solve(ax, top.k_a * e_top)
        z_p = (u_target - base[-1]) / unit[-1]
        u = base + z_p * unit
        sim.inputs[INPUT.axial_force] = 0.0
    else:                                      # constant hook load: hook load = weight
        sim.inputs[INPUT.axial_force] = -g.W_o
        u = _static_solve(ax, top.psi * g.W_o * (e_bit - e_top), pin=True)
        u += u_target - u[-1]
        z_p = 0.0
    x[sl['u']] = u
    x[sl['v']] = -g.upsilon_o
    x[sl['block']] = z_p
    sim.inputs[INPUT.block_velocity] = 0.0
    # --- torsional: untwisted, motor angle θ_p = 0, everything at rest
    if nt > 0:
        e = np.zeros(nt)
        e[-1] = 1.0
        if top.k_t > 0.0:                      # tied to the motor angle: solve
            x[sl['phi']] = _static_solve(model.torsional, g.T_o * e)
        else:                                  # a free top node (the motor's): it holds
            e_top_t = np.zeros(nt)             # no torque either, the angle is pinned
            e_top_t[0] = 1.0
            x[sl['phi']] = _static_solve(model.torsional, g.T_o * (e - e_top_t), pin=True)
        x[sl['omega']] = -g.omega_o
        if top.drive_pi > 0.0:                 # the PI loop at rest: no motor torque
            x[sl['drive_integral']] = -g.T_o / top.ki
            x[sl['torque_reference']] = -g.T_o
    x[sl['drive_angle']] = 0.0
    x[sl['drive_speed']] = -g.omega_o
    sim.inputs[INPUT.speed_command] = 0.0
    # --- the rock: flat, at U = 0; no blade on it
    fill_flat(sim.surface, 0.0, tau)
    sim.mode[MODE.angular] = ANGULAR.slip
    sim.mode[MODE.axial] = AXIAL.down
    sim.mode[MODE.contact:] = 0
    sim.start_bit[:] = 0.0
    sim.settle_wall()                          # every node in contact with the wall sticks
    return float(z_p)


def element_weights_below_N(system, element_lengths_m, section_elements,
                            cos_inclination=None) -> np.ndarray:
    """Buoyed weight hanging below the top of every element [N] (top to bottom); with
    ``cos_inclination`` (cos I at every element's middle, a deviated well) its axial part,
    what the tension carries when the wall takes the rest (soft string, no axial drag)."""
    weights = []
    for sec, n in zip(system.sections, section_elements):
        per = sec.buoyed_weight_N(system.mud_density_kg_m3) / n
        weights += [per] * n
    weights = np.asarray(weights)
    if cos_inclination is not None:
        weights = weights * np.asarray(cos_inclination, float)
    return np.cumsum(weights[::-1])[::-1]


def element_tension_N(scenario, sim, cos_inclination=None) -> np.ndarray:
    """Tension of every finite element of the string now [N], top to bottom (the
    weight below — its axial part in a deviated well, ``cos_inclination`` per element — and
    the nominal WOB of the reference state, plus the elastic change)."""
    model = sim.model
    if model.element_lengths_m is None:
        raise ValueError('element tensions need a finite-element string')
    s = scenario.scales
    ax = model.axial
    u = sim.x[sim.slices()['u']]
    if hasattr(ax, 'expand'):                        # a reduced string: its nodes
        ax, u = ax.full, ax.expand(u)
    below = element_weights_below_N(scenario.system, model.element_lengths_m,
                                    model.section_elements, cos_inclination)
    reference = below - sim.groups.W_o * s.force_N
    elastic = -ax.stiffness[2, :-1] * np.diff(u)    # k_e (u_{e+1} - u_e) between DOFs
    if ax.n == len(model.element_lengths_m):         # imposed top: its node was eliminated
        z_p = sim.x[sim.slices()['block']][0]
        elastic = np.concatenate([[ax.k_top * (u[0] - z_p)], elastic])
    return reference + elastic / model.psi * s.force_N
