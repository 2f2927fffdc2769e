"""Typed Python API around the jitted kernel: build, perturb, drive and run a model.

A :class:`Simulation` owns the state arrays of one run (state vector, interface
mode, delay history, counters) and advances them in place through
:func:`drill_twin.physics.kernel.advance`; all integration steps happen inside
numba.  The same object serves the offline CLI and a real-time node (call
:meth:`Simulation.advance` with the number of steps that matches wall time).
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from . import kernel as K
from .bottom_surface import fill_steady, new_surface, nodes_for
from .chain import pack_chain
from .layout import (
    ANGULAR,
    AXIAL,
    CONTACT,
    COUNTER,
    DRIVE,
    INPUT,
    MODE,
    RECORD_CHANNELS,
    SIGNAL,
    START,
    STATUS,
    TIME,
    WALL,
    state_layout,
)
from .models import StringModel, max_stable_step, rgd
from .parameters import BitRockGroups
from .time_history import new_time_history, push_sample
from .top_drive import kernel_drive
from .wall_contact import NO_WALL

__all__ = ['Simulation', 'Trajectory', 'SimulationDiverged', 'bit_law', 'top_coupling',
           'compile_kernels', 'state_slices']

_RECORD_NAMES = {name: i for i, name in enumerate(RECORD_CHANNELS)}


def bit_law(groups: BitRockGroups):
    """The kernel's :class:`~drill_twin.physics.kernel.Law`, the surface period and the
    smallest blade gap: an even bit is one blade group of n_b blades on a period of one
    pitch 2π/n_b; an uneven bit has one group per blade on the full circle."""
    if groups.uneven:
        offsets = np.array(groups.blade_angles, float)
        weights = np.ones(groups.n_b)
        period = 2.0 * math.pi
    else:
        offsets = np.zeros(1)
        weights = np.full(1, float(groups.n_b))
        period = 2.0 * math.pi / groups.n_b
    law = K.Law(float(groups.lam), float(groups.beta), offsets, weights)
    return law, period, min(groups.blade_gaps)


def top_coupling(model: StringModel, groups: BitRockGroups, drive_time_constant: float = 0.0):
    """The kernel's :class:`~drill_twin.physics.kernel.Top` of a model at an operating
    point."""
    tors = model.torsional
    z_a = tau_a = z_t = tau_t = 0.0
    if model.delayed_damping is not None:
        z_a, tau_a, z_t, tau_t = model.delayed_damping
    drive = model.motor_drive or kernel_drive(None, None)
    return K.Top(omega_o=float(groups.omega_o), upsilon_o=float(groups.upsilon_o),
                 W_o=float(groups.W_o), T_o=float(groups.T_o), psi=float(model.psi),
                 k_t=float(tors.k_top) if tors is not None else 0.0,
                 c_t=float(tors.c_top) if tors is not None else 0.0,
                 m_t=float(tors.m_top) if tors is not None else 0.0,
                 k_a=float(model.axial.k_top), c_a=float(model.axial.c_top),
                 drive_node=1.0 if tors is not None and tors.drive_node else 0.0,
                 drive_tau=float(drive_time_constant), z_a=float(z_a), tau_a=float(tau_a),
                 z_t=float(z_t), tau_t=float(tau_t),
                 **{k: float(v) for k, v in drive.items()})


def state_slices(na: int, nt: int) -> dict:
    """Slices of the parts of the state vector of ``na`` axial and ``nt`` torsional DOFs,
    from :func:`~drill_twin.physics.layout.state_layout`: ``u, v, phi, omega`` and the drive
    block's entries under their names (``drive_angle, drive_speed, block, drive_integral,
    torque_reference``)."""
    L = state_layout.py_func(na, nt)
    out = {'u': slice(L.u, L.u + na), 'v': slice(L.v, L.v + na),
           'phi': slice(L.phi, L.phi + nt), 'omega': slice(L.omega, L.omega + nt)}
    for name, index in DRIVE._asdict().items():
        out[_DRIVE_SLICE_NAMES[name]] = slice(L.drive + index, L.drive + index + 1)
    return out


#: the names :meth:`Simulation.slices` gives the drive block's entries
_DRIVE_SLICE_NAMES = {'angle': 'drive_angle', 'speed': 'drive_speed', 'block': 'block',
                      'integral': 'drive_integral', 'torque_reference': 'torque_reference'}


class SimulationDiverged(RuntimeError):
    """The state became non-finite; the message says when and where."""


@dataclass
class Trajectory:
    """Recorded dimensionless time series of one run.

    Attributes are 1-D arrays named after :data:`_RECORD_NAMES` (τ, bit
    speeds υ_o+υ and ω_o+ω, W, T, δ, τ_1, residual of eq. 2.4.14, modes ...),
    and ``state`` (rows of the full state vector) when requested.
    """

    data: np.ndarray
    state: np.ndarray | None = None

    def __getattr__(self, name):
        if name in _RECORD_NAMES:
            return self.data[:, _RECORD_NAMES[name]]
        raise AttributeError(name)

    def __len__(self):
        return self.data.shape[0]

    @staticmethod
    def channels():
        return list(_RECORD_NAMES)


class Simulation:
    """One run of a drill-string model with the bit/rock law.

    Parameters
    ----------
    model : StringModel
        Chains and bit-force scale (:mod:`drill_twin.physics.models`).
    groups : BitRockGroups
        Dimensionless operating point and interface numbers.
    time_step : float
        Integration step Δτ (units of t*).
    drive_time_constant : float
        First-order lag of the surface speed drive following its command
        (units t*); 0 = ideal stiff speed drive.
    surface_nodes : int, optional
        Nodes of the bottom surface over its period; default four per nominal step
        of rotation (:func:`~drill_twin.physics.bottom_surface.nodes_for`).
    """

    def __init__(self, model: StringModel, groups: BitRockGroups, time_step: float,
                 drive_time_constant: float = 0.0, surface_nodes: int | None = None):
        if not (math.isfinite(time_step) and time_step > 0):
            raise ParameterError(f'time_step must be finite and > 0, got {time_step!r}')
        if time_step > 0.25 * groups.min_delay:
            raise ParameterError(
                f'time_step {time_step:g} is too large for the delay {groups.min_delay:g}'
                ' (need <= a quarter of the shortest blade delay)')
        limit = max_stable_step(model, cap=max(time_step, 5e-3))
        if time_step > limit:
            raise ParameterError(
                f'time_step {time_step:g} is outside the RK4 stability region of model '
                f'{model.name} (largest stable step {limit:.3g}; use time_step: auto)')
        self.model = model
        self.groups = groups
        self.h = float(time_step)
        self.A = pack_chain(model.axial)
        self.T = pack_chain(model.torsional)
        self.law, period, min_gap = bit_law(groups)
        self.top = top_coupling(model, groups, drive_time_constant)
        if model.delayed_damping is not None and (self.A.shape[1] != 1 or self.T.shape[1] != 1):
            raise ParameterError('delayed dash-pots need single-mass chains (model III)')
        self.inputs = np.zeros(len(INPUT))
        self.inputs[INPUT.speed_command] = groups.omega_o
        self.inputs[INPUT.block_velocity] = groups.upsilon_o
        self.inputs[INPUT.torque_limit] = self.top.t_max
        na, nt = self.A.shape[1], self.T.shape[1]
        self.n_axial, self.n_torsional = na, nt
        self.x = np.zeros(state_layout.py_func(na, nt).size)
        self.mode = np.zeros(MODE.contact + self.law.offsets.size, np.int64)
        self.mode[MODE.angular], self.mode[MODE.axial] = ANGULAR.slip, AXIAL.down
        self.mode[MODE.contact:] = 1
        self.tau = np.zeros(len(TIME))  # the clock: τ and the accumulated angular stick time
        self.counters = np.zeros(len(COUNTER), np.int64)
        # bit motion at the end of the initial function, when a perturbation jumps from it
        self.start_bit = np.zeros(len(START))
        # the bottom surface of steady drilling (the initial function of the DDE)
        nodes = surface_nodes or nodes_for(period, groups.omega_o * self.h, min_gap)
        self.surface, self.geom = new_surface(period, nodes, min_gap)
        fill_steady(self.surface, self.geom, self.law.offsets, groups.upsilon_o,
                    groups.omega_o)
        # the signal history of the constant delays (lumped model III, drive sensors)
        memory = max(self.top.tau_a, self.top.tau_t, self.top.t_delay)
        self.th, self.thm = new_time_history(int(1.5 * memory / self.h) + 64 if memory else 4)
        self.wall = NO_WALL
        self.contact = np.zeros(0, np.int64)
        if memory:
            steady = np.zeros(len(SIGNAL))
            steady[SIGNAL.bit_axial_speed] = groups.upsilon_o
            steady[SIGNAL.bit_angular_speed] = groups.omega_o
            for k in range(int(1.2 * memory / self.h) + 2, -1, -1):
                push_sample(self.th, self.thm, -k * self.h, steady, np.zeros(len(SIGNAL)))

    # --- state access -------------------------------------------------------------
    @classmethod
    def from_scenario(cls, scenario, time_step: float | None = None,
                      drive_time_constant: float = 0.0, perturbation: dict | None = None):
        """The simulation a :class:`~drill_twin.config.scenario.Scenario` describes, with its
        initial perturbation applied (``perturbation`` replaces the configured one;
        ``time_step`` the configured step)."""
        if scenario.stability_only:
            raise ParameterError('model semi_infinite is a stability model only (thesis §5.2: '
                                 'a massless stuck bit never restarts); use lumped_I to '
                                 'simulate')
        sim = cls(scenario.integrated_model, scenario.groups, time_step or scenario.time_step,
                  drive_time_constant=drive_time_constant)
        if getattr(scenario, 'wall', None) is not None:
            sim.set_wall(scenario.wall)
        sim.perturb(where=scenario.perturb_where,
                    **(scenario.initial_perturbation if perturbation is None else perturbation))
        return sim

    @property
    def time(self) -> float:
        """Current dimensionless time τ."""
        return float(self.tau[0])

    def slices(self):
        """Named slices of the state vector (:func:`drill_twin.physics.layout.state_layout`):
        ``u, v, phi, omega`` and the drive block's ``drive_angle, drive_speed, block,
        drive_integral, torque_reference``."""
        return state_slices(self.n_axial, self.n_torsional)

    def kernel_model(self) -> K.Model:
        """What the kernel integrates (:class:`~drill_twin.physics.kernel.Model`)."""
        return K.Model(self.law, self.top, self.A, self.T, self.geom, self.wall)

    def set_wall(self, wall: np.ndarray):
        """The nodes in contact with the wall (:func:`~drill_twin.physics.wall_contact.
        pack_wall`); each starts stuck if its total velocity is zero, else sliding."""
        wall = np.ascontiguousarray(wall, float)
        if wall.ndim != 2 or wall.shape[0] != len(WALL):
            raise ParameterError(f'wall array must have {len(WALL)} rows')
        self.wall = wall
        self.contact = np.zeros(wall.shape[1], np.int64)
        self.settle_wall()

    def settle_wall(self):
        """Each wall node sticks if its total velocity is zero (a string at rest), else
        slides."""
        L = state_layout.py_func(self.n_axial, self.n_torsional)
        for j in range(self.wall.shape[1]):
            ia, it = int(self.wall[WALL.axial_dof, j]), int(self.wall[WALL.torsional_dof, j])
            rest = self.top.upsilon_o + self.x[L.v + ia] == 0.0 and \
                self.top.omega_o + self.x[L.omega + it] == 0.0
            self.contact[j] = CONTACT.stick if rest else CONTACT.slide

    def kernel_state(self) -> K.State:
        """The arrays the kernel updates (:class:`~drill_twin.physics.kernel.State`), this
        simulation's own (built at each call: attributes may have been replaced)."""
        return K.State(self.tau, self.x, self.mode, self.inputs, self.surface, self.th,
                       self.thm, self.counters, self.start_bit, self.contact)

    def perturb(self, u: float = 0.0, v: float = 0.0, phi: float = 0.0, omega: float = 0.0,
                where: str = 'bit'):
        """Add an instantaneous perturbation (units d*, d*/t*, rad, rad/t*).

        ``where='bit'`` perturbs the bit DOFs only, ``'all'`` every DOF (a rigid
        shift), ``'smooth'`` a field compatible with the top boundary: uniform for a
        free top, linear from zero at a prescribed or driven top (spring, dash-pot, or the
        motor drive's controller) to the value at the bit (so
        no element is suddenly strained; in a finite-element string a perturbation
        of the bit node alone is a local strain spike that sticks the bit at once).
        A reduced string (:mod:`~drill_twin.physics.reduction`) gets the projection of that
        field of its nodes on its coordinates (kinetic-energy norm).
        """
        for name, val in (('u', u), ('v', v), ('phi', phi), ('omega', omega)):
            if not math.isfinite(val):
                raise ParameterError(f'perturbation {name} must be finite')
        if where not in ('bit', 'all', 'smooth'):
            raise ParameterError(f"perturbation 'where' must be bit, all or smooth, "
                                 f'got {where!r}')
        sl = self.slices()
        for name, val in (('u', u), ('v', v), ('phi', phi), ('omega', omega)):
            idx = sl[name]
            if idx.stop == idx.start:
                continue
            chain = self.model.axial if name in ('u', 'v') else self.model.torsional
            n = getattr(chain, 'full', chain).n       # the chain's nodes
            if where == 'bit':
                profile = np.zeros(n)
                profile[-1] = 1.0
            elif where == 'all':
                profile = np.ones(n)
            else:
                # a top held by a spring, a dash-pot or the drive's controller
                fixed = chain.k_top > 0 or chain.c_top > 0 or (
                    name in ('phi', 'omega') and bool(self.model.motor_drive))
                profile = np.arange(1, n + 1) / n if fixed else np.ones(n)
            if hasattr(chain, 'project'):                # a reduced chain: its coordinates
                profile = chain.project(profile)
            self.x[idx] += val * profile
        if self.groups.upsilon_o + self.x[sl['v'].stop - 1] < 0:
            self.mode[MODE.axial] = AXIAL.up
        self._jump_from_initial_function()

    def _jump_from_initial_function(self):
        """A perturbation at τ = 0 jumps from the DDE's initial function (the nominal
        motion up to τ = 0): the rock swept by the first step is written from that motion,
        not from the perturbed state (the convention of the thesis and of the delay
        formulation; an instantaneous jump of the bit angle would otherwise leave a sector
        of rock uncut)."""
        if self.time == 0.0 and self.counters[COUNTER.steps] == 0:
            g = self.groups
            start = self.start_bit
            start[START.position], start[START.velocity] = 0.0, g.upsilon_o
            start[START.angle], start[START.speed] = 0.0, g.omega_o
            start[START.pending] = 1.0

    def set_perturbation_state(self, y):
        """Set the perturbation state ``[u, u', φ, φ']`` of all DOFs, followed for a motor
        drive by its integral ϑ_p and torque reference T_ref (the layout of
        :func:`drill_twin.stability.linearize.linearize`)."""
        y = np.asarray(y, float)
        n = 2 * self.n_axial + 2 * self.n_torsional
        sizes = (n, n + 2) if self.model.motor_drive else (n,)
        if y.shape not in [(k,) for k in sizes] or not np.all(np.isfinite(y)):
            raise ParameterError(f'perturbation state must be {" or ".join(map(str, sizes))}'
                                 ' finite numbers')
        self.x[:n] = y[:n]
        if y.size > n:
            sl = self.slices()
            self.x[sl['drive_integral']] = y[n]
            self.x[sl['torque_reference']] = y[n + 1]
        self._jump_from_initial_function()

    def set_surface_speed(self, omega: float):
        """Command the dimensionless surface (motor) speed."""
        if not (math.isfinite(omega) and omega >= 0):
            raise ParameterError(f'surface speed must be finite and >= 0, got {omega!r}')
        self.inputs[INPUT.speed_command] = omega

    def set_axial_top_force(self, force: float):
        """Extra downward force on the top DOF, units W* (hook-load change, negated)."""
        if not math.isfinite(force):
            raise ParameterError('axial top force must be finite')
        self.inputs[INPUT.axial_force] = force

    def set_torque_limit(self, limit: float):
        """Torque limit of the PI motor drive in force (units C, ≥ 0): at most the drive's
        rated limit; a larger value leaves the rated one."""
        if not (math.isfinite(limit) and limit >= 0.0):
            raise ParameterError(f'torque limit must be finite and >= 0, got {limit!r}')
        self.inputs[INPUT.torque_limit] = limit

    def set_block_velocity(self, velocity: float):
        """Command the block (top of an imposed-velocity string, or drum of a hoist) to move
        down at ``velocity`` (units d*/t*; the nominal ROP υ_o keeps it on the steady
        motion)."""
        if not math.isfinite(velocity):
            raise ParameterError('block velocity must be finite')
        self.inputs[INPUT.block_velocity] = velocity

    # --- running ---------------------------------------------------------------------
    def advance(self, n_steps: int, record_every: int = 0, record_state: bool = False):
        """Advance ``n_steps`` steps; return a :class:`Trajectory` of the recorded rows."""
        n_rows = n_steps // record_every if record_every > 0 else 0
        record = np.zeros((n_rows, len(RECORD_CHANNELS)))
        state = np.zeros((n_rows if record_state else 0, self.x.size))
        n_rec = np.zeros(1, np.int64)
        K.advance(int(n_steps), self.h, self.kernel_model(), self.kernel_state(),
                  K.Recording(record, state, int(record_every), n_rec))
        if self.counters[COUNTER.status] != STATUS.ok:
            idx = int(self.counters[COUNTER.bad_index])
            part = next((k for k, s in self.slices().items() if s.start <= idx < s.stop),
                        'drive')
            raise SimulationDiverged(
                f'state became non-finite at tau = {self.time:.6g} in {part}[{idx}] '
                f'of model {self.model.name}')
        r = int(n_rec[0])
        return Trajectory(record[:r], state[:r] if record_state else None)

    def run(self, duration: float, record_interval: float | None = None,
            record_state: bool = False, progress=None, chunk: float = 50.0) -> Trajectory:
        """Integrate for ``duration`` (units t*), recording every ``record_interval``.

        ``progress`` is an optional callable ``f(fraction_done)``.
        """
        if not (math.isfinite(duration) and duration > 0):
            raise ParameterError(f'duration must be finite and > 0, got {duration!r}')
        every = max(1, round((record_interval or self.h) / self.h))
        total = int(round(duration / self.h))
        per_chunk = max(every, int(chunk / self.h) // every * every)
        parts, states, done = [], [], 0
        while done < total:
            n = min(per_chunk, total - done)
            traj = self.advance(n, every, record_state)
            parts.append(traj.data)
            if record_state:
                states.append(traj.state)
            done += n
            if progress is not None:
                progress(done / total)
        data = np.concatenate(parts) if parts else np.zeros((0, len(RECORD_CHANNELS)))
        state = np.concatenate(states) if record_state and states else None
        return Trajectory(data, state)

    def warm_up(self):
        """Compile (or load from numba's cache) and execute once every kernel that
        :meth:`advance` and :meth:`snapshot` call, on a copy of this simulation (its state
        is untouched), so that the first real step of a real-time loop costs what every
        other step costs."""
        scratch = copy.deepcopy(self)
        scratch.advance(2, record_every=1, record_state=True)
        scratch.snapshot()

    def snapshot(self) -> dict:
        """Current recorded channels (dimensionless), without advancing."""
        row = np.zeros(len(RECORD_CHANNELS))
        K.snapshot(self.kernel_model(), self.kernel_state(), row)
        return {name: float(row[i]) for name, i in _RECORD_NAMES.items()}

    @property
    def history_overflows(self) -> int:
        """Reads of the velocity history before its oldest sample (model III; 0 when the
        capacity is right).  The bottom surface itself cannot overflow."""
        return int(self.thm[2])

    @property
    def surface_writes(self) -> int:
        """Surface nodes written so far (the blades' passes over the rock)."""
        return int(self.counters[COUNTER.writes])

    @property
    def event_count(self) -> int:
        return int(self.counters[COUNTER.events])

    @property
    def impulse_count(self) -> int:
        return int(self.counters[COUNTER.impulses])


def compile_kernels():
    """Compile (or load from numba's cache) every kernel a simulation runs.

    Every model runs the same compiled code (the kernel's arguments have the same types
    whatever the model: its size and drives are data), so warming up the smallest model
    — the RGD of thesis §4.1 at the point of its stick-slip figure — compiles it all."""
    groups = BitRockGroups(n_b=6, lam=5.0 / 6.0, beta=0.3, W_o=7.0, omega_o=5.0, psi=50.0)
    Simulation(rgd(50.0), groups, 2e-3).warm_up()
