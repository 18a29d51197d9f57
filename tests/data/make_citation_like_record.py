"""Write the small real-format flight record in tests/data/citation_like/ from a known flight.

Three maneuvers of the simulated business jet (global5000, perfect sensors, one flight
condition) are joined into one continuous 10 Hz "flight": 20 s on the ground (weight on
wheels, taxiing), smooth transitions between the maneuvers, and written the way a real
flight-test record arrives: one text file per channel (time, value) in aviation units
(deg, deg/s, knots, ft, g, degC, lbs of fuel used, lbs/hr of fuel flow per engine),
indicated airspeed instead of true
airspeed, no sideslip vane, an empty heading file, GPS latitude and longitude only, the
normal load factor (+1 g in level flight) instead of the body z specific force, and the
elevator stored without time stamps at the stated 10 Hz. The truth (SI, schema names, with
the mass from the fuel burnt and inertias from the radii of gyration) goes to truth.csv.

Run from the repository root (needs the 'sim' extra; about 10 s):

    .venv/bin/python tests/data/make_citation_like_record.py
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from simplexspline.aero.data import atmosphere
from simplexspline.sim import Campaign, ConditionGrid, FlightProtocol, SensorModel

OUT = Path(__file__).resolve().parent / "citation_like"
RATE = 10.0
KT, FT, LB, G0 = 1852.0 / 3600.0, 0.3048, 0.45359237, 9.80665
RAMP_LB, BURN_LB_S = 14000.0, 0.35
FLOW_SHARE = 0.48  # of the fuel flow through the left engine
RADII_M = {"x": 2.6, "y": 3.1, "z": 3.9}
LAT0, LON0 = math.radians(52.0), math.radians(4.7)
FIELD_FT = 4600.0


def _blend(a: dict, b: dict, n: int) -> dict:
    w = 0.5 - 0.5 * np.cos(np.linspace(0, np.pi, n + 2)[1:-1])
    return {k: a[k] + (b[k] - a[k]) * w for k in a}


def main() -> None:
    df = Campaign("global5000", maneuvers=3, seed=11, sensors=SensorModel.ideal(),
                  grid=ConditionGrid([1500.0], [130.0], jitter=False),
                  protocol=FlightProtocol(mix={"3211": 2, "doublet": 1}, turn_fraction=0.0),
                  ).run(workers=1, progress=False)
    cols = ["alpha", "beta", "tas", "h", "p", "q", "r", "phi", "theta", "psi", "ax", "ay",
            "az", "de", "da", "dr", "vn_gps", "ve_gps", "vd_gps", "rho", "mach"]
    pieces, types = [], []
    for m, g in df.groupby("maneuver"):
        g = g.iloc[::10]  # 100 Hz -> 10 Hz, instantaneous sampling
        pieces.append({c: g[c].to_numpy() for c in cols})
        types.append(str(g["maneuver_type"].iloc[0]))
    first = {c: pieces[0][c][0] for c in cols}
    ground = {c: 0.0 for c in cols}
    ground.update(tas=8.0, h=FIELD_FT * FT, az=-G0, vn_gps=8.0, rho=first["rho"],
                  mach=8.0 / 340.0, psi=first["psi"])
    n_ground = int(20 * RATE)
    blocks = [({c: np.full(n_ground, ground[c]) for c in cols}, None, 1.0)]
    blocks.append((_blend(ground, first, int(20 * RATE)), None, 0.0))
    for i, piece in enumerate(pieces):
        blocks.append((piece, types[i], 0.0))
        last = {c: piece[c][-1] for c in cols}
        nxt = {c: pieces[i + 1][c][0] for c in cols} if i + 1 < len(pieces) else last
        blocks.append((_blend(last, nxt, int(15 * RATE)), None, 0.0))
    truth = {c: np.concatenate([b[0][c] for b in blocks]) for c in cols}
    wow = np.concatenate([np.full(len(b[0]["tas"]), b[2]) for b in blocks])
    n = wow.size
    t = 1000.0 + np.arange(n) / RATE  # the recorder's clock does not start at zero
    start = 0
    maneuvers = []
    for b, typ, _ in blocks:
        k = len(b["tas"])
        if typ is not None:
            maneuvers.append((t[start], t[start + k - 1], typ))
        start += k
    # the truth of what the import must derive
    fuel_lb = BURN_LB_S * (t - t[0])
    mass = (RAMP_LB - fuel_lb) * LB
    temp = atmosphere.isa_temperature(truth["h"])
    pressure = atmosphere.isa_pressure(truth["h"])
    tas = truth["tas"]
    mach = tas / atmosphere.speed_of_sound(temp)
    # calibrated airspeed giving this Mach at this pressure (inverse St Venant)
    qc = pressure * ((1 + 0.2 * mach ** 2) ** 3.5 - 1)
    a0 = float(atmosphere.speed_of_sound(atmosphere.T0))
    cas = a0 * np.sqrt(5 * ((qc / atmosphere.P0 + 1) ** (2 / 7) - 1))
    north = np.concatenate([[0.0], np.cumsum(0.5 * (truth["vn_gps"][1:] + truth["vn_gps"][:-1]))
                            / RATE])
    east = np.concatenate([[0.0], np.cumsum(0.5 * (truth["ve_gps"][1:] + truth["ve_gps"][:-1]))
                           / RATE])
    s2 = math.sin(LAT0) ** 2
    r_n = 6378137.0 * (1 - 6.69437999014e-3) / (1 - 6.69437999014e-3 * s2) ** 1.5
    r_e = 6378137.0 / math.sqrt(1 - 6.69437999014e-3 * s2)
    lat = LAT0 + north / r_n
    lon = LON0 + east / (r_e * math.cos(LAT0))
    OUT.mkdir(exist_ok=True)
    channels = {
        "vane_aoa": np.degrees(truth["alpha"]), "ias": cas / KT, "hp": truth["h"] / FT,
        "roll_rate": np.degrees(truth["p"]), "pitch_rate": np.degrees(truth["q"]),
        "yaw_rate": np.degrees(truth["r"]), "roll_angle": np.degrees(truth["phi"]),
        "pitch_angle": np.degrees(truth["theta"]),
        "ax_g": truth["ax"] / G0, "ay_g": truth["ay"] / G0, "an_g": -truth["az"] / G0,
        "delta_a": np.degrees(truth["da"]), "delta_r": np.degrees(truth["dr"]),
        "sat": temp - 273.15, "fuel_used": fuel_lb, "gps_lat": np.degrees(lat),
        "gps_lon": np.degrees(lon), "wow": wow,
        # fuel flow per engine [lbs/hr], as the Citation's lh/rh_engine_FMF channels
        "lh_engine_FMF": np.full(n, FLOW_SHARE * BURN_LB_S * 3600.0),
        "rh_engine_FMF": np.full(n, (1 - FLOW_SHARE) * BURN_LB_S * 3600.0),
    }
    for name, v in channels.items():
        np.savetxt(OUT / f"{name}.txt", np.column_stack([t, v]), fmt=["%.2f", "%.8g"],
                   header=f"time {name}", comments="")
    np.savetxt(OUT / "delta_e.txt", np.degrees(truth["de"]), fmt="%.8g")  # no time stamps
    (OUT / "heading.txt").write_text("")  # the heading channel exists but is empty
    pd.DataFrame(maneuvers, columns=["start", "end", "type"]).to_csv(
        OUT / "maneuvers.csv", index=False, float_format="%.2f")
    tru = pd.DataFrame({"t_record": t, "wow": wow, **{c: truth[c] for c in cols}})
    tru["mass"] = mass
    for axis in "xyz":
        tru[f"I{axis * 2}"] = mass * RADII_M[axis] ** 2
    tru["isa_rho"] = atmosphere.density(pressure, temp)
    tru["lat"], tru["lon"] = lat, lon
    tru.to_csv(OUT / "truth.csv", index=False, float_format="%.10g")
    print(f"{OUT}: {n} samples ({n / RATE:.0f} s), maneuvers {types}")


if __name__ == "__main__":
    main()
