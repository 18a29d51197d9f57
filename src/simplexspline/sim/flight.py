"""Fly one maneuver: trim, excite, hold, record, cut at the envelope, measure.

:func:`simulate_maneuver` is what a worker process runs. It takes a plain-data spec (made
by :mod:`simplexspline.sim.campaign`) and returns plain data: a dict of column arrays in
the flight-data schema plus a log entry. It is deterministic: the same spec gives the same
arrays, in any process.
"""

from __future__ import annotations

import math
from array import array

import numpy as np

from simplexspline.aero.data.atmosphere import pressure_altitude
from simplexspline.errors import SimulationError
from simplexspline.sim import units as u
from simplexspline.sim.aircraft import AircraftProfile, Envelope
from simplexspline.sim.fdm import IDX, Recorder, quiet_scratch, set_wind, trim_fdm
from simplexspline.sim.maneuvers import LEAD_S, excitation
from simplexspline.sim.pilot import (Actuator, AircraftState, Airframe, Pilot, PilotStyle,
                                     Turn)
from simplexspline.sim.sensors import SensorModel

__all__ = ["simulate_maneuver", "trim_condition", "schema_columns", "FlightLoop", "DT"]

DT = 0.01  #: sample time [s] (100 Hz)

# WGS84, for the local flat-earth GPS coordinates
_A = 6378137.0
_E2 = 6.69437999014e-3

_PROFILES: dict = {}


def _profile(d: dict) -> AircraftProfile:
    key = repr(sorted(d.items()))
    prof = _PROFILES.get(key)
    if prof is None:
        prof = _PROFILES[key] = AircraftProfile.from_dict(d)
    return prof


def trim_condition(spec: dict) -> dict:
    """Trim at one grid condition and report the trim state (the campaign's pre-pass).

    Parameters
    ----------
    spec : dict
        ``profile`` (dict), ``condition``, ``h_m``, ``tas_mps``, optional ``scratch``.

    Returns
    -------
    dict
        ``condition``, ``h_m``, ``tas_mps``, ``trimmed`` (bool), ``reason`` and, if
        trimmed, ``alpha``, ``mach``, ``de``, ``throttle`` at the trim point and ``cg_in``,
        the c.g. with the model's full fuel load (JSBSim's structural frame [in]): the
        campaign's sensor-geometry reference point.
    """
    profile = _profile(spec["profile"])
    out = {"condition": spec["condition"], "h_m": spec["h_m"], "tas_mps": spec["tas_mps"],
           "trimmed": False, "reason": ""}
    with quiet_scratch(spec.get("scratch")):
        try:
            fdm = trim_fdm(profile, spec["h_m"], spec["tas_mps"])
        except SimulationError as exc:
            out["reason"] = str(exc)
            return out
        fdm.run()
        rec = Recorder(fdm, profile)
        s = rec.sample()
        de = rec.surface_reads[0]()
        thr = rec.throttle_nodes[0].get_double_value()
    env = Envelope.from_dict(spec["envelope"])
    alpha, mach = s[IDX["aero/alpha-rad"]], s[IDX["velocities/mach"]]
    out.update(alpha=alpha, mach=mach, de=de, throttle=thr)
    margin = math.radians(3.0)
    if not (env.alpha_min + margin <= alpha <= env.alpha_max - margin):
        out["reason"] = (f"trim alpha {math.degrees(alpha):.1f} deg is within 3 deg of the "
                         "envelope's alpha limits")
    elif mach > env.mach_max - 0.02:
        out["reason"] = f"trim Mach {mach:.3f} is within 0.02 of the envelope's Mach limit"
    elif not (0.02 <= thr <= 0.98):
        out["reason"] = f"trim throttle {thr:.2f} leaves no margin to hold airspeed"
    else:
        out["trimmed"] = True
    out["cg_in"] = [s[IDX[f"inertia/cg-{a}-in"]] for a in "xyz"]
    return out


def _violation(env: Envelope, s: list) -> str | None:
    """Reason the raw JSBSim sample ``s`` lies outside ``env``, or None."""
    a = s[0]
    if not (env.alpha_min <= a <= env.alpha_max):
        return f"alpha {math.degrees(a):.1f} deg outside [{math.degrees(env.alpha_min):.1f}, " \
               f"{math.degrees(env.alpha_max):.1f}] deg"
    if not (abs(s[1]) <= env.beta_max):
        return f"|beta| {math.degrees(abs(s[1])):.1f} deg > {math.degrees(env.beta_max):.1f} deg"
    if not (abs(s[10]) <= env.phi_max):
        return f"|phi| {math.degrees(abs(s[10])):.1f} deg > {math.degrees(env.phi_max):.1f} deg"
    if not (abs(s[11]) <= env.theta_max):
        return (f"|theta| {math.degrees(abs(s[11])):.1f} deg > "
                f"{math.degrees(env.theta_max):.1f} deg")
    nz = -s[15] / (s[31] * u.G0 / u.FT)
    if not (env.nz_min <= nz <= env.nz_max):
        return f"load factor {nz:.2f} outside [{env.nz_min}, {env.nz_max}]"
    if not (s[3] <= env.mach_max):
        return f"Mach {s[3]:.3f} > {env.mach_max}"
    if not (s[4] * u.FT >= env.h_min):
        return f"altitude {s[4] * u.FT:.0f} m < {env.h_min:.0f} m"
    return None


def simulate_maneuver(spec: dict) -> dict:
    """Fly one maneuver from a plain-data spec.

    Parameters
    ----------
    spec : dict
        ``index``, ``condition``, ``profile`` (dict), ``envelope`` (dict), ``sensors``
        (dict), ``design`` (dict from :func:`~simplexspline.sim.maneuvers.design_maneuver`),
        ``h_m``, ``tas_mps`` (jittered trim point), ``h_nominal``, ``tas_nominal``, optional
        ``wind`` (from :meth:`~simplexspline.sim.wind.Wind.draw`),
        ``psi_rad``, ``fuel_fraction``, ``seed`` (int), ``min_kept_s``, ``pilot`` (dict of
        :class:`~simplexspline.sim.pilot.PilotStyle`),
        optional ``scratch`` and ``cg_reference_in`` (the sensor-geometry reference point,
        JSBSim's structural frame [in]: the c.g. with full fuel from the campaign's trims;
        without it the sensors sit at the c.g. and no c.g. columns are written).

    Returns
    -------
    dict
        ``columns`` (dict of (n,) arrays, possibly empty) and ``log`` (dict).
    """
    profile = _profile(spec["profile"])
    env = Envelope.from_dict(spec["envelope"])
    sensors = SensorModel.from_dict(spec["sensors"])
    design = spec["design"]
    n = int(round(design["duration_s"] / DT))
    log = {"maneuver": spec["index"], "condition": spec["condition"], "type": design["type"],
           "h_m": spec["h_m"], "tas_mps": spec["tas_mps"], "status": "complete",
           "reason": "", "duration_s": 0.0, "planned_s": n * DT}
    for key in ("unit_s", "accel", "accel_rms", "bank"):
        if key in design:
            log[key] = design[key]
    with quiet_scratch(spec.get("scratch")):
        try:
            fdm = trim_fdm(profile, spec["h_m"], spec["tas_mps"], spec["psi_rad"],
                           spec["fuel_fraction"])
        except SimulationError:
            try:
                fdm = trim_fdm(profile, spec["h_nominal"], spec["tas_nominal"],
                               spec["psi_rad"], spec["fuel_fraction"])
                log.update(h_m=spec["h_nominal"], tas_mps=spec["tas_nominal"])
            except SimulationError as exc:
                log.update(status="trim-failed", reason=str(exc))
                return {"columns": {}, "log": log}
        wind = spec.get("wind")
        if wind:
            set_wind(fdm, wind["ned_mps"], wind["severity"], wind["seed"])
            log["wind_ned_mps"] = list(wind["ned_mps"])
        raw, surf, reason = _fly(fdm, profile, env, design, spec, n)
    kept = len(raw)
    log["duration_s"] = kept * DT
    if reason is not None:
        log["reason"] = f"{reason} at t = {kept * DT:.2f} s"
        log["status"] = "cut" if kept and kept * DT >= spec["min_kept_s"] else "dropped"
        if log["status"] == "dropped":
            log["duration_s"] = 0.0
            return {"columns": {}, "log": log}
    geometry = (fdm["metrics/Sw-sqft"] * u.FT**2, fdm["metrics/bw-ft"] * u.FT,
                fdm["metrics/cbarw-ft"] * u.FT)
    columns = schema_columns(raw, surf, geometry, spec, sensors)
    return {"columns": columns, "log": log, "geometry": geometry}


def _fly(fdm, profile: AircraftProfile, env: Envelope, design: dict, spec: dict, n: int):
    """The 100 Hz loop. Returns raw samples, surface positions and the cut reason."""
    loop = FlightLoop(fdm, profile, env)
    s = loop.start()
    exc = excitation(design, n, DT, loop.gains(s), loop.limits,
                     pitch_scale=min(1.0, profile.pulse_qbar_ref / (s[6] * u.PSF))).tolist()
    pilot = Pilot("pilot" if design["family"] == "sum-of-sines" else "autopilot", loop.trim(s),
                  loop.airframe, style=PilotStyle(**spec["pilot"]),
                  turn=Turn(design.get("bank", 0.0), LEAD_S), protection=loop.protection(s),
                  dt=DT)
    _, reason = loop.steps(pilot, exc, n, s, first=True, stop=True)
    return loop.raw(), loop.surfaces(), reason


class FlightLoop:
    """The 100 Hz loop of one trimmed FDM: pilot and excitation -> actuators -> JSBSim.

    One campaign maneuver is one call of :meth:`steps`; a whole flight (:mod:`simplexspline
    .sim.whole_flight`) calls it once per phase (steady flight, a maneuver, a climb) on the
    same FDM, with the actuators, throttle and records carried over.

    Parameters
    ----------
    fdm : jsbsim.FGFDMExec
        Trimmed, FCS off (:func:`~simplexspline.sim.fdm.trim_fdm`).
    profile : AircraftProfile
    env : Envelope
        Limits checked at every sample.
    """

    def __init__(self, fdm, profile: AircraftProfile, env: Envelope):
        self.fdm, self.profile, self.env = fdm, profile, env
        self.rec = Recorder(fdm, profile)
        self.trim_surf = [f() for f in self.rec.surface_reads]
        for w, d in zip(self.rec.surface_writers, self.trim_surf):
            for setter, gain in w:
                setter(gain * d)
        self.limits = tuple(sf.limit for sf in profile.surfaces)
        self.actuators = [Actuator(d, sf.limit, sf.rate, sf.tau, DT)
                          for d, sf in zip(self.trim_surf, profile.surfaces)]
        self.deflections = list(self.trim_surf)
        self.geometry = (fdm["metrics/Sw-sqft"] * u.FT**2, fdm["metrics/bw-ft"] * u.FT,
                         fdm["metrics/cbarw-ft"] * u.FT)
        self.airframe = Airframe.of(profile, self.geometry)
        # flat float buffers: one extend per sample is cheaper than a list of lists
        self.rows, self.surf = array("d"), array("d")
        self.width = len(IDX)

    def start(self) -> list:
        """The first ``run()`` after the trim; returns the first sample."""
        self.fdm.run()
        return self.rec.sample()

    def throttle(self) -> float:
        """The current throttle setting of the first engine."""
        return self.rec.throttle_nodes[0].get_double_value()

    def gains(self, s: list) -> tuple:
        """Deflection per angular acceleration of (elevator, aileron, rudder) at sample
        ``s`` (the control power and dynamic pressure there)."""
        S, b, c = self.geometry
        qbar = s[6] * u.PSF
        inertia = (s[33] * u.SLUG_FT2, s[32] * u.SLUG_FT2, s[34] * u.SLUG_FT2)
        refs = (c, b, b)
        return tuple(inertia[i] / (qbar * S * refs[i] * self.profile.control_power[i])
                     for i in range(3))

    def trim(self, s: list) -> dict:
        """The pilot's trim point: the state of sample ``s`` and the current surfaces and
        throttle."""
        de, da, dr = (a.x for a in self.actuators)
        return {"theta": s[11], "phi": s[10], "psi": s[12], "h": s[4] * u.FT,
                "tas": s[2] * u.FT, "de": de, "da": da, "dr": dr, "throttle": self.throttle()}

    def protection(self, s: list) -> dict:
        """Soft envelope protection of the flight control computer around sample ``s``."""
        env = self.env
        return {"nz": (1 - 0.7 * (1 - env.nz_min), 1 + 0.7 * (env.nz_max - 1)),
                "alpha": (env.alpha_min + 0.3 * (s[0] - env.alpha_min),
                          env.alpha_max - 0.3 * (env.alpha_max - s[0])),
                "phi": 0.7 * env.phi_max}

    def raw(self) -> np.ndarray:
        """Every recorded sample, (n, len(IDX)), JSBSim units."""
        return np.frombuffer(self.rows, dtype=float).reshape(-1, self.width)

    def surfaces(self) -> np.ndarray:
        """Recorded (de, da, dr, flap) per sample, (n, 4)."""
        return np.frombuffer(self.surf, dtype=float).reshape(-1, 4)

    def steps(self, pilot: Pilot, exc: list, n: int, s: list, *, first: bool = False,
              stop: bool = True) -> tuple:
        """Fly ``n`` samples.

        Parameters
        ----------
        pilot : Pilot
        exc : list of (3,) sequences
            Deflections added to the pilot's commands; ``exc[k]`` is applied in the step
            that produces sample ``k`` of this call.
        n : int
        s : list
            The current sample (the last one recorded, or the first one when ``first``).
        first : bool
            Record ``s`` itself as sample 0 (the start of a flight) instead of stepping to
            it.
        stop : bool
            Stop at the first sample outside the envelope (not recorded); else record it
            and go on.

        Returns
        -------
        s : list
            The last sample recorded.
        reason : str or None
            The first envelope violation.
        """
        fdm, rec, env = self.fdm, self.rec, self.env
        writers = rec.surface_writers
        throttle_nodes = rec.throttle_nodes
        schedules = rec.schedule_writers
        flap_read = rec.flap_read
        sample = rec.sample
        run = fdm.run
        command = pilot.command
        FT, PSF, SL2 = u.FT, u.PSF, u.SLUG_FT2
        g_ft = u.G0 / FT
        rows_extend, surf_extend = self.rows.extend, self.surf.extend
        deflections = self.deflections
        reason = None
        # envelope bounds in JSBSim units for the fast in-loop check
        a_lo, a_hi, b_max = env.alpha_min, env.alpha_max, env.beta_max
        phi_max, th_max, m_max = env.phi_max, env.theta_max, env.mach_max
        nz_lo, nz_hi, h_lo = env.nz_min, env.nz_max, env.h_min / FT
        act_e, act_a, act_r = (a.step for a in self.actuators)
        w_e, w_a, w_r = writers
        for k in range(n):
            if k or not first:
                de, da, dr, thr = command(AircraftState(
                    theta=s[11], phi=s[10], psi=s[12], p=s[7], q=s[8], r=s[9], h=s[4] * FT,
                    tas=s[2] * FT, vd=s[41] * FT, qbar=s[6] * PSF, ixx=s[32] * SL2,
                    iyy=s[33] * SL2, izz=s[34] * SL2, alpha=s[0], nz=-s[15] / (s[31] * g_ft)))
                e = exc[k]
                deflections = [act_e(de + e[0]), act_a(da + e[1]), act_r(dr + e[2])]
                d = deflections[0]
                for setter, gain in w_e:
                    setter(gain * d)
                d = deflections[1]
                for setter, gain in w_a:
                    setter(gain * d)
                d = deflections[2]
                for setter, gain in w_r:
                    setter(gain * d)
                for setter, default, rules in schedules:
                    value = default
                    for var, threshold, v in rules:
                        if (s[0] if var == "alpha" else s[3]) > threshold:
                            value = v
                            break
                    setter(value)
                if thr is not None:
                    for node in throttle_nodes:
                        node.set_double_value(thr)
                run()
                s = sample()
            nz = -s[15] / (s[31] * g_ft)
            if not (a_lo <= s[0] <= a_hi and -b_max <= s[1] <= b_max
                    and -phi_max <= s[10] <= phi_max and -th_max <= s[11] <= th_max
                    and nz_lo <= nz <= nz_hi and s[3] <= m_max and s[4] >= h_lo):
                if reason is None:
                    reason = _violation(env, s)
                if stop:
                    break
            rows_extend(s)
            surf_extend((*deflections, flap_read() if flap_read else 0.0))
        self.deflections = deflections
        return s, reason


def schema_columns(raw: np.ndarray, surf: np.ndarray, geometry: tuple, spec: dict,
             sensors: SensorModel) -> dict:
    """Schema columns (SI) from raw JSBSim samples: truth, thrust, sensors."""
    n = raw.shape[0]
    S, b, c = geometry
    col = {name: raw[:, i] for name, i in IDX.items()}
    t = np.arange(n) * DT
    mass = col["inertia/mass-slugs"] * u.SLUG
    qbar = col["aero/qbar-psf"] * u.PSF
    alpha, beta = col["aero/alpha-rad"], col["aero/beta-rad"]
    lat, lon, hsl = col["position/lat-geod-rad"], col["position/long-gc-rad"], \
        col["position/h-sl-ft"] * u.FT
    sin0 = math.sin(lat[0])
    rn = _A / math.sqrt(1 - _E2 * sin0**2)
    rm = _A * (1 - _E2) / (1 - _E2 * sin0**2) ** 1.5
    psi = col["attitude/psi-rad"]
    true = {
        "alpha": alpha, "beta": beta, "tas": col["velocities/vt-fps"] * u.FT,
        # what an altimeter shows: the ISA pressure altitude of the static pressure
        "mach": col["velocities/mach"],
        "h": pressure_altitude(col["atmosphere/P-psf"] * u.PSF),
        "rho": col["atmosphere/rho-slugs_ft3"] * u.SLUG_FT3,
        "p": col["velocities/pi-rad_sec"], "q": col["velocities/qi-rad_sec"],
        "r": col["velocities/ri-rad_sec"],
        "phi": col["attitude/phi-rad"], "theta": col["attitude/theta-rad"],
        "psi": (psi + math.pi) % (2 * math.pi) - math.pi,
        "ax": col["forces/fbx-total-lbs"] * u.LBF / mass,
        "ay": col["forces/fby-total-lbs"] * u.LBF / mass,
        "az": col["forces/fbz-total-lbs"] * u.LBF / mass,
        "pdot": col["accelerations/pidot-rad_sec2"],
        "qdot": col["accelerations/qidot-rad_sec2"],
        "rdot": col["accelerations/ridot-rad_sec2"],
        "de": surf[:, 0], "da": surf[:, 1], "dr": surf[:, 2],
        "x_gps": (lat - lat[0]) * (rm + hsl[0]),
        "y_gps": (lon - lon[0]) * (rn + hsl[0]) * math.cos(lat[0]),
        "z_gps": -(hsl - hsl[0]),
        "vn_gps": col["velocities/v-north-fps"] * u.FT,
        "ve_gps": col["velocities/v-east-fps"] * u.FT,
        "vd_gps": col["velocities/v-down-fps"] * u.FT,
    }
    # the c.g. from the sensor-geometry reference point (the full-fuel c.g.), body axes
    # (x forward, y right, z down) from JSBSim's structural frame (x aft, y right, z up)
    # (sensors that follow the c.g. see none of it, and the table gets no c.g. columns; a
    # spec without the campaign's reference point places the sensors at the c.g. too)
    ref = spec.get("cg_reference_in")
    cg = None if sensors.at_cg or ref is None else np.column_stack(
        [-(col["inertia/cg-x-in"] - ref[0]) * u.IN, (col["inertia/cg-y-in"] - ref[1]) * u.IN,
         -(col["inertia/cg-z-in"] - ref[2]) * u.IN])
    ss = np.random.SeedSequence(spec["seed"], spawn_key=(1, spec["index"]))
    noise_rng = np.random.default_rng(ss.spawn(2)[1])
    measured = sensors.apply(true, t, noise_rng, cg=cg)
    qs = qbar * S
    cx = col["forces/fbx-aero-lbs"] * u.LBF / qs
    cy = col["forces/fby-aero-lbs"] * u.LBF / qs
    cz = col["forces/fbz-aero-lbs"] * u.LBF / qs
    ca, sa, cb, sb = np.cos(alpha), np.sin(alpha), np.cos(beta), np.sin(beta)
    out = {"maneuver": np.full(n, spec["index"], dtype=np.int64), "t": t}
    out.update(measured)
    out.update({
        "mass": mass,
        "Ixx": col["inertia/ixx-slugs_ft2"] * u.SLUG_FT2,
        "Iyy": col["inertia/iyy-slugs_ft2"] * u.SLUG_FT2,
        "Izz": col["inertia/izz-slugs_ft2"] * u.SLUG_FT2,
        # JSBSim's ixz has the opposite sign of the paper's Eq. 46-48 (GUIDE section 4)
        "Ixz": -col["inertia/ixz-slugs_ft2"] * u.SLUG_FT2,
        "thrust_x": col["forces/fbx-prop-lbs"] * u.LBF,
        "thrust_y": col["forces/fby-prop-lbs"] * u.LBF,
        "thrust_z": col["forces/fbz-prop-lbs"] * u.LBF,
        "thrust_l": col["moments/l-prop-lbsft"] * u.LBF_FT,
        "thrust_m": col["moments/m-prop-lbsft"] * u.LBF_FT,
        "thrust_n": col["moments/n-prop-lbsft"] * u.LBF_FT,
        "flap": surf[:, 3] * spec["profile"]["flap_scale"],
        "condition": np.full(n, spec["condition"], dtype=np.int64),
        "fuel_flow": col["engines/fuel-flow-pps"] * u.LB,
    })
    n1 = col["engines/n1-pct"] / 100.0
    if np.isfinite(n1).all():  # turbines (a piston engine has no fan)
        out["n1"] = n1
    if cg is not None:
        out.update(x_cg=cg[:, 0], y_cg=cg[:, 1], z_cg=cg[:, 2])
    for ch, x in true.items():
        out["true_" + ch] = x
    out.update({
        "true_qbar": qbar,
        "true_CX": cx, "true_CY": cy, "true_CZ": cz,
        "true_Cl": col["moments/l-aero-lbsft"] * u.LBF_FT / (qs * b),
        "true_Cm": col["moments/m-aero-lbsft"] * u.LBF_FT / (qs * c),
        "true_Cn": col["moments/n-aero-lbsft"] * u.LBF_FT / (qs * b),
        "true_CL": cx * sa - cz * ca,
        "true_CD": -(cx * ca * cb + cy * sb + cz * sa * cb),
    })
    if spec.get("wind"):  # steady wind + turbulence, towards north, east, down
        for axis, d in (("n", "north"), ("e", "east"), ("d", "down")):
            out[f"true_wind_{axis}"] = col[f"atmosphere/total-wind-{d}-fps"] * u.FT
        for axis in "pqr":
            out[f"true_{axis}_aero"] = col[f"velocities/{axis}-aero-rad_sec"]
    return out
