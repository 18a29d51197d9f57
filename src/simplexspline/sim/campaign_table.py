"""Assemble worker results into one flight-data table with its metadata; coverage summary."""

from __future__ import annotations

import math
from importlib.metadata import version

import numpy as np

from simplexspline._version import __version__
from simplexspline.aero.data.flight_data import FLIGHT_DATA_COLUMNS, SCHEMA_VERSION
from simplexspline.errors import SimulationError
from simplexspline.sim.aircraft import SURFACE_SIGN_CONVENTIONS
from simplexspline.sim.maneuvers import MANEUVER_TYPES
from simplexspline.sim.fdm import LATITUDE_DEG
from simplexspline.sim.flight import DT

__all__ = ["assemble", "envelope_coverage", "COVERAGE_CHANNELS"]

#: Channels summarised by :func:`envelope_coverage` with their display unit and factor.
COVERAGE_CHANNELS = {
    "alpha": ("deg", 180 / math.pi), "beta": ("deg", 180 / math.pi), "mach": ("-", 1.0),
    "tas": ("m/s", 1.0), "h": ("m", 1.0), "p": ("deg/s", 180 / math.pi),
    "q": ("deg/s", 180 / math.pi), "r": ("deg/s", 180 / math.pi),
    "phi": ("deg", 180 / math.pi), "theta": ("deg", 180 / math.pi),
    "de": ("deg", 180 / math.pi), "da": ("deg", 180 / math.pi), "dr": ("deg", 180 / math.pi),
    "nz": ("g", 1.0),
}


def assemble(results: list, conditions: list, st: dict, campaign):
    """One DataFrame (schema column order) from per-maneuver results, metadata in attrs.

    Consumes the column arrays of ``results`` (they are moved into the table).
    """
    import pandas as pd  # optional dependency (the 'sim' extra)

    kept = [r for r in results if r["columns"]]
    logs = [r["log"] for r in results]
    if not kept:
        statuses = sorted({lg["status"] for lg in logs})
        raise SimulationError(
            f"no maneuver was kept (statuses: {statuses}; first reason: "
            f"{logs[0]['reason'] if logs else 'none planned'}); widen the envelope, lower "
            "the excitation or choose other flight conditions")
    first = kept[0]["columns"]
    names = [c for c in FLIGHT_DATA_COLUMNS if c in first] + \
        [c for c in first if c not in FLIGHT_DATA_COLUMNS]
    codes = np.concatenate([
        np.full(len(r["columns"]["t"]), MANEUVER_TYPES.index(r["log"]["type"]), dtype=np.int8)
        for r in kept])
    # column by column, releasing the per-maneuver pieces: peak memory ~ one copy of the data
    data = {name: np.concatenate([r["columns"].pop(name) for r in kept]) for name in names}
    data["maneuver_type"] = pd.Categorical.from_codes(codes, categories=list(MANEUVER_TYPES))
    order = ["maneuver", "t", "condition", "maneuver_type"]
    cols = order + [c for c in names if c not in order]
    df = pd.DataFrame({c: data[c] for c in cols}, copy=False)
    S, b, cbar = kept[0]["geometry"]
    profile, env, sensors = st["profile"], st["envelope"], st["sensors"]
    protocol = campaign.protocol
    status = [lg["status"] for lg in logs]
    meta = {
        "schema": SCHEMA_VERSION,
        "aircraft": profile.name,
        "S": float(S), "b": float(b), "cbar": float(cbar),
        "sample_rate_hz": 1.0 / DT,
        "latitude_deg": LATITUDE_DEG,
        "units": {c: FLIGHT_DATA_COLUMNS[c].unit for c in cols
                  if c in FLIGHT_DATA_COLUMNS and FLIGHT_DATA_COLUMNS[c].unit},
        "sign_conventions": {
            **SURFACE_SIGN_CONVENTIONS,
            "axes": "body axes x forward, y right, z down; moments about the c.g.",
            "rates": "p, q, r and pdot, qdot, rdot are inertial (what gyros measure)",
            "Ixz": "sign of the paper's Eq. 46-48 (Ixz = integral of x z dm); JSBSim's "
                   "inertia/ixz-slugs_ft2 has the opposite sign",
            "gps": "x/y/z_gps: north/east/down from each maneuver's first sample (local "
                   "flat earth); vn/ve/vd_gps: Earth-relative NED velocity",
            "flap": profile.notes or "flap deflection",
        },
        "coefficients": (
            "true_CX..true_Cn: aerodynamic forces/moments only (thrust excluded; thrust in "
            "thrust_*), body axes, about the c.g., divided by qbar*S (forces), qbar*S*b "
            "(Cl, Cn), qbar*S*cbar (Cm) with qbar = 0.5*rho*tas^2. With ideal sensors, Eq. "
            "43-48 of the paper applied to the recorded columns after subtracting thrust_* "
            "reproduce them to rounding error."),
        "simulator": {
            "name": "simplexspline.sim",
            "versions": {"simplexspline": __version__, "jsbsim": version("jsbsim"),
                         "numpy": np.__version__},
            "jsbsim_model": profile.model,
            "seed": int(campaign.seed),
            "dt_s": DT,
            "campaign": {
                "altitudes_m": st["altitudes"].tolist(),
                "airspeeds_mps": st["airspeeds"].tolist(),
                "maneuvers": len(results),
                "mix": dict(protocol.mix), "sos_duration_s": list(protocol.sos_duration_s),
                "turn_fraction": float(protocol.turn_fraction),
                "jitter": bool(campaign.grid.jitter), "pilot_delay_s": protocol.pilot_delay_s,
                "min_kept_s": protocol.min_kept_s, "design": protocol.design,
                "pilot_style": protocol.pilot.to_dict(),
            },
            "sensors": sensors.to_dict(),
            "sensor_reference": (
                "the moving c.g. (sensors at the c.g.; no c.g. columns)" if sensors.at_cg else
                {"point": "the c.g. with full fuel; x_cg, y_cg, z_cg and the sensor positions "
                          "are measured from it",
                 "jsbsim_structural_in": next((c["cg_in"] for c in conditions
                                               if c.get("trimmed")), None)}),
            "wind": None if campaign.wind is None else campaign.wind.to_dict(),
            "envelope": env.to_dict(),
            "actuators": {name: {"limit_rad": s.limit, "rate_rad_s": s.rate, "tau_s": s.tau}
                          for name, s in zip(("elevator", "aileron", "rudder"),
                                             profile.surfaces)},
            "pilot": {"bandwidth_rad_s": list(profile.pilot_bandwidth),
                      "sas_damping_1_s": list(profile.sas_damping),
                      "control_power": list(profile.control_power)},
        },
        "summary": {
            "maneuvers_planned": len(results),
            "maneuvers_kept": len(kept),
            **{s: status.count(s) for s in ("complete", "cut", "dropped", "trim-failed")},
            "samples": len(df),
            "flight_time_s": round(len(df) * DT, 2),
        },
        "conditions": conditions,
        "maneuvers": logs,
    }
    geometry = sensors.sensor_geometry()
    if geometry is not None:
        meta["sensor_geometry"] = geometry
    df.attrs = meta
    return df


def envelope_coverage(df, percentiles=(1, 50, 99)):
    """Range of the main channels covered by a campaign (true values when present).

    Parameters
    ----------
    df : pandas.DataFrame
        Flight data.
    percentiles : sequence of float
        Percentiles to report besides min and max.

    Returns
    -------
    pandas.DataFrame
        One row per channel of :data:`COVERAGE_CHANNELS` (display units: deg, deg/s, g).
    """
    import pandas as pd  # optional dependency (the 'sim' extra)

    rows = {}
    for ch, (unit, f) in COVERAGE_CHANNELS.items():
        if ch == "nz":
            az = df["true_az"] if "true_az" in df else df["az"]
            x = -az.to_numpy() / 9.80665
        else:
            x = (df["true_" + ch] if "true_" + ch in df else df[ch]).to_numpy() * f
        row = {"unit": unit, "min": np.nanmin(x)}
        row.update({f"p{p:g}": np.nanpercentile(x, p) for p in percentiles})
        row["max"] = np.nanmax(x)
        rows[ch] = row
    return pd.DataFrame.from_dict(rows, orient="index")
