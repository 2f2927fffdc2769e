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

from . import kernel as K
from .delay_history import new_history, push_sample
from .models import StringModel, max_stable_step
from .parameters import BitRockGroups, ParameterError

__all__ = ['Simulation', 'Trajectory', 'SimulationDiverged']

_RECORD_NAMES = {
    'tau': K.R_TAU, 'bit_axial_speed': K.R_V, 'bit_angular_speed': K.R_OMEGA,
    'weight_on_bit': K.R_W, 'torque_on_bit': K.R_T, 'depth_of_cut': K.R_DELTA,
    'delay': K.R_TAU1, 'delay_residual': K.R_RES, 'angular_stick': K.R_ANG,
    'axial_mode': K.R_AX, 'contact': K.R_CONTACT, 'surface_torque': K.R_TSURF,
    'surface_speed': K.R_OMSURF, 'bit_axial_perturbation': K.R_UBIT,
    'bit_angle_perturbation': K.R_PHIBIT, 'top_axial_speed': K.R_VTOP,
    'stick_time': K.R_STICK_TIME,
}


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
    history_capacity : int, optional
        Ring-buffer samples; default 16 nominal delays worth of steps.
    """

    def __init__(self, model: StringModel, groups: BitRockGroups, time_step: float,
                 drive_time_constant: float = 0.0, history_capacity: int | None = None):
        if not (math.isfinite(time_step) and time_step > 0):
            raise ParameterError(f'time_step must be finite and > 0, got {time_step!r}')
        if time_step > 0.25 * groups.tau_10:
            raise ParameterError(
                f'time_step {time_step:g} is too large for the delay tau_10 = {groups.tau_10:g}'
                ' (need <= tau_10/4)')
        limit = max_stable_step(model, cap=max(time_step, 5e-3))
        if time_step > limit:
            raise ParameterError(
                f'time_step {time_step:g} is outside the RK4 stability region of model '
                f'{model.name} (largest stable step {limit:.3g}; use time_step: auto)')
        self.model = model
        self.groups = groups
        self.h = float(time_step)
        self.A = K.pack_chain(model.axial)
        self.T = K.pack_chain(model.torsional)
        tors = model.torsional
        P = np.zeros(K.N_PARAMS)
        P[K.P_NB] = groups.n_b
        P[K.P_LAM] = groups.lam
        P[K.P_BETA] = groups.beta
        P[K.P_OMEGA] = groups.omega_o
        P[K.P_UPS] = groups.upsilon_o
        P[K.P_WO] = groups.W_o
        P[K.P_TO] = groups.T_o
        P[K.P_PSI] = model.psi
        P[K.P_KTOP_A] = model.axial.k_top
        P[K.P_CTOP_A] = model.axial.c_top
        if tors is not None:
            P[K.P_KTOP_T] = tors.k_top
            P[K.P_CTOP_T] = tors.c_top
            P[K.P_MTOP_T] = tors.m_top
        P[K.P_DRIVE_TAU] = drive_time_constant
        extra_memory = 0.0
        if model.delayed_damping is not None:
            if self.A.shape[1] != 1 or self.T.shape[1] != 1:
                raise ParameterError('delayed dash-pots need single-mass chains (model III)')
            P[K.P_ZDEL_A], P[K.P_TDEL_A], P[K.P_ZDEL_T], P[K.P_TDEL_T] = model.delayed_damping
            extra_memory = max(model.delayed_damping[1], model.delayed_damping[3])
        self.P = P
        self.inputs = np.zeros(K.N_INPUTS)
        self.inputs[K.IN_OMEGA_CMD] = groups.omega_o
        na, nt = self.A.shape[1], self.T.shape[1]
        self.n_axial, self.n_torsional = na, nt
        self.x = np.zeros(2 * na + 2 * nt + 2)
        self.mode = np.array([K.ANG_SLIP, K.AX_DOWN, 1], np.int64)
        self.tau = np.zeros(2)  # [τ, accumulated angular stick time]
        self.counters = np.zeros(K.N_COUNTERS, np.int64)
        cap = history_capacity or int((16 * groups.tau_10 + 2 * extra_memory) / self.h) + 64
        self.hist, self.meta = new_history(cap)
        # nominal motion before τ = 0 (initial function of the DDE)
        for k in range(int((1.5 * groups.tau_10 + extra_memory) / self.h) + 2, -1, -1):
            t = -k * self.h
            push_sample(self.hist, self.meta, t, groups.upsilon_o * t, groups.omega_o * t,
                        groups.upsilon_o, groups.omega_o)

    # --- state access -------------------------------------------------------------
    @classmethod
    def from_scenario(cls, scenario, time_step: float | None = None,
                      drive_time_constant: float = 0.0, perturbation: dict | None = None):
        """The simulation a :class:`~drill_twin.physics.scenario.Scenario` describes, with its
        initial perturbation applied (``perturbation`` replaces the configured one;
        ``time_step`` the configured step)."""
        if scenario.stability_only:
            raise ParameterError('model semi_infinite is a stability model only (thesis §5.2: '
                                 'a massless stuck bit never restarts); use lumped_I to '
                                 'simulate')
        sim = cls(scenario.model, scenario.groups, time_step or scenario.time_step,
                  drive_time_constant=drive_time_constant)
        sim.perturb(where=scenario.perturb_where,
                    **(scenario.initial_perturbation if perturbation is None else perturbation))
        return sim

    @property
    def time(self) -> float:
        """Current dimensionless time τ."""
        return float(self.tau[0])

    def slices(self):
        na, nt = self.n_axial, self.n_torsional
        return {'u': slice(0, na), 'v': slice(na, 2 * na),
                'phi': slice(2 * na, 2 * na + nt), 'omega': slice(2 * na + nt, 2 * na + 2 * nt)}

    def perturb(self, u: float = 0.0, v: float = 0.0, phi: float = 0.0, omega: float = 0.0,
                where: str = 'bit'):
        """Add an instantaneous perturbation (units d*, d*/t*, rad, rad/t*).

        ``where='bit'`` perturbs the bit DOFs only, ``'all'`` every DOF (a rigid
        shift), ``'smooth'`` a field compatible with the top boundary: uniform for a
        free top, linear from zero at a prescribed top to the value at the bit (so
        no element is suddenly strained; in a finite-element string a perturbation
        of the bit node alone is a local strain spike that sticks the bit at once).
        """
        for name, val in (('u', u), ('v', v), ('phi', phi), ('omega', omega)):
            if not math.isfinite(val):
                raise ParameterError(f'perturbation {name} must be finite')
        sl = self.slices()
        for name, val in (('u', u), ('v', v), ('phi', phi), ('omega', omega)):
            idx = sl[name]
            if idx.stop == idx.start:
                continue
            if where == 'bit':
                self.x[idx.stop - 1] += val
            elif where == 'all':
                self.x[idx] += val
            elif where == 'smooth':
                chain = self.model.axial if name in ('u', 'v') else self.model.torsional
                n = idx.stop - idx.start
                fixed = chain.k_top > 0 or chain.c_top > 0
                profile = np.arange(1, n + 1) / n if fixed else np.ones(n)
                self.x[idx] += val * profile
            else:
                raise ParameterError(f"perturbation 'where' must be bit, all or smooth, "
                                     f'got {where!r}')
        if self.groups.upsilon_o + self.x[sl['v'].stop - 1] < 0:
            self.mode[K.MD_AX] = K.AX_UP

    def set_perturbation_state(self, y):
        """Set the perturbation state ``[u, u', φ, φ']`` of all DOFs (the layout of
        :func:`drill_twin.stability.linearize.linearize`)."""
        y = np.asarray(y, float)
        n = 2 * self.n_axial + 2 * self.n_torsional
        if y.shape != (n,) or not np.all(np.isfinite(y)):
            raise ParameterError(f'perturbation state must be {n} finite numbers')
        self.x[:n] = y

    def set_surface_speed(self, omega: float):
        """Command the dimensionless surface (motor) speed."""
        if not (math.isfinite(omega) and omega >= 0):
            raise ParameterError(f'surface speed must be finite and >= 0, got {omega!r}')
        self.inputs[K.IN_OMEGA_CMD] = omega

    def set_axial_top_force(self, force: float):
        """Extra downward force on the top DOF, units W* (hook-load change, negated)."""
        if not math.isfinite(force):
            raise ParameterError('axial top force must be finite')
        self.inputs[K.IN_AXIAL_FORCE] = force

    def set_motor_torque(self, torque: float):
        """Extra torque on the top torsional DOF, units C (external torque drive)."""
        if not math.isfinite(torque):
            raise ParameterError('motor torque must be finite')
        self.inputs[K.IN_MOTOR_TORQUE] = torque

    # --- running ---------------------------------------------------------------------
    def advance(self, n_steps: int, record_every: int = 0, record_state: bool = False):
        """Advance ``n_steps`` steps; return a :class:`Trajectory` of the recorded rows."""
        n_rows = n_steps // record_every if record_every > 0 else 0
        record = np.zeros((n_rows, K.N_RECORD))
        state = np.zeros((n_rows if record_state else 0, self.x.size))
        n_rec = np.zeros(1, np.int64)
        K.advance(int(n_steps), self.h, self.tau, self.x, self.mode, self.P, self.inputs,
                  self.A, self.T, self.hist, self.meta, self.counters, record,
                  int(record_every), n_rec, state)
        if self.counters[K.C_STATUS] != K.STATUS_OK:
            idx = int(self.counters[K.C_BAD_INDEX])
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
        data = np.concatenate(parts) if parts else np.zeros((0, K.N_RECORD))
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
        row = np.zeros(K.N_RECORD)
        K.snapshot(self.tau, self.x, self.mode, self.P, self.inputs, self.A, self.T, self.hist,
                   self.meta, row)
        return {name: float(row[i]) for name, i in _RECORD_NAMES.items()}

    @property
    def history_overflows(self) -> int:
        return int(self.meta[2])

    @property
    def event_count(self) -> int:
        return int(self.counters[K.C_EVENTS])

    @property
    def impulse_count(self) -> int:
        return int(self.counters[K.C_IMPULSES])
