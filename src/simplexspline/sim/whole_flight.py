"""One continuous flight: maneuvers flown one after another, as a real flight-test sortie.

A :class:`Campaign` trims every maneuver afresh; a real flight test is one sortie: the
aircraft flies from one test point to the next, climbs and accelerates between them, turns,
and flies its 3211s, doublets and sums of sines from steady flight, with one set of sensors
(the same biases all flight), one air mass (a steady wind and turbulence) and fuel burnt all
along. :class:`WholeFlight` simulates that on one JSBSim model: a list of **legs** (flight
conditions visited in order), maneuvers spread over them, and between them steady flight
(the pilot model holding altitude, heading and airspeed), occasional turns to a new heading
and pilot-flown climbs, descents and speed changes. The result is one table (maneuver 0,
100 Hz) and the list of what was flown when (``df.attrs["flight"]["segments"]``, the
maneuver log a flight-test engineer writes); :func:`~simplexspline.sim.record_export
.write_channel_record` turns it into a real-format record.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from importlib.metadata import version

import numpy as np

from simplexspline._version import __version__
from simplexspline.aero.data.flight_data import FLIGHT_DATA_COLUMNS, SCHEMA_VERSION
from simplexspline.errors import InputError, SimulationError
from simplexspline.sim import units as u
from simplexspline.sim.aircraft import SURFACE_SIGN_CONVENTIONS, AircraftProfile, get_aircraft
from simplexspline.sim.campaign import FlightProtocol, isa_speed_of_sound, split_counts
from simplexspline.sim.fdm import LATITUDE_DEG, quiet_scratch, set_wind, trim_fdm
from simplexspline.sim.flight import DT, FlightLoop, schema_columns
from simplexspline.sim.maneuvers import AXES, LEAD_S, design_maneuver, excitation
from simplexspline.sim.pilot import Pilot, Turn
from simplexspline.sim.sensors import SensorModel
from simplexspline.sim.wind import Wind

__all__ = ["WholeFlight", "FLIGHT_TYPE", "STATIONARY_TYPE"]

#: The ``maneuver_type`` of a whole flight's single maneuver.
FLIGHT_TYPE = "whole-flight"
#: The segment type of a stationary measurement (:class:`WholeFlight` ``stationary_s``).
STATIONARY_TYPE = "stationary"
_SETTLE_S = 30.0  #: steady flight after a climb or speed change before the next maneuver [s]
_CATCH_UP_S = 600.0  #: longest time the pilot may lag behind a climb or speed change [s]


def _default_legs(profile: AircraftProfile) -> list:
    """Four test points from the profile's own grid: its lowest altitude and one a third
    up, at its second and second-to-last airspeed, flown as a snake (no aircraft constant)."""
    alts = sorted(profile.altitudes_m)
    speeds = sorted(profile.airspeeds_mps)
    a0, a1 = alts[0], alts[len(alts) // 3]
    v0, v1 = speeds[min(1, len(speeds) - 1)], speeds[max(0, len(speeds) - 2)]
    return [(a0, v0), (a0, v1), (a1, v1), (a1, v0)]


@dataclass(frozen=True)
class _Phase:
    kind: str            # 'steady', 'settle', 'stationary', 'turn', 'transition', 'maneuver'
    duration_s: float
    leg: int
    design: dict | None = None
    target: tuple | None = None   # (h_m, tas_mps) of a transition
    heading_change: float = 0.0   # [rad] of a turn


class WholeFlight:
    """A simulated flight-test sortie: one continuous flight through several test points.

    Parameters
    ----------
    aircraft : str or AircraftProfile
    legs : sequence of (float, float), optional
        Test points ``(altitude [m], true airspeed [m/s])`` flown in this order; default
        four points from the profile's grid (its lowest altitude and one a third up, at its
        second and second-to-last airspeeds).
    maneuvers : int
        Number of maneuvers, spread evenly over the legs in order.
    seed : int
        Non-negative seed; the same seed gives identical output.
    protocol : FlightProtocol, optional
        Maneuver mix and design, sum-of-sines lengths and turns, pilot (as for a
        :class:`Campaign`).
    sensors : SensorModel, optional
        One instrumentation package for the whole flight (default ``SensorModel()``).
    wind : Wind, optional
        One steady wind (speed drawn once from ``wind.speed_mps``) and turbulence for the
        whole flight; default still air.
    steady_s : (float, float)
        Range of the steady flight before each maneuver [s].
    turn_probability : float
        Probability that the pilot turns to a new heading (60-180 deg, at up to 20 deg of
        bank) before a maneuver, as a pilot staying inside a test area does.
    climb_rate_mps, accel_mps2 : float
        Rates at which the pilot changes altitude and airspeed between legs.
    fuel_fraction : float
        Fuel on board at the start, as a fraction of the model's full load.
    envelope : Envelope, optional
        Limits: samples outside are kept (a flight cannot be cut) but each maneuver's log
        names its first excursion.
    stationary_s : (float, float), optional
        With it, every leg begins (once the aircraft has settled there) with a stationary
        measurement of this range of durations [s]: trimmed straight flight logged as a
        maneuver of type :data:`STATIONARY_TYPE`, as a flight-test course logs its lift-drag
        and elevator-trim series. Default none.

    Examples
    --------
    >>> from simplexspline.sim import FlightProtocol, SensorModel
    >>> df = WholeFlight("global5000", legs=[(3000, 170)], maneuvers=1, steady_s=(5, 5),
    ...                  protocol=FlightProtocol(mix={"doublet": 1}),
    ...                  sensors=SensorModel.ideal()).run()
    >>> [s["type"] for s in df.attrs["flight"]["segments"]]
    ['steady', 'doublet-elevator', 'steady']
    """

    def __init__(self, aircraft: str | AircraftProfile = "global5000", *, legs=None,
                 maneuvers: int = 24, seed: int = 0, protocol: FlightProtocol | None = None,
                 sensors: SensorModel | None = None, wind: Wind | None = None,
                 steady_s: tuple = (20.0, 45.0), turn_probability: float = 0.3,
                 climb_rate_mps: float = 5.0, accel_mps2: float = 0.4,
                 fuel_fraction: float = 0.9, envelope=None, stationary_s=None):
        self.profile = get_aircraft(aircraft)
        self.legs = [tuple(float(x) for x in leg) for leg in
                     (_default_legs(self.profile) if legs is None else legs)]
        self.maneuvers = maneuvers
        self.seed = seed
        self.protocol = FlightProtocol() if protocol is None else protocol
        self.sensors = SensorModel() if sensors is None else sensors
        self.wind = wind
        self.steady_s = tuple(float(x) for x in steady_s)
        self.turn_probability = float(turn_probability)
        self.climb_rate_mps = float(climb_rate_mps)
        self.accel_mps2 = float(accel_mps2)
        self.fuel_fraction = float(fuel_fraction)
        self.envelope = self.profile.envelope if envelope is None else envelope
        self.stationary_s = None if stationary_s is None else tuple(float(x)
                                                                    for x in stationary_s)
        self._check()

    def _check(self) -> None:
        if not self.legs or any(len(leg) != 2 or not all(math.isfinite(x) and x > 0
                                                         for x in leg) for leg in self.legs):
            raise InputError("legs must be a non-empty list of (altitude [m], airspeed [m/s]) "
                             "pairs of positive numbers")
        for h, v in self.legs:
            mach = v / isa_speed_of_sound(h)
            if mach > self.envelope.mach_max - 0.03:
                raise InputError(f"leg ({h:g} m, {v:g} m/s) is at Mach {mach:.3f}, above the "
                                 f"envelope's {self.envelope.mach_max} - 0.03: fly it slower "
                                 "or lower")
        if not (isinstance(self.maneuvers, (int, np.integer)) and self.maneuvers >= 1):
            raise InputError(f"maneuvers must be a positive integer, got {self.maneuvers!r}")
        if not (isinstance(self.seed, (int, np.integer)) and self.seed >= 0):
            raise InputError(f"seed must be a non-negative integer, got {self.seed!r}")
        lo, hi = self.steady_s
        if not (0 < lo <= hi):
            raise InputError(f"steady_s must be (low, high) with 0 < low <= high, got "
                             f"{self.steady_s!r}")
        if self.stationary_s is not None and not (
                len(self.stationary_s) == 2 and 0 < self.stationary_s[0] <= self.stationary_s[1]):
            raise InputError(f"stationary_s must be (low, high) with 0 < low <= high, got "
                             f"{self.stationary_s!r}")
        if not 0 <= self.turn_probability <= 1:
            raise InputError("turn_probability must be in [0, 1]")
        if not (self.climb_rate_mps > 0 and self.accel_mps2 > 0):
            raise InputError("climb_rate_mps and accel_mps2 must be positive")
        if not 0 < self.fuel_fraction <= 1:
            raise InputError("fuel_fraction must be in (0, 1]")
        if not isinstance(self.protocol, FlightProtocol):
            raise InputError("protocol must be a simplexspline.sim.FlightProtocol")
        if not isinstance(self.sensors, SensorModel):
            raise InputError("sensors must be a simplexspline.sim.SensorModel")
        if self.wind is not None and not isinstance(self.wind, Wind):
            raise InputError("wind must be a simplexspline.sim.Wind or None")

    # ------------------------------------------------------------------ planning
    def plan(self) -> list:
        """The phases of the flight, in order (plain data: kind, duration, leg, design)."""
        rng = np.random.default_rng(np.random.SeedSequence(int(self.seed), spawn_key=(0,)))
        protocol = self.protocol
        fams = list(protocol.mix)
        kinds: list = []
        weights = [protocol.mix[f] for f in fams]
        for fam, k in zip(fams, split_counts(int(self.maneuvers), weights)):
            kinds += (["sum-of-sines"] * k if fam == "sum-of-sines"
                      else [f"{fam}-{AXES[j % 3]}" for j in range(k)])
        kinds = [kinds[j] for j in rng.permutation(len(kinds))]
        per_leg = split_counts(len(kinds), [1.0] * len(self.legs))
        phases, i = [], 0
        for leg, count in enumerate(per_leg):
            if leg:
                phases.append(_Phase("transition", 0.0, leg, target=self.legs[leg]))
                phases.append(_Phase("settle", _SETTLE_S, leg))
            if self.stationary_s is not None:
                phases.append(_Phase("stationary", float(rng.uniform(*self.stationary_s)), leg))
            for _ in range(count):
                design_rng = np.random.default_rng(
                    np.random.SeedSequence(int(self.seed), spawn_key=(1, i)).spawn(2)[0])
                design = design_maneuver(kinds[i], self.profile, design_rng,
                                         protocol.sos_duration_s,
                                         float(protocol.turn_fraction), protocol.design)
                if rng.random() < self.turn_probability:
                    change = rng.uniform(math.radians(60), math.pi) * rng.choice([-1, 1])
                    phases.append(_Phase("turn", 0.0, leg, heading_change=float(change)))
                phases.append(_Phase("steady", float(rng.uniform(*self.steady_s)), leg))
                phases.append(_Phase("maneuver", float(design["duration_s"]), leg, design))
                i += 1
        phases.append(_Phase("steady", float(rng.uniform(*self.steady_s)), len(self.legs) - 1))
        return phases

    # ------------------------------------------------------------------ flying
    def run(self):
        """Fly the sortie.

        Returns
        -------
        pandas.DataFrame
            One maneuver (0, ``maneuver_type`` :data:`FLIGHT_TYPE`) at 100 Hz in the
            flight-data schema with the ``true_*`` columns; ``df.attrs`` holds the schema
            metadata and ``flight``: the legs, the settings and ``segments``, one entry per
            phase (``start_s``, ``end_s``, ``type``: a maneuver type, 'steady', 'turn' or
            'transition', ``leg``, ``reason``: the first envelope excursion, if any).
        """
        import pandas as pd  # optional dependency (the 'sim' extra)

        phases = self.plan()
        rng = np.random.default_rng(np.random.SeedSequence(int(self.seed), spawn_key=(2,)))
        psi0 = float(rng.uniform(-math.pi, math.pi))
        wind = None if self.wind is None else self.wind.draw(rng)
        h0, v0 = self.legs[0]
        with quiet_scratch():
            fdm = trim_fdm(self.profile, h0, v0, psi0, self.fuel_fraction)
            if wind:
                set_wind(fdm, wind["ned_mps"], wind["severity"], wind["seed"])
            loop = FlightLoop(fdm, self.profile, self.envelope)
            s = loop.start()
            cg0 = [fdm[f"inertia/cg-{a}-in"] for a in "xyz"]
            segments = self._fly(loop, phases, s)
        spec = {"seed": int(self.seed), "index": 0, "condition": 0,
                "profile": self.profile.to_dict(), "cg_reference_in": cg0, "wind": wind}
        columns = schema_columns(loop.raw(), loop.surfaces(), loop.geometry, spec, self.sensors)
        columns.pop("condition")
        names = [c for c in FLIGHT_DATA_COLUMNS if c in columns] + \
            [c for c in columns if c not in FLIGHT_DATA_COLUMNS]
        df = pd.DataFrame({c: columns[c] for c in names}, copy=False)
        df.insert(2, "maneuver_type", pd.Categorical([FLIGHT_TYPE] * len(df)))
        df.attrs = self._metadata(df, loop.geometry, wind, segments)
        return df

    def _fly(self, loop: FlightLoop, phases: list, s: list) -> list:
        style = self.protocol.pilot
        cruise = Pilot("pilot", loop.trim(s), loop.airframe, style=style,
                       protection=loop.protection(s), dt=DT)
        segments, first, n_done = [], True, 0
        zeros = [(0.0, 0.0, 0.0)]

        def fly(pilot, exc, n):
            nonlocal s, first, n_done
            s, why = loop.steps(pilot, exc, n, s, first=first, stop=False)
            first = False
            n_done += n
            return why

        for ph in phases:
            start = n_done
            reason = None
            if ph.kind == "maneuver":
                design = ph.design
                n = int(round(design["duration_s"] / DT))
                qbar = s[6] * u.PSF
                exc = excitation(design, n, DT, loop.gains(s), loop.limits,
                                 pitch_scale=min(1.0, self.profile.pulse_qbar_ref / qbar))
                mode = "pilot" if design["family"] == "sum-of-sines" else "autopilot"
                pilot = Pilot(mode, loop.trim(s), loop.airframe, style=style,
                              turn=Turn(design.get("bank", 0.0), LEAD_S),
                              protection=loop.protection(s), dt=DT)
                reason = fly(pilot, exc.tolist(), n)
                kind = design["type"]
            elif ph.kind in ("steady", "settle", "stationary"):
                cruise.hold(psi=s[12], resume=True)
                n = int(round(ph.duration_s / DT))
                reason = fly(cruise, zeros * n, n)
                kind = STATIONARY_TYPE if ph.kind == "stationary" else "steady"
                if ph.kind == "settle":
                    # at a new test point the pilot trims afresh (new integrators and
                    # envelope protection around the new trim)
                    cruise = Pilot("pilot", {**loop.trim(s), "phi": 0.0}, loop.airframe,
                                   style=style, protection=loop.protection(s), dt=DT)
                    cruise.hold(h=self.legs[ph.leg][0], tas=self.legs[ph.leg][1])
            elif ph.kind == "turn":
                psi_new = s[12] + ph.heading_change
                cruise.hold(psi=(psi_new + math.pi) % (2 * math.pi) - math.pi, resume=True)
                rate = u.G0 * math.tan(math.radians(20.0)) / (s[2] * u.FT)
                n = int(round((abs(ph.heading_change) / rate + 20.0) / DT))
                reason = fly(cruise, zeros * n, n)
                kind = "turn"
            else:  # transition: climb/descend and accelerate/decelerate, 1 s at a time
                h_start, v_start = cruise.h_ref, cruise.v_ref
                h_end, v_end = ph.target
                t_need = max(abs(h_end - h_start) / self.climb_rate_mps,
                             abs(v_end - v_start) / self.accel_mps2, 1.0)
                chunks = int(math.ceil(t_need))
                cruise.hold(psi=s[12], resume=True)
                one = int(round(1.0 / DT))
                for j in range(1, chunks + int(_CATCH_UP_S) + 1):
                    f = min(1.0, j / chunks)
                    if f == 1.0 and abs(s[4] * u.FT - h_end) < 30.0 \
                            and abs(s[2] * u.FT - v_end) < 3.0:
                        break            # the aircraft got there
                    # the pitch attitude of level flight changes with the airspeed: the
                    # pilot re-trims it every second on the way
                    level = s[11] + s[41] * u.FT / (s[2] * u.FT)    # theta - gamma
                    cruise.hold(h=h_start + f * (h_end - h_start),
                                tas=v_start + f * (v_end - v_start), theta=level)
                    reason = reason or fly(cruise, zeros * one, one)
                kind = "transition"
            segments.append({"start_s": round(start * DT, 6),
                             "end_s": round((n_done - 1) * DT, 6), "type": kind,
                             "leg": ph.leg, "reason": reason or ""})
            if s[4] * u.FT < self.envelope.h_min or not math.isfinite(s[2]):
                raise SimulationError(f"{self.profile.name}: the whole flight left the "
                                      f"envelope in a {kind} phase ({reason}); fly gentler "
                                      "maneuvers or other legs")
        return segments

    def _metadata(self, df, geometry: tuple, wind, segments: list) -> dict:
        S, b, cbar = geometry
        p = self.protocol
        meta = {
            "schema": SCHEMA_VERSION, "aircraft": self.profile.name,
            "S": float(S), "b": float(b), "cbar": float(cbar), "sample_rate_hz": 1.0 / DT,
            "latitude_deg": LATITUDE_DEG,
            "units": {c: FLIGHT_DATA_COLUMNS[c].unit for c in df.columns
                      if c in FLIGHT_DATA_COLUMNS and FLIGHT_DATA_COLUMNS[c].unit},
            "sign_conventions": dict(SURFACE_SIGN_CONVENTIONS),
            "simulator": {
                "name": "simplexspline.sim.whole_flight",
                "versions": {"simplexspline": __version__, "jsbsim": version("jsbsim"),
                             "numpy": np.__version__},
                "jsbsim_model": self.profile.model, "seed": int(self.seed), "dt_s": DT,
                "sensors": self.sensors.to_dict(),
                "wind": None if self.wind is None else {**self.wind.to_dict(),
                                                        "drawn": wind},
                "envelope": self.envelope.to_dict(),
            },
            "flight": {
                "legs": [list(leg) for leg in self.legs], "maneuvers": int(self.maneuvers),
                "mix": dict(p.mix), "sos_duration_s": list(p.sos_duration_s),
                "turn_fraction": p.turn_fraction, "design": p.design,
                "steady_s": list(self.steady_s), "turn_probability": self.turn_probability,
                "climb_rate_mps": self.climb_rate_mps, "accel_mps2": self.accel_mps2,
                "fuel_fraction": self.fuel_fraction, "stationary_s": (
                    None if self.stationary_s is None else list(self.stationary_s)),
                "segments": segments,
                "duration_s": round(len(df) * DT, 2),
            },
        }
        geometry_meta = self.sensors.sensor_geometry()
        if geometry_meta is not None:
            meta["sensor_geometry"] = geometry_meta
        return meta
