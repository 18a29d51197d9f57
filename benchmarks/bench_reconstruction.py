"""Flight path reconstruction benchmark (issue 5): speed and the acceptance tables.

Simulates (or reads) an f16 campaign with the default sensor noise and biases, reconstructs
it (IEKF + RTS per maneuver, in parallel) and prints

1. the real-time factor: seconds of flight per second of wall time (target >= 50x, i.e.
   about 10,000 s of flight in <= 200 s on 2 cores), and CPU seconds per flight second;
2. estimated biases against the true ones: per channel the true bias, the median estimate,
   the median standard deviation, the fraction of maneuvers within 3 sigma and the largest
   |error| / sigma;
3. RMS errors of reconstructed alpha, beta, V, phi, theta against the raw sensor errors;
4. RMS and relative RMS (RMS / range of the true coefficient) of CX .. Cn against the
   ``true_`` columns, with measured and with differentiated angular accelerations.

Usage::

    python benchmarks/bench_reconstruction.py                     # 250 maneuvers (~10,000 s)
    python benchmarks/bench_reconstruction.py --maneuvers 30      # a quick subset
    python benchmarks/bench_reconstruction.py --input campaign.parquet
"""

from __future__ import annotations

import argparse
import os
import resource
import time

import numpy as np
import pandas as pd

from simplexspline.aero import ReconstructionSettings, aerodynamic_coefficients, reconstruct
from simplexspline.aero.data.flight_data import read_flight_data
from simplexspline.sim import Campaign

IMU = ("ax", "ay", "az", "p", "q", "r")
AIR = ("alpha", "beta", "tas")
COEF = ("CX", "CY", "CZ", "Cl", "Cm", "Cn")


def _flight_time(df) -> float:
    g = df.groupby("maneuver")["t"]
    return float((g.max() - g.min()).sum())


def bias_table(rec, true_bias: dict) -> pd.DataFrame:
    bt = rec.bias_table()
    rows = {}
    for ch in IMU + AIR:
        z = (bt[ch] - true_bias.get(ch, 0.0)) / bt[ch + "_sigma"]
        rows[ch] = {"true": true_bias.get(ch, 0.0), "median estimate": bt[ch].median(),
                    "median sigma": bt[ch + "_sigma"].median(),
                    "within 3 sigma": float((z.abs() < 3).mean()),
                    "max |err|/sigma": float(z.abs().max())}
    return pd.DataFrame.from_dict(rows, orient="index")


def _outliers(rec, true_bias: dict, df) -> pd.DataFrame:
    bt = rec.bias_table()
    z = pd.DataFrame({ch: (bt[ch] - true_bias.get(ch, 0.0)) / bt[ch + "_sigma"]
                      for ch in IMU + AIR})
    bad = z[(z.abs() > 3).any(axis=1)]
    info = df.groupby("maneuver").agg(
        type=("maneuver_type", "first"), duration=("t", "max"),
        max_abs_phi=("true_phi", lambda x: float(np.abs(x).max())),
        max_nz=("true_az", lambda x: float(-x.min() / 9.81)))
    return pd.concat([bad.round(1), info.loc[bad.index]], axis=1)


def state_table(raw, rec_data) -> pd.DataFrame:
    rows = {}
    raw = raw.loc[raw["maneuver"].isin(rec_data["maneuver"].unique())]
    for ch in ("alpha", "beta", "tas", "phi", "theta"):
        rows[ch] = {
            "RMS reconstructed": float(np.sqrt(np.mean((rec_data[ch] - rec_data["true_" + ch])
                                                       ** 2))),
            "RMS raw sensor": float(np.sqrt(np.mean((raw[ch] - raw["true_" + ch]) ** 2))),
            "raw noise std": float(np.std(raw[ch] - raw["true_" + ch])),
        }
    return pd.DataFrame.from_dict(rows, orient="index")


def coefficient_table(data, coef) -> pd.DataFrame:
    rows = {}
    for c in COEF:
        truth = data["true_" + c].to_numpy()
        rms = float(np.sqrt(np.mean((coef[c].to_numpy() - truth) ** 2)))
        span = float(truth.max() - truth.min())
        rows[c] = {"RMS": rms, "range": span, "relative RMS %": 100 * rms / span}
    return pd.DataFrame.from_dict(rows, orient="index")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--maneuvers", type=int, default=250)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--input", default=None, help="read this campaign instead of simulating")
    args = ap.parse_args()

    if args.input:
        df, _ = read_flight_data(args.input, nan="ignore")
    else:
        t0 = time.perf_counter()
        df = Campaign("f16", maneuvers=args.maneuvers, seed=args.seed).run(
            workers=args.workers, progress=False)
        print(f"simulated {df['maneuver'].nunique()} maneuvers in "
              f"{time.perf_counter() - t0:.1f} s")
    sensors = df.attrs.get("simulator", {}).get("sensors", {})
    true_bias = {k: float(v) for k, v in sensors.get("bias", {}).items()}
    flight = _flight_time(df)

    cpu0 = os.times()
    t0 = time.perf_counter()
    rec = reconstruct(df, workers=args.workers)
    wall = time.perf_counter() - t0
    cpu1 = os.times()
    cpu = (cpu1.user - cpu0.user) + (cpu1.children_user - cpu0.children_user) + \
        (cpu1.system - cpu0.system) + (cpu1.children_system - cpu0.children_system)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\n1. speed: {len(df):,} samples, {flight:,.0f} s of flight, "
          f"{df['maneuver'].nunique()} maneuvers, {args.workers} workers")
    print(f"   reconstruction + coefficients: {wall:.1f} s wall "
          f"({flight / wall:.0f}x real time), {cpu:.0f} CPU s "
          f"({1e6 * cpu / len(df):.0f} CPU us per sample); peak RSS of this process "
          f"{peak:,.0f} MB; load average {os.getloadavg()[0]:.1f}")
    print(f"   accepted {len(rec.maneuvers)}, rejected {len(rec.rejected)}")
    for m, why in sorted(rec.rejected.items()):
        print(f"     maneuver {m}: {why}")

    pd.set_option("display.width", 120)
    print("\n2. biases (estimate per maneuver vs the simulator's true bias)")
    print(bias_table(rec, true_bias).to_string(float_format="%.4g"))
    outliers = _outliers(rec, true_bias, df)
    if len(outliers):
        print("   maneuvers with a bias beyond 3 sigma:")
        print(outliers.to_string(float_format="%.3g"))
    print("\n3. reconstructed states vs truth (raw sensor error for comparison)")
    print(state_table(df, rec.data).to_string(float_format="%.3g"))
    print("\n4. coefficients vs true_ (measured pdot, qdot, rdot: the simulated sensor)")
    coef_m, thrust = aerodynamic_coefficients(rec.data, accelerations="measured")
    print(coefficient_table(rec.data, coef_m).to_string(float_format="%.3g"))
    print(f"   thrust subtracted: {thrust}")
    s = ReconstructionSettings()
    print(f"\n   ... with pdot, qdot, rdot from smoothed differentiation of the reconstructed "
          f"rates (m = {s.diff_half_window or 'the default for the rate'}, degree {s.diff_degree})")
    coef_d, _ = aerodynamic_coefficients(rec.data, accelerations="differentiate",
                                         half_window=s.diff_half_window,
                                         degree=s.diff_degree)
    print(coefficient_table(rec.data, coef_d).to_string(float_format="%.3g"))


if __name__ == "__main__":
    main()
