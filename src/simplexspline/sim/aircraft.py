"""Aircraft profiles: how the simulator drives one JSBSim model, and its sane envelope.

A profile is plain data (numbers, strings, tuples): it travels to worker processes as a
dictionary (:meth:`AircraftProfile.to_dict`) and is rebuilt there, so nothing is pickled
but builtins. The bundled profiles are ``f16`` (a fly-by-wire fighter with strongly
nonlinear tables), ``global5000`` (a twin-jet business aircraft), ``c172p`` (a light
single-piston aircraft, slow, with propeller slipstream), ``A4`` (a subsonic light attack
jet), ``737`` (a twin-jet transport, added after the identification's defaults were
settled, to judge them on an aircraft they were not developed on) and ``T37`` (a
straight-wing twin-jet trainer with alpha-dot terms in lift and pitch, the class of a light
business jet, added at stop 58 for the same purpose); :func:`get_aircraft` returns one,
:func:`register_aircraft` adds your own.

Sign conventions (JSBSim's, measured on all six bundled models):

* ``de`` > 0: elevator trailing edge down, nose-down pitching moment (dCm/dde < 0);
* ``da`` > 0: positive (right-wing-down) rolling moment (dCl/dda > 0);
* ``dr`` > 0: trailing edge left, nose-left yawing moment (dCn/ddr < 0).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace

from simplexspline.aero.variables import DEG
from simplexspline.errors import InputError

__all__ = [
    "Envelope",
    "Surface",
    "AircraftProfile",
    "get_aircraft",
    "register_aircraft",
    "available_aircraft",
    "SURFACE_SIGN_CONVENTIONS",
]


SURFACE_SIGN_CONVENTIONS = {
    "de": "positive trailing edge down; gives a nose-down pitching moment (dCm/dde < 0)",
    "da": "positive gives a right-wing-down rolling moment (dCl/dda > 0)",
    "dr": "positive trailing edge left; gives a nose-left yawing moment (dCn/ddr < 0)",
}


@dataclass(frozen=True)
class Envelope:
    """Limits a kept sample must satisfy (true values, SI units, radians).

    A maneuver is cut at the first sample outside these limits; the samples before it are
    kept and the maneuver is marked ``cut`` in the campaign log.

    Attributes
    ----------
    alpha_min, alpha_max : float
        Angle-of-attack limits [rad].
    beta_max : float
        Largest sideslip magnitude [rad].
    phi_max, theta_max : float
        Largest bank and pitch-attitude magnitudes [rad].
    nz_min, nz_max : float
        Load-factor limits, nz = -az / g0 (+1 in level flight) [-].
    mach_max : float
        Largest Mach number [-].
    h_min : float
        Lowest pressure altitude [m].
    """

    alpha_min: float
    alpha_max: float
    beta_max: float
    phi_max: float
    theta_max: float
    nz_min: float
    nz_max: float
    mach_max: float
    h_min: float = 300.0

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> Envelope:
        return cls(**d)


@dataclass(frozen=True)
class Surface:
    """One control-surface channel: JSBSim properties and the actuator model.

    Attributes
    ----------
    limit : float
        Deflection limit, symmetric [rad].
    rate : float
        Actuator rate limit [rad/s].
    tau : float
        Actuator first-order time constant [s].
    writes : tuple of (str, float)
        JSBSim properties set to ``gain * deflection`` each step (FCS disabled): the ones
        the aerodynamic model reads. The first one is read back as the deflection.
    """

    limit: float
    rate: float
    tau: float
    writes: tuple


@dataclass(frozen=True)
class AircraftProfile:
    """Everything the simulator needs to know about one JSBSim aircraft.

    Attributes
    ----------
    name : str
        Profile name (the ``aircraft`` metadata value).
    model : str
        JSBSim model name (``FGFDMExec.load_model``).
    elevator, aileron, rudder : Surface
        Control-surface channels.
    throttles : tuple of str
        Throttle position properties (one per engine).
    tanks : tuple of str
        Fuel tank contents properties [lbs] scaled by the fuel fraction before the trim.
    control_power : tuple of float
        Approximate (dCm/dde, dCl/dda, dCn/ddr) [1/rad], measured on the model; used only
        to schedule the pilot and the excitation amplitudes with dynamic pressure.
    altitudes_m, airspeeds_mps : tuple of float
        Default flight-condition grid (geometric altitude, true airspeed).
    envelope : Envelope
        Limits of kept data.
    pulse_unit_s : tuple of float
        (min, max) 3211/doublet pulse unit [s].
    pulse_accel : tuple of tuple of float
        (min, max) angular-acceleration amplitude of a pulse per axis (pitch, roll, yaw)
        [rad/s^2]; converted to a deflection with the control power and dynamic pressure.
    pulse_qbar_ref : float
        Above this dynamic pressure [Pa] the elevator pulse amplitude is reduced by
        ``pulse_qbar_ref / qbar`` (the load-factor response grows with dynamic pressure).
    sos_accel_rms : tuple of float
        RMS angular acceleration of the sum-of-sines input per axis [rad/s^2].
    sos_band_hz : tuple of float
        (low, high) frequency band of the sum-of-sines components [Hz].
    sos_bank : float
        Largest bank angle of a sum-of-sines maneuver flown in a level turn [rad]; half of
        those maneuvers are flown turning at a random bank up to this value (load factor
        and angle of attack above 1 g), the others wings level.
    pilot_bandwidth : tuple of float
        Natural frequency of the pilot's (pitch, roll) attitude loop [rad/s].
    sas_damping : tuple of float
        Rate-damper angular-acceleration gains (pitch, roll, yaw) [1/s].
    fuel_fraction : tuple of float
        (min, max) fraction of the model's initial fuel per maneuver (mass variation).
    schedules : tuple
        Surfaces scheduled by the simulated FCS, each ``(property, default, rules)`` with
        rules ``((variable, threshold, value), ...)``: the first rule whose ``variable``
        ('alpha' [rad] or 'mach') exceeds ``threshold`` sets ``value``.
    flap_property : str or None
        Property recorded in the ``flap`` column [rad], or None.
    flap_scale : float
        Factor converting ``flap_property`` to radians.
    loading : tuple of (str, float)
        JSBSim properties set when the model is loaded, before the trim (payload, point-mass
        positions). The paper's Eq. 46-48 assume a symmetric aircraft (Ixy = Iyz = 0): put
        off-centre point masses on the centreline here.
    """

    name: str
    model: str
    elevator: Surface
    aileron: Surface
    rudder: Surface
    throttles: tuple
    tanks: tuple
    control_power: tuple
    altitudes_m: tuple
    airspeeds_mps: tuple
    envelope: Envelope
    pulse_unit_s: tuple
    pulse_accel: tuple
    pulse_qbar_ref: float
    sos_accel_rms: tuple
    sos_band_hz: tuple
    sos_bank: float
    pilot_bandwidth: tuple
    sas_damping: tuple
    fuel_fraction: tuple = (0.4, 1.0)
    schedules: tuple = ()
    flap_property: str | None = None
    flap_scale: float = 1.0
    loading: tuple = ()
    notes: str = field(default="", compare=False)

    @property
    def surfaces(self) -> tuple:
        """(elevator, aileron, rudder)."""
        return (self.elevator, self.aileron, self.rudder)

    def to_dict(self) -> dict:
        """Plain-data form (JSON-compatible after tuple -> list)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> AircraftProfile:
        d = dict(d)
        for key in ("elevator", "aileron", "rudder"):
            s = dict(d[key])
            s["writes"] = tuple(tuple(w) for w in s["writes"])
            d[key] = Surface(**s)
        d["envelope"] = Envelope.from_dict(d["envelope"])
        d["schedules"] = tuple(
            (p, float(dflt), tuple(tuple(r) for r in rules)) for p, dflt, rules in d["schedules"]
        )
        for key in ("throttles", "tanks", "control_power", "altitudes_m", "airspeeds_mps",
                    "pulse_unit_s", "sos_accel_rms", "sos_band_hz", "pilot_bandwidth",
                    "sas_damping", "fuel_fraction"):
            d[key] = tuple(d[key])
        d["pulse_accel"] = tuple(tuple(a) for a in d["pulse_accel"])
        d["loading"] = tuple((str(p), float(v)) for p, v in d.get("loading", ()))
        return cls(**d)

    def replace(self, **changes) -> AircraftProfile:
        """A copy with some fields changed (e.g. a tighter envelope)."""
        return replace(self, **changes)


_F16 = AircraftProfile(
    name="f16",
    model="f16",
    # Actuators after Stevens & Lewis' F-16 model: 20.2 rad/s lag, 60/80/120 deg/s.
    # only the properties the f16's aerodynamics read (the FCS that would derive the
    # others is off)
    elevator=Surface(0.436, 60 * DEG, 1 / 20.2, (("fcs/elevator-pos-rad", 1.0),)),
    aileron=Surface(0.375, 80 * DEG, 1 / 20.2, (("fcs/aileron-pos-rad", 1.0),)),
    rudder=Surface(0.524, 120 * DEG, 1 / 20.2, (("fcs/rudder-pos-rad", 1.0),)),
    throttles=("fcs/throttle-pos-norm",),
    tanks=("propulsion/tank/contents-lbs", "propulsion/tank[1]/contents-lbs"),
    control_power=(-0.53, 0.050, -0.046),
    altitudes_m=(1500.0, 3000.0, 4500.0, 6000.0, 7500.0, 9000.0, 10500.0),
    airspeeds_mps=(110.0, 140.0, 170.0, 200.0, 230.0, 260.0),
    envelope=Envelope(alpha_min=-10 * DEG, alpha_max=25 * DEG, beta_max=10 * DEG,
                      phi_max=75 * DEG, theta_max=60 * DEG, nz_min=-2.0, nz_max=7.0,
                      mach_max=0.95, h_min=300.0),
    pulse_unit_s=(0.25, 0.6),
    pulse_accel=((0.5, 1.3), (1.5, 4.0), (0.3, 0.9)),
    pulse_qbar_ref=9000.0,
    sos_accel_rms=(0.35, 1.0, 0.2),
    sos_band_hz=(0.1, 2.0),
    sos_bank=60 * DEG,
    pilot_bandwidth=(2.0, 2.5),
    sas_damping=(3.0, 3.0, 1.5),
    schedules=(("fcs/lef-pos-rad", 0.0,
                (("alpha", 0.2618, 0.436), ("alpha", 0.0873, 0.262), ("mach", 0.9, -0.0349))),),
    flap_property="fcs/lef-pos-rad",
    notes="leading-edge flap (flap column) scheduled on alpha and Mach as in JSBSim's f16 FCS",
)

_GLOBAL5000 = AircraftProfile(
    name="global5000",
    model="global5000",
    # the aerodynamics read the left aileron only, and the drag |elevator-pos-norm|
    elevator=Surface(0.35, 40 * DEG, 0.08,
                     (("fcs/elevator-pos-rad", 1.0), ("fcs/elevator-pos-norm", 1 / 0.35))),
    aileron=Surface(0.35, 40 * DEG, 0.08, (("fcs/left-aileron-pos-rad", 1.0),)),
    rudder=Surface(0.35, 40 * DEG, 0.08, (("fcs/rudder-pos-rad", 1.0),)),
    throttles=("fcs/throttle-pos-norm", "fcs/throttle-pos-norm[1]"),
    tanks=("propulsion/tank/contents-lbs", "propulsion/tank[1]/contents-lbs",
           "propulsion/tank[2]/contents-lbs"),
    control_power=(-0.90, 0.100, -0.100),
    altitudes_m=(1500.0, 3000.0, 4500.0, 6000.0, 7500.0, 9000.0, 10500.0, 12000.0),
    airspeeds_mps=(120.0, 145.0, 170.0, 195.0, 220.0, 245.0),
    envelope=Envelope(alpha_min=-5 * DEG, alpha_max=12 * DEG, beta_max=8 * DEG,
                      phi_max=45 * DEG, theta_max=30 * DEG, nz_min=-0.5, nz_max=2.5,
                      mach_max=0.89, h_min=300.0),
    pulse_unit_s=(0.5, 1.2),
    pulse_accel=((0.15, 0.45), (0.3, 0.9), (0.08, 0.25)),
    pulse_qbar_ref=20000.0,
    sos_accel_rms=(0.15, 0.4, 0.08),
    sos_band_hz=(0.05, 1.5),
    sos_bank=30 * DEG,
    pilot_bandwidth=(1.5, 1.5),
    sas_damping=(2.0, 2.0, 1.0),
    flap_property="fcs/flap-pos-deg",
    flap_scale=math.pi / 180.0,
)

_C172P = AircraftProfile(
    name="c172p",
    model="c172p",
    # a light single-piston aircraft with cable-driven controls; the aerodynamics read the
    # left aileron only, the elevator magnitude (fcs/mag-elevator-pos-rad, which JSBSim
    # derives from fcs/elevator-pos-rad itself) and the propeller slipstream
    elevator=Surface(0.35, 80 * DEG, 0.05, (("fcs/elevator-pos-rad", 1.0),)),
    aileron=Surface(0.30, 80 * DEG, 0.05, (("fcs/left-aileron-pos-rad", 1.0),)),
    rudder=Surface(0.28, 80 * DEG, 0.05, (("fcs/rudder-pos-rad", 1.0),)),
    throttles=("fcs/throttle-pos-norm",),
    tanks=("propulsion/tank/contents-lbs", "propulsion/tank[1]/contents-lbs"),
    # measured with JSBSim 1.3.3 at 500-2500 m, 40-55 m/s
    control_power=(-1.40, 0.229, -0.055),
    altitudes_m=(500.0, 1000.0, 1500.0, 2000.0, 2500.0),
    airspeeds_mps=(38.0, 44.0, 50.0, 56.0, 62.0),
    # alpha_max stays below the stall hysteresis (0.36 rad) and the model's alpha limit
    envelope=Envelope(alpha_min=-5 * DEG, alpha_max=14 * DEG, beta_max=10 * DEG,
                      phi_max=45 * DEG, theta_max=25 * DEG, nz_min=-0.5, nz_max=3.0,
                      mach_max=0.25, h_min=100.0),
    pulse_unit_s=(0.4, 0.9),
    pulse_accel=((0.7, 2.0), (0.8, 2.4), (0.12, 0.4)),
    pulse_qbar_ref=1500.0,
    sos_accel_rms=(0.3, 0.8, 0.12),
    sos_band_hz=(0.08, 1.8),
    sos_bank=30 * DEG,
    pilot_bandwidth=(1.5, 2.0),
    sas_damping=(2.0, 2.0, 1.0),
    flap_property="fcs/flap-pos-deg",
    flap_scale=math.pi / 180.0,
    # the model seats its 180 lbs pilot 14 in left of the centreline (Ixy, Iyz != 0, which
    # the schema's inertia columns cannot carry): seated on the centreline instead
    loading=tuple((f"inertia/pointmass-location-Y-inches[{i}]", 0.0) for i in range(4)),
    notes="flaps up (flap column zero); propeller slipstream acts on the aerodynamics; "
          "pilot seated on the centreline",
)

_A4 = AircraftProfile(
    name="A4",
    model="A4",
    # a subsonic light attack jet with hydraulic controls and no fly-by-wire; the
    # aerodynamics read the left aileron only
    elevator=Surface(0.35, 50 * DEG, 0.06, (("fcs/elevator-pos-rad", 1.0),)),
    aileron=Surface(0.30, 60 * DEG, 0.06, (("fcs/left-aileron-pos-rad", 1.0),)),
    rudder=Surface(0.30, 60 * DEG, 0.06, (("fcs/rudder-pos-rad", 1.0),)),
    throttles=("fcs/throttle-pos-norm",),
    tanks=("propulsion/tank/contents-lbs",),
    # measured with JSBSim 1.3.3 at 1500-7500 m, 120-240 m/s (dCm/dde falls with Mach)
    control_power=(-0.42, 0.090, -0.100),
    altitudes_m=(1500.0, 3000.0, 4500.0, 6000.0, 7500.0, 9000.0, 10500.0),
    airspeeds_mps=(130.0, 160.0, 190.0, 220.0, 250.0),
    envelope=Envelope(alpha_min=-6 * DEG, alpha_max=20 * DEG, beta_max=8 * DEG,
                      phi_max=60 * DEG, theta_max=45 * DEG, nz_min=-1.5, nz_max=5.5,
                      mach_max=0.85, h_min=300.0),
    pulse_unit_s=(0.3, 0.8),
    pulse_accel=((0.3, 0.9), (1.0, 3.0), (0.15, 0.5)),
    pulse_qbar_ref=12000.0,
    sos_accel_rms=(0.25, 0.7, 0.12),
    sos_band_hz=(0.08, 2.0),
    sos_bank=45 * DEG,
    pilot_bandwidth=(1.8, 2.2),
    sas_damping=(2.5, 2.5, 1.2),
    flap_property="fcs/flap-pos-deg",
    flap_scale=math.pi / 180.0,
    notes="flaps up (flap column zero); speed brake retracted",
)

_B737 = AircraftProfile(
    name="737",
    model="737",
    # a twin-jet transport with conventional controls; the aerodynamics read the left
    # aileron only. Flaps, spoilers and speed brake stay retracted.
    elevator=Surface(0.35, 40 * DEG, 0.08, (("fcs/elevator-pos-rad", 1.0),)),
    aileron=Surface(0.35, 40 * DEG, 0.08, (("fcs/left-aileron-pos-rad", 1.0),)),
    rudder=Surface(0.35, 40 * DEG, 0.08, (("fcs/rudder-pos-rad", 1.0),)),
    throttles=("fcs/throttle-pos-norm", "fcs/throttle-pos-norm[1]"),
    tanks=("propulsion/tank/contents-lbs", "propulsion/tank[1]/contents-lbs",
           "propulsion/tank[2]/contents-lbs"),
    # the model's tables at Mach 0.6 (JSBSim 1.3.3): Cmde, Clda, Cndr
    control_power=(-0.93, 0.080, -0.200),
    # every point trims at full fuel; 6000 m and above at 130 m/s, or 9000 m at 155 m/s,
    # do not (the lift needed is beyond the lift table's maximum, 1.2)
    altitudes_m=(1500.0, 3000.0, 4500.0, 6000.0, 7500.0, 9000.0),
    airspeeds_mps=(165.0, 185.0, 205.0, 225.0, 245.0),
    envelope=Envelope(alpha_min=-5 * DEG, alpha_max=12 * DEG, beta_max=8 * DEG,
                      phi_max=45 * DEG, theta_max=30 * DEG, nz_min=-0.5, nz_max=2.5,
                      mach_max=0.85, h_min=300.0),
    pulse_unit_s=(0.5, 1.2),
    pulse_accel=((0.15, 0.45), (0.3, 0.9), (0.08, 0.25)),
    pulse_qbar_ref=20000.0,
    sos_accel_rms=(0.15, 0.4, 0.08),
    sos_band_hz=(0.05, 1.5),
    sos_bank=30 * DEG,
    pilot_bandwidth=(1.5, 1.5),
    sas_damping=(2.0, 2.0, 1.0),
    flap_property="fcs/flap-pos-deg",
    flap_scale=math.pi / 180.0,
    notes="flaps, spoilers and speed brake retracted; yaw damper off (the FCS is off)",
)

_T37 = AircraftProfile(
    name="T37",
    model="T37",
    # a straight-wing twin-jet trainer with manual controls and a linear, Roskam-derived
    # database that includes alpha-dot lift and pitching moment (the class of a light
    # business jet); the aerodynamics read the left aileron only and the elevator
    # magnitude (fcs/mag-elevator-pos-rad, derived by JSBSim from fcs/elevator-pos-rad)
    elevator=Surface(0.35, 60 * DEG, 0.06, (("fcs/elevator-pos-rad", 1.0),)),
    aileron=Surface(0.35, 60 * DEG, 0.06, (("fcs/left-aileron-pos-rad", 1.0),)),
    rudder=Surface(0.35, 60 * DEG, 0.06, (("fcs/rudder-pos-rad", 1.0),)),
    throttles=("fcs/throttle-pos-norm", "fcs/throttle-pos-norm[1]"),
    tanks=("propulsion/tank/contents-lbs", "propulsion/tank[1]/contents-lbs"),
    # the model's values at Mach 0.35 (JSBSim 1.3.3): Cmde, Clda, Cndr
    control_power=(-0.96, 0.156, -0.037),
    altitudes_m=(1500.0, 3000.0, 4500.0, 6000.0),
    airspeeds_mps=(95.0, 110.0, 125.0, 140.0),
    # the lift table is linear up to 0.26 rad and stalls beyond
    envelope=Envelope(alpha_min=-5 * DEG, alpha_max=13 * DEG, beta_max=8 * DEG,
                      phi_max=60 * DEG, theta_max=35 * DEG, nz_min=-0.5, nz_max=3.5,
                      mach_max=0.6, h_min=300.0),
    pulse_unit_s=(0.4, 1.0),
    pulse_accel=((0.25, 0.7), (0.6, 1.8), (0.1, 0.3)),
    pulse_qbar_ref=8000.0,
    sos_accel_rms=(0.2, 0.5, 0.1),
    sos_band_hz=(0.06, 1.6),
    sos_bank=40 * DEG,
    pilot_bandwidth=(1.6, 1.8),
    sas_damping=(2.0, 2.0, 1.0),
    flap_property="fcs/flap-pos-deg",
    flap_scale=math.pi / 180.0,
    notes="flaps, gear and speed brake retracted; alpha-dot terms in lift and pitch",
)

_REGISTRY: dict[str, AircraftProfile] = {"f16": _F16, "global5000": _GLOBAL5000,
                                         "c172p": _C172P, "A4": _A4, "737": _B737,
                                         "T37": _T37}


def available_aircraft() -> list[str]:
    """Names of the registered aircraft profiles."""
    return sorted(_REGISTRY)


def get_aircraft(aircraft: str | AircraftProfile) -> AircraftProfile:
    """Return the profile for ``aircraft`` (a name or a profile, returned unchanged)."""
    if isinstance(aircraft, AircraftProfile):
        return aircraft
    try:
        return _REGISTRY[str(aircraft)]
    except KeyError:
        raise InputError(
            f"unknown aircraft {aircraft!r}: choose one of {available_aircraft()} "
            "or register a profile with simplexspline.sim.register_aircraft"
        ) from None


def register_aircraft(profile: AircraftProfile) -> None:
    """Register a profile under ``profile.name`` (replacing one of the same name)."""
    if not isinstance(profile, AircraftProfile):
        raise InputError("register_aircraft expects an AircraftProfile")
    _REGISTRY[profile.name] = profile
