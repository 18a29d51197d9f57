"""Actuators, stability augmentation and the pilot model.

With JSBSim's own flight control system switched off after the trim, these models close
the loop:

* :class:`Actuator`: first-order lag with rate and position limits, per surface;
* :class:`Pilot`: rate dampers (the flight control computer's SAS, always on) plus an
  attitude-holding outer loop. In ``"pilot"`` mode (sum-of-sines maneuvers) it holds
  straight and level flight like a human on a sidestick: altitude through pitch attitude,
  heading through bank, airspeed through the throttle, with a reaction delay. In
  ``"autopilot"`` mode (3211s and doublets, flown automatically) it is a weak attitude
  hold without delay and with the throttle fixed, so the aircraft's free response stays
  visible.

The control laws are written as angular-acceleration demands and inverted with the
aircraft's control power at the current dynamic pressure (gain scheduling), so one set of
bandwidths serves the whole envelope. They use the true state: the simulated pilot sees the
outside world, not the sensor noise.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import asdict, dataclass
from typing import NamedTuple

from simplexspline.errors import InputError

__all__ = ["Actuator", "AircraftState", "Airframe", "Pilot", "PilotStyle", "Turn"]

_G0 = 9.80665


class Actuator:
    """First-order actuator with rate and position limits (discrete, exact lag).

    Parameters
    ----------
    position : float
        Initial deflection [rad].
    limit : float
        Symmetric position limit [rad].
    rate : float
        Rate limit [rad/s].
    tau : float
        Time constant [s].
    dt : float
        Step [s].
    """

    __slots__ = ("x", "limit", "max_step", "alpha")

    def __init__(self, position: float, limit: float, rate: float, tau: float, dt: float):
        self.x = float(position)
        self.limit = float(limit)
        self.max_step = float(rate) * dt
        self.alpha = 1.0 - math.exp(-dt / tau) if tau > 0 else 1.0

    def step(self, command: float) -> float:
        """Advance one step towards ``command``; return the new deflection [rad]."""
        lim = self.limit
        if command > lim:
            command = lim
        elif command < -lim:
            command = -lim
        d = self.alpha * (command - self.x)
        m = self.max_step
        if d > m:
            d = m
        elif d < -m:
            d = -m
        self.x += d
        return self.x


class AircraftState(NamedTuple):
    """The true aircraft state the pilot and the flight control computer read (SI, rad)."""

    theta: float  #: pitch attitude [rad]
    phi: float    #: bank angle [rad]
    psi: float    #: heading [rad]
    p: float      #: roll rate [rad/s]
    q: float      #: pitch rate [rad/s]
    r: float      #: yaw rate [rad/s]
    h: float      #: altitude [m]
    tas: float    #: true airspeed [m/s]
    vd: float     #: down velocity [m/s] (minus the climb rate)
    qbar: float   #: dynamic pressure [Pa]
    ixx: float    #: roll inertia [kg m^2]
    iyy: float    #: pitch inertia [kg m^2]
    izz: float    #: yaw inertia [kg m^2]
    alpha: float  #: angle of attack [rad]
    nz: float     #: load factor [g]


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


class Airframe(NamedTuple):
    """What the control laws know of the aircraft (from its profile and the FDM).

    Attributes
    ----------
    bandwidth : (float, float)
        Pitch and roll attitude-loop natural frequencies [rad/s] of the pilot.
    damping : (float, float, float)
        Pitch, roll and yaw rate-damper gains [1/s].
    control_power : (float, float, float)
        dCm/dde, dCl/dda, dCn/ddr [1/rad].
    geometry : (float, float, float)
        S [m^2], b [m], cbar [m].
    """

    bandwidth: tuple
    damping: tuple
    control_power: tuple
    geometry: tuple

    @classmethod
    def of(cls, profile, geometry: tuple) -> Airframe:
        """From an :class:`~simplexspline.sim.aircraft.AircraftProfile` and (S, b, cbar)."""
        return cls(tuple(profile.pilot_bandwidth), tuple(profile.sas_damping),
                   tuple(profile.control_power), tuple(geometry))


@dataclass(frozen=True)
class PilotStyle:
    """How the pilot model flies: the protocol's choice, not the aircraft's.

    The defaults are the pilot every campaign was developed with; :meth:`relaxed` is a
    different pilot (lower bandwidth, longer delay, looser altitude and heading holds) to
    judge identification on data it was not developed on.

    Parameters
    ----------
    delay_s : float
        Reaction delay of the human pilot's attitude loop [s] (pilot mode only).
    bandwidth_scale : float
        Factor on the profile's attitude-loop bandwidths in pilot mode [-].
    autopilot_scale : float
        Factor on the profile's attitude-loop bandwidths in autopilot mode [-].
    altitude_gain : float
        Climb-rate demand per metre of altitude error [1/s] (pilot mode).
    heading_gain : float
        Bank demand per radian of heading error [-] (pilot mode).
    """

    delay_s: float = 0.2
    bandwidth_scale: float = 1.0
    autopilot_scale: float = 0.4
    altitude_gain: float = 0.12
    heading_gain: float = 1.2

    def __post_init__(self):
        for name in ("delay_s", "bandwidth_scale", "autopilot_scale", "altitude_gain",
                     "heading_gain"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and 0 <= v <= 60):
                raise InputError(f"PilotStyle.{name} must be a number in [0, 60], got {v!r}")

    @classmethod
    def relaxed(cls) -> PilotStyle:
        """A slower, later pilot with looser holds than the default one."""
        return cls(delay_s=0.35, bandwidth_scale=0.7, autopilot_scale=0.25,
                   altitude_gain=0.06, heading_gain=0.8)

    def to_dict(self) -> dict:
        """Plain-data form (for metadata and worker processes)."""
        return asdict(self)


class Turn(NamedTuple):
    """A level turn the pilot rolls into (pilot mode)."""

    bank: float = 0.0     #: bank angle held instead of the heading [rad]; 0 holds heading
    start_s: float = 0.0  #: time at which the pilot starts rolling in [s]


class Pilot:
    """SAS plus attitude/altitude/heading/speed hold, in angular-acceleration form.

    Parameters
    ----------
    mode : {'pilot', 'autopilot'}
    trim : dict
        Trim point: ``theta``, ``phi``, ``psi`` [rad], ``h`` [m], ``tas`` [m/s], surface positions
        ``de``, ``da``, ``dr`` [rad], ``throttle`` [-].
    airframe : Airframe
        Bandwidths, damper gains, control power and geometry.
    style : PilotStyle, optional
        Delay, bandwidth factors and hold gains (default ``PilotStyle()``).
    turn : Turn, optional
        Level turn to fly instead of holding the heading (pilot mode; rolled in over
        :attr:`ROLL_IN_S` from ``turn.start_s``).
    protection : dict, optional
        Soft envelope protection of the flight control computer: ``nz`` (low, high) [-],
        ``alpha`` (low, high) [rad] and ``phi`` (largest bank) [rad] beyond which the SAS
        adds a restoring angular-acceleration demand (like a g/alpha limiter).
    dt : float
        Step [s].
    """

    K_NZ = 1.5  #: pitch acceleration per g beyond the load-factor protection [rad/s^2]
    K_ALPHA = 25.0  #: pitch acceleration per rad beyond the alpha protection [rad/s^2 / rad]
    K_PHI = 6.0  #: roll acceleration per rad beyond the bank protection [rad/s^2 / rad]
    ROLL_IN_S = 6.0  #: time to roll into a turn [s]

    def __init__(self, mode: str, trim: dict, airframe: Airframe, *,
                 style: PilotStyle | None = None, turn: Turn = Turn(),
                 protection: dict | None = None, dt: float = 0.01):
        style = PilotStyle() if style is None else style
        self.human = mode == "pilot"
        factor = style.bandwidth_scale if self.human else style.autopilot_scale
        bandwidth = airframe.bandwidth
        self.w2_theta = (factor * bandwidth[0]) ** 2
        self.w2_phi = (factor * bandwidth[1]) ** 2
        self.kq, self.kp, self.kr = airframe.damping
        self.k_h, self.k_psi = style.altitude_gain, style.heading_gain
        S, b, c = airframe.geometry
        control_power = airframe.control_power
        # deflection per angular acceleration and per (qbar / Pa) and inertia / kg m^2
        self.g_de = 1.0 / (S * c * control_power[0])
        self.g_da = 1.0 / (S * b * control_power[1])
        self.g_dr = 1.0 / (S * b * control_power[2])
        self.dt = dt
        self.trim = dict(trim)
        self.theta0, self.phi0 = trim["theta"], trim["phi"]
        self.de0, self.da0, self.dr0 = trim["de"], trim["da"], trim["dr"]
        self.thr0 = trim["throttle"]
        self.h_ref = trim["h"]
        self.psi_ref = trim["psi"]
        self.v_ref = trim["tas"]
        prot = protection or {}
        self.nz_lo, self.nz_hi = prot.get("nz", (-math.inf, math.inf))
        self.alpha_lo, self.alpha_hi = prot.get("alpha", (-math.inf, math.inf))
        self.phi_lim = prot.get("phi", math.inf)
        self.bank = float(turn.bank) if self.human else 0.0
        self.k = -int(round(turn.start_s / dt))
        self.int_theta = 0.0
        self.int_v = 0.0
        n_delay = int(round(style.delay_s / dt)) if self.human else 0
        # after an append, buffer[0] is the demand computed n_delay steps earlier
        self.buffer = (deque([(0.0, 0.0)] * (n_delay + 1), maxlen=n_delay + 1)
                       if n_delay else None)

    def hold(self, *, h: float | None = None, tas: float | None = None,
             psi: float | None = None, theta: float | None = None,
             resume: bool = False) -> None:
        """Change what the pilot holds (pilot mode): altitude [m], airspeed [m/s], heading
        [rad], the pitch attitude of level flight [rad]; ``None`` keeps the current one.

        A whole flight changes its flight condition by moving these references a little
        at a time (a climb, an acceleration; the pitch attitude of level flight changes with
        the airspeed). ``resume`` also forgets the delayed demands of before (the pilot
        takes over again after an automatic maneuver); the integrators, which hold the
        trim, are kept.
        """
        if theta is not None:
            self.theta0 = float(theta)
        if h is not None:
            self.h_ref = float(h)
        if tas is not None:
            self.v_ref = float(tas)
        if psi is not None:
            self.psi_ref = float(psi)
        if resume and self.buffer is not None:
            self.buffer.extend([(0.0, 0.0)] * self.buffer.maxlen)

    def command(self, state: AircraftState) -> tuple[float, float, float, float | None]:
        """Surface commands (de, da, dr) [rad] and throttle for the current true state.

        Parameters
        ----------
        state : AircraftState

        Returns
        -------
        (float, float, float, float or None)
            ``(de, da, dr, throttle)``; throttle is None in autopilot mode (hold).
        """
        theta, phi, psi, p, q, r, h, tas, vd, qbar, ixx, iyy, izz, alpha, nz = state
        if tas < 1.0:
            tas = 1.0
        # --- outer loops: desired attitude --------------------------------------------
        if self.human:
            hdot_cmd = self.k_h * (self.h_ref - h)
            hdot_cmd = -8.0 if hdot_cmd < -8.0 else (8.0 if hdot_cmd > 8.0 else hdot_cmd)
            theta_ref = self.theta0 + (hdot_cmd + vd) / tas  # vd = -hdot
            if self.bank:
                self.k += 1
                x = self.k * self.dt / self.ROLL_IN_S
                phi_ref = self.phi0 + self.bank * (0.0 if x < 0.0 else (1.0 if x > 1.0 else x))
            else:
                x = self.k_psi * _wrap(self.psi_ref - psi)
                phi_ref = self.phi0 + (-0.35 if x < -0.35 else (0.35 if x > 0.35 else x))
        else:
            theta_ref = self.theta0
            phi_ref = self.phi0
        e_theta = theta_ref - theta
        self.int_theta += e_theta * self.dt
        pitch_att = self.w2_theta * (e_theta + 0.25 * self.int_theta)
        roll_att = self.w2_phi * _wrap(phi_ref - phi)
        if self.buffer is not None:
            self.buffer.append((pitch_att, roll_att))
            pitch_att, roll_att = self.buffer[0]
        # --- inner loops: rate damping (SAS), no delay ---------------------------------
        sphi = math.sin(phi)
        turn = _G0 * math.cos(theta) / tas  # turn rate per tan(phi)
        cphi = math.cos(phi)
        q_coord = turn * sphi * sphi / (cphi if cphi > 0.17 else 0.17)
        qdot = pitch_att - self.kq * (q - q_coord)
        pdot = roll_att - self.kp * p
        rdot = -self.kr * (r - turn * sphi)
        # --- envelope protection (FCS), no delay ---------------------------------------
        if nz > self.nz_hi:
            qdot -= self.K_NZ * (nz - self.nz_hi)
        elif nz < self.nz_lo:
            qdot += self.K_NZ * (self.nz_lo - nz)
        if alpha > self.alpha_hi:
            qdot -= self.K_ALPHA * (alpha - self.alpha_hi)
        elif alpha < self.alpha_lo:
            qdot += self.K_ALPHA * (self.alpha_lo - alpha)
        if phi > self.phi_lim:
            pdot -= self.K_PHI * (phi - self.phi_lim)
        elif phi < -self.phi_lim:
            pdot -= self.K_PHI * (phi + self.phi_lim)
        inv_q = 1.0 / (qbar if qbar > 1.0 else 1.0)
        de = self.de0 + iyy * qdot * inv_q * self.g_de
        da = self.da0 + ixx * pdot * inv_q * self.g_da
        dr = self.dr0 + izz * rdot * inv_q * self.g_dr
        thr = None
        if self.human:
            e_v = self.v_ref - tas
            self.int_v += e_v * self.dt
            thr = self.thr0 + 0.03 * e_v + 0.006 * self.int_v
            thr = 0.0 if thr < 0.0 else (1.0 if thr > 1.0 else thr)
        return de, da, dr, thr
