"""The top drive: a motor with inertia behind a PI speed loop, and its controller modes.

Model (derivation in docs/control.md)
-------------------------------------
The motor (with its gearbox, reflected to the quill) is the top node of the torsional
chain, inertia ``J_m`` [kg m²].  The drive applies the motor torque

    T_m = sat( T_o + K_p e + K_i ϑ ),     e = ω_ref - ω̃_m,
    ω_ref = ω_set - g_T (T̃_s - T_ref),
    ϑ' = e + (sat(u) - u)/K_p,            T_ref' = (T̃_s - T_ref)/τ_f,

where ``ω̃_m`` and ``T̃_s`` are the motor speed and the string torque at the surface as the
sensors report them (delayed by ``τ_m``), ``sat`` clips to ±``T_max`` and the second term
of ``ϑ'`` is back-calculation anti-windup with tracking time ``K_p/K_i`` (the integral
stops growing while the torque is limited; the right-hand side stays Lipschitz, so RK4
keeps its order).  ``T_ref`` (slow low-pass of the surface torque) lets the torque
feedback act on torque *oscillations* only.  Without limit, delay and torque feedback the
PI loop is exactly the spring ``K_i`` and dash-pot ``K_p`` of thesis §3.2 between the
motor and the set-point angle.

Controller modes differ only in ``(K_p, K_i, g_T)``:

``stiff_pi``        a speed loop of bandwidth ω_c: ``K_p = 2 J_m ω_c, K_i = J_m ω_c²``
                    (critically damped on the motor inertia), ``g_T = 0``;
``soft_torque``     the §3.2 tuning on the motor inertia: ``K_i = J_m/t*²``,
                    ``K_p = 2 ξ sqrt(K_i J_m)``, ``ξ = sqrt(I/(2 J_m))``, ``g_T = 0``;
``z_torque``        the stiff loop with ``g_T = 1/Z``, ``Z = J_p sqrt(G ρ)`` the
                    characteristic torsional impedance of the pipe at the top (after Dwars
                    et al., SPE/IADC-173037, 2015): the drive answers a wave with the
                    torque a semi-infinite pipe would, so waves are not reflected;
``stability_tuned`` gains that minimise the closed-loop spectral abscissa of the
                    torsional roots (:mod:`drill_twin.control.tuning`).

Pure Python; the kernel reads the dimensionless numbers of :func:`kernel_drive`.
"""
from __future__ import annotations

import cmath
import math
from dataclasses import dataclass, replace

from ..errors import ParameterError
from .parameters import DrillStringSI, soft_torque_si

__all__ = ['CONTROLLERS', 'DriveGains', 'TopDrive', 'pipe_torsional_impedance',
           'mode_gains', 'drive_impedance', 'reflection_coefficient', 'kernel_drive']

CONTROLLERS = ('stiff_pi', 'soft_torque', 'z_torque', 'stability_tuned')


@dataclass(frozen=True)
class DriveGains:
    """Gains of the drive's controller (SI).

    Attributes
    ----------
    proportional_Nms_rad : float
        K_p [N m s/rad], > 0.
    integral_Nm_rad : float
        K_i [N m/rad], >= 0.
    torque_feedback_rad_s_Nm : float
        g_T [rad/s per N m], >= 0 (1/Z for Z-Torque).
    """

    proportional_Nms_rad: float
    integral_Nm_rad: float
    torque_feedback_rad_s_Nm: float = 0.0

    def __post_init__(self):
        for name in ('proportional_Nms_rad', 'integral_Nm_rad', 'torque_feedback_rad_s_Nm'):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ParameterError(f'drive gain {name} must be finite and >= 0, got {v!r}')
        if self.proportional_Nms_rad <= 0:
            raise ParameterError('drive gain proportional_Nms_rad must be > 0')


@dataclass(frozen=True)
class TopDrive:
    """A motor top drive and its controller (SI).

    Attributes
    ----------
    controller : str
        One of :data:`CONTROLLERS`.
    motor_inertia_kgm2 : float
        J_m, motor and gearbox reflected to the quill [kg m²].
    torque_limit_Nm : float
        T_max, motor torque limit [N m].
    speed_loop_bandwidth_rad_s : float
        ω_c of the stiff loop (``stiff_pi``, ``z_torque``) [rad/s].
    sensor_delay_s : float
        τ_m, delay of the speed and torque measurements [s].
    torque_filter_s : float
        τ_f, time constant of the torque reference T_ref [s].
    gains : DriveGains
        The controller's gains.
    """

    controller: str
    motor_inertia_kgm2: float
    torque_limit_Nm: float
    speed_loop_bandwidth_rad_s: float
    sensor_delay_s: float
    torque_filter_s: float
    gains: DriveGains

    def with_gains(self, gains: DriveGains) -> TopDrive:
        return replace(self, gains=gains)


def pipe_torsional_impedance(system: DrillStringSI) -> float:
    """Characteristic torsional impedance of the pipe at the top, ``Z = J sqrt(G ρ)``
    [N m s/rad]: a semi-infinite pipe answers a spin ω with the torque Z ω."""
    top = system.sections[0]
    return top.polar_m4 * math.sqrt(top.shear_modulus_Pa * top.density_kg_m3)


def mode_gains(controller: str, system: DrillStringSI, motor_inertia_kgm2: float,
               bandwidth_rad_s: float) -> DriveGains:
    """The gains of a controller mode (``stability_tuned`` starts from Soft-Torque's)."""
    J = motor_inertia_kgm2
    if controller in ('stiff_pi', 'z_torque'):
        g = 1.0 / pipe_torsional_impedance(system) if controller == 'z_torque' else 0.0
        return DriveGains(2.0 * J * bandwidth_rad_s, J * bandwidth_rad_s ** 2, g)
    if controller in ('soft_torque', 'stability_tuned'):
        st = soft_torque_si(system, J)
        return DriveGains(st['damping'], st['stiffness'], 0.0)
    raise ParameterError(f'drive controller must be one of {", ".join(CONTROLLERS)}, '
                         f'got {controller!r}')


def drive_impedance(s: complex, drive: TopDrive) -> complex:
    """The impedance the drive presents to the string, ``Z_d(s) = -T_s/ω_m`` (Laplace
    variable ``s`` in 1/s; torque limit inactive)::

        Z_d = (J s + C(s) e^{-s τ_m}) / (1 + g_T(s) C(s) e^{-s τ_m}),
        C(s) = K_p + K_i/s,   g_T(s) = g_T τ_f s/(1 + τ_f s).
    """
    g = drive.gains
    C = g.proportional_Nms_rad + g.integral_Nm_rad / s
    delay = cmath.exp(-s * drive.sensor_delay_s)
    tf = drive.torque_filter_s
    gT = g.torque_feedback_rad_s_Nm * (tf * s / (1.0 + tf * s) if tf > 0 else 1.0)
    return (drive.motor_inertia_kgm2 * s + C * delay) / (1.0 + gT * C * delay)


def reflection_coefficient(omega_rad_s: float, drive: TopDrive, impedance: float) -> complex:
    """Reflection coefficient of a torsional wave at the drive, ``r = (Z - Z_d)/(Z + Z_d)``
    at angular frequency ω [rad/s] (``|r|²`` is the reflected share of the energy)."""
    zd = drive_impedance(1j * omega_rad_s, drive)
    return (impedance - zd) / (impedance + zd)


def kernel_drive(drive: TopDrive | None, system: DrillStringSI | None) -> dict:
    """The kernel's dimensionless drive numbers (torque in C, time in t*, inertia in I)::

        kp = K_p/(C t*), ki = K_i/C, g_t = g_T C t*, t_max = T_max/C,
        t_filter = τ_f/t*, t_delay = τ_m/t*;   drive_pi = 1 for the motor drive.
    """
    if drive is None:
        return {'drive_pi': 0.0, 'kp': 0.0, 'ki': 0.0, 'g_t': 0.0, 't_max': 0.0,
                't_filter': 0.0, 't_delay': 0.0}
    s = system.scales()
    C, t = s.torque_Nm, s.time_s
    g = drive.gains
    return {'drive_pi': 1.0, 'kp': g.proportional_Nms_rad / (C * t),
            'ki': g.integral_Nm_rad / C, 'g_t': g.torque_feedback_rad_s_Nm * C * t,
            't_max': drive.torque_limit_Nm / C, 't_filter': drive.torque_filter_s / t,
            't_delay': drive.sensor_delay_s / t}
