"""Reconstruction with missing sensors, wind and sensor geometry (issues 16 and 19).

Simulates a small f16 campaign (or reads one), then reconstructs it once per sensor variant
(channels dropped from the table, as a real record would lack them) and prints a Markdown
table: RMS errors of the reconstructed alpha, beta and V against the ``true_*`` columns next
to the raw sensors' errors (noise plus bias plus geometry), the RMS error of the estimated
wind against ``true_wind_*`` (when the campaign flies in wind), and per coefficient the RMS
error against the truth and ``b/n``: the largest per-maneuver mean error (a per-maneuver
bias) divided by the within-maneuver standard deviation of the error (the noise).

Usage::

    python benchmarks/bench_missing_sensors.py                        # real-like, in wind
    python benchmarks/bench_missing_sensors.py --still --default-sensors
    python benchmarks/bench_missing_sensors.py --maneuvers 12 --variants "no GPS;all sensors"
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from simplexspline.aero import reconstruct
from simplexspline.sim import Campaign, ConditionGrid, FlightProtocol, SensorModel
from simplexspline.sim.wind import Wind

GPS = ["x_gps", "y_gps", "z_gps", "vn_gps", "ve_gps", "vd_gps"]
GPS_VEL = ["vn_gps", "ve_gps", "vd_gps"]
VARIANTS = {
    "all sensors": [],
    "all sensors, geometry not given": "nogeo",
    "no beta vane": ["beta"],
    "no heading": ["psi"],
    "GPS position only": GPS_VEL,
    "no beta, no heading, GPS position only": ["beta", "psi", *GPS_VEL],
    "no GPS": GPS,
    "no GPS, no beta vane": [*GPS, "beta"],
    "no accelerometers": ["ax", "ay", "az"],
}
COEF = ("CX", "CY", "CZ", "Cl", "Cm", "Cn")


def _rms(x) -> float:
    return float(np.sqrt(np.nanmean(np.square(np.asarray(x, dtype=float)))))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maneuvers", type=int, default=12)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--still", action="store_true", help="still air (default: 5-12 m/s wind)")
    ap.add_argument("--default-sensors", action="store_true",
                    help="default sensors at the c.g. (default: SensorModel.real_like())")
    ap.add_argument("--variants", default="", help="';'-separated subset of the variants")
    ap.add_argument("--tas-bias", type=float, default=None,
                    help="override the airspeed sensor's bias [m/s] (an experiment: how "
                         "much of the no-GPS coefficient bias is the airspeed bias)")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    sensors = SensorModel() if args.default_sensors else SensorModel.real_like()
    if args.tas_bias is not None:
        sensors = SensorModel(noise_std=sensors.noise_std, bias={**sensors.bias,
                                                                  "tas": args.tas_bias},
                              lag_s=sensors.lag_s, alpha_vane=sensors.alpha_vane,
                              beta_vane=sensors.beta_vane,
                              imu_position_m=sensors.imu_position_m)
    wind = None if args.still else Wind((5.0, 12.0), "none")
    t0 = time.time()
    df = Campaign("f16", maneuvers=args.maneuvers, seed=args.seed, sensors=sensors, wind=wind,
                  grid=ConditionGrid(altitudes_m=[3000.0, 7000.0],
                                     airspeeds_mps=[160.0, 220.0]),
                  protocol=FlightProtocol(mix={"3211": 2, "doublet": 1, "sum-of-sines": 2},
                                          sos_duration_s=(30.0, 40.0))).run(
        workers=args.workers, progress=False)
    print(f"campaign: f16, {df['maneuver'].nunique()} maneuvers, {len(df):,} samples, "
          f"{'still air' if wind is None else 'wind 5-12 m/s'}, "
          f"{'default' if args.default_sensors else 'real-like'} sensors"
          f"{'' if args.tas_bias is None else f' (airspeed bias {args.tas_bias} m/s)'}, "
          f"seed {args.seed} "
          f"({time.time() - t0:.0f} s)\n")
    names = [v for v in args.variants.split(";") if v] or list(VARIANTS)
    raw = {c: _rms(df[c] - df["true_" + c]) for c in ("alpha", "beta", "tas")}
    print("| variant | alpha [rad] | beta [rad] | V [m/s] | wind [m/s] | "
          + " | ".join(f"{c} RMS (b/n)" for c in COEF) + " | rejected | wall s |")
    print("|---" * (7 + len(COEF)) + "|")
    print("| raw sensors (noise, bias, geometry) | " + " | ".join(f"{raw[c]:.2e}" for c in raw)
          + " | - |" + " - |" * len(COEF) + " - | - |")
    for name in names:
        drop = VARIANTS[name]
        data = df.copy()
        data.attrs = dict(df.attrs)
        if drop == "nogeo":
            data.attrs.pop("sensor_geometry", None)
        else:
            data = data.drop(columns=drop)
        t0 = time.time()
        rec = reconstruct(data, workers=args.workers)
        wall = time.time() - t0
        d = rec.data
        err = [_rms(d[c] - d["true_" + c]) for c in ("alpha", "beta", "tas")]
        if "wind_n" in d and "true_wind_n" in d:
            e = (d[["wind_n", "wind_e", "wind_d"]].to_numpy()
                 - d[["true_wind_n", "true_wind_e", "true_wind_d"]].to_numpy())
            wind_cell = f"{_rms(np.linalg.norm(e, axis=1)):.2f}"
        elif "wind_n" in d:
            wind_cell = f"{_rms(np.linalg.norm(d[['wind_n', 'wind_e', 'wind_d']], axis=1)):.2f}"
        else:
            wind_cell = "held"
        cells = []
        for c in COEF:
            e = d[c] - d["true_" + c]
            if e.isna().all():
                cells.append("n/a")
                continue
            g = e.groupby(d["maneuver"])
            bias = float(np.max(np.abs(g.mean())))
            noise = float(np.sqrt(np.mean(g.var())))
            cells.append(f"{_rms(e):.1e} ({bias / noise:.1f})")
        print(f"| {name} | " + " | ".join(f"{x:.2e}" for x in err) + f" | {wind_cell} | "
              + " | ".join(cells) + f" | {len(rec.rejected)} | {wall:.0f} |", flush=True)


if __name__ == "__main__":
    main()
