"""Soft-Torque stick-slip controller (thesis §3.2, after Kyllingstad & Nessjøen [37]).

The controller makes a stiff speed-controlled top drive behave like the tuned
spring-dash-pot drive of §3.2: it integrates a *virtual* drive of inertia
``I_DS`` tied to the operator's set-point by a spring ``k_f`` and a dash-pot
``c_f`` and loaded by the measured string torque ``T_s`` at the surface,

    I_DS ω' = k_f Δθ + c_f (ω_set - ω) - (T_s - T_ref),     Δθ' = ω_set - ω,

and commands the motor speed ``ω``.  At steady drilling ω = ω_set; a torque
rise slows the drive down like a soft spring, which absorbs the first
torsional mode.  Tuning: ``k_f = I_DS/t*²`` (drive frequency = the string's
1/t* = sqrt(C/I)), ``c_f = 2 ξ_opt sqrt(k_f I_DS)``, ``ξ_opt = sqrt(I/(2 I_DS))``.
``T_ref`` (the torque at the set-point) is tracked by a slow low-pass filter so
that the spring only reacts to torque *oscillations*.

Pure Python, no ROS: :mod:`drill_twin.ros.soft_torque_node` is the adapter.
"""
from __future__ import annotations

import math

from ..errors import ParameterError

__all__ = ['SoftTorqueController']


class SoftTorqueController:
    """Discrete Soft-Torque controller.

    Parameters
    ----------
    inertia, stiffness, damping : float
        I_DS [kg m²], k_f [N m/rad], c_f [N m s/rad].
    max_speed_rad_s : float
        Output bound (the command is clipped to [0, max]).
    max_accel_rad_s2 : float
        Rate limit of the command.
    torque_filter_s : float
        Time constant of the T_ref low-pass [s].
    torque_feedback : float
        g_T [rad/s per N m]: the virtual drive tracks ``ω_set - g_T (T_s - T_ref)``
        instead of ``ω_set`` (Z-Torque and the stability-tuned drive,
        :mod:`drill_twin.physics.top_drive`); 0 for Soft-Torque.
    """

    def __init__(self, inertia, stiffness, damping, max_speed_rad_s=40.0,
                 max_accel_rad_s2=20.0, torque_filter_s=20.0, torque_feedback=0.0):
        for name, v in (('inertia', inertia), ('stiffness', stiffness), ('damping', damping)):
            if not (math.isfinite(v) and v > 0):
                raise ParameterError(f'Soft-Torque {name} must be finite and > 0, got {v!r}')
        self.inertia, self.stiffness, self.damping = float(inertia), float(stiffness), \
            float(damping)
        self.max_speed = float(max_speed_rad_s)
        self.max_accel = float(max_accel_rad_s2)
        self.torque_filter_s = float(torque_filter_s)
        if not (math.isfinite(torque_feedback) and torque_feedback >= 0):
            raise ParameterError(f'torque feedback must be finite and >= 0, got '
                                 f'{torque_feedback!r}')
        self.torque_feedback = float(torque_feedback)
        self.enabled = True
        self.setpoint = None
        self.speed = None
        self.twist = 0.0
        self.torque_ref = None

    def reset(self, setpoint, speed=None, torque=None):
        """Start from the steady state at ``setpoint`` [rad/s]."""
        self.setpoint = float(setpoint)
        self.speed = float(setpoint if speed is None else speed)
        self.twist = 0.0
        self.torque_ref = torque

    def update(self, dt, setpoint, surface_torque):
        """Advance by ``dt`` [s] with the operator set-point and the measured surface
        torque [N m]; returns the speed command [rad/s]."""
        if not (dt > 0 and math.isfinite(dt)):
            raise ParameterError(f'controller step must be > 0, got {dt!r}')
        if self.speed is None:
            self.reset(setpoint, torque=surface_torque)
        self.setpoint = float(setpoint)
        if not self.enabled:
            self.speed, self.twist = self.setpoint, 0.0
            return self._bounded(self.setpoint, dt)
        if self.torque_ref is None:
            self.torque_ref = surface_torque
        a = min(1.0, dt / self.torque_filter_s)
        self.torque_ref += a * (surface_torque - self.torque_ref)
        swing = surface_torque - self.torque_ref
        reference = self.setpoint - self.torque_feedback * swing
        # semi-implicit Euler of the virtual drive (stable for dt < 2 sqrt(I/k))
        accel = (self.stiffness * self.twist + self.damping * (reference - self.speed)
                 - swing) / self.inertia
        target = self.speed + dt * accel
        self.speed = self._bounded(target, dt)
        self.twist += dt * (reference - self.speed)
        return self.speed

    def _bounded(self, target, dt):
        prev = self.speed if self.speed is not None else target
        step = self.max_accel * dt
        value = min(max(target, prev - step), prev + step)
        return min(max(value, 0.0), self.max_speed)
