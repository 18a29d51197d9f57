"""Import -> reconstruct -> identify on a simulated real-like record (issue 16).

Simulates an f16 campaign with the sensors of a real installation
(:meth:`SensorModel.real_like`: noise and biases, vanes on a nose boom with scale and offset
errors, an IMU lever arm, channel lags) in a steady wind per maneuver plus JSBSim's
turbulence, writes it as a real-format record (:func:`write_channel_record`: one text file
per channel at 10 Hz in aviation units, no sideslip vane, an empty heading channel, GPS
latitude and longitude only, indicated airspeed, the normal load factor, fuel used), adds
the installation to the mapping file (``[metadata] sensor_geometry``: vane positions and
calibrations, IMU position; *not* the lags, which the reconstruction estimates), imports
it with :func:`import_record`, reconstructs and identifies with default settings, and
prints Markdown tables:

1. reconstructed alpha, beta and V: RMS error against the truth next to the raw sensor's
   error (noise, bias, geometry, lag), and the lags estimated and undone;
2. the estimated wind per maneuver against the truth (the steady part and the turbulence:
   ``true_wind_*`` is JSBSim's total wind), with the maneuver's heading change;
3. per coefficient: RMS of the reconstructed coefficient against the truth, ``b/n`` (the
   largest per-maneuver mean error over the within-maneuver standard deviation of the
   error), and after identification the validation model's RMS against the truth over the
   noise (``true/noise``), the same at the true states (the model's own error, without
   that of the reconstructed states it is evaluated at; body rates relative to the air,
   as the aerodynamics see them in turbulence) and R2.

Usage::

    python benchmarks/bench_real_like.py                       # 12 maneuvers, seed 11, light
    python benchmarks/bench_real_like.py --maneuvers 6 --turbulence none --no-identify
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from bench_generalization import rms_at_true_inputs

from simplexspline.aero import identify, import_record, reconstruct
from simplexspline.sim import Campaign, ConditionGrid, FlightProtocol, SensorModel
from simplexspline.sim.record_export import write_channel_record
from simplexspline.sim.wind import Wind

COEF = ("CX", "CY", "CZ", "Cl", "Cm", "Cn")
TRUTH = ("alpha", "beta", "tas", "psi", "wind_n", "wind_e", "wind_d", *COEF,
         # the model inputs' truth (bench_generalization.true_inputs)
         "mach", "rho", "p", "q", "r", "p_aero", "q_aero", "r_aero", "de", "da", "dr")


def _rms(x) -> float:
    return float(np.sqrt(np.nanmean(np.square(np.asarray(x, dtype=float)))))


def _toml_vector(v) -> str:
    return "[" + ", ".join(f"{float(x):.6g}" for x in v) + "]"


def installation(sensors: SensorModel, lags: bool = False) -> str:
    """``[metadata.sensor_geometry]`` of the sensors' installation, with the lags if asked."""
    lines = []
    if lags:
        lines += ["[metadata.sensor_geometry.lag_s]"]
        lines += [f"{c} = {float(v):.6g}" for c, v in sensors.lag_s.items() if v] + [""]
    for vane in ("alpha_vane", "beta_vane"):
        g = getattr(sensors, vane)
        lines += [f"[metadata.sensor_geometry.{vane}]",
                  f"position_m = {_toml_vector(g['position_m'])}",
                  f"scale = {float(g['scale']):.6g}",
                  f"offset_rad = {float(g['offset_rad']):.6g}", ""]
    lines += ["[metadata.sensor_geometry.imu]",
              f"position_m = {_toml_vector(sensors.imu_position_m)}", ""]
    return "\n".join(lines)


def thrust_in_truth(df: pd.DataFrame) -> pd.DataFrame:
    """The campaign with the thrust added to the true coefficients, in place: a record
    without a thrust channel measures the forces with the thrust in them and the moments
    with its moments about the c.g. (an engine's thrust line off the c.g. pitches: on the
    f16 1e-3 of Cm, the size of its noise), and the truth to judge those coefficients by is
    the same sum."""
    if "thrust_x" not in df.columns:
        return df
    force = df["true_qbar"] * df.attrs["S"]
    for c, column, length in (("CX", "thrust_x", 1.0), ("CY", "thrust_y", 1.0),
                              ("CZ", "thrust_z", 1.0), ("Cl", "thrust_l", df.attrs["b"]),
                              ("Cm", "thrust_m", df.attrs["cbar"]),
                              ("Cn", "thrust_n", df.attrs["b"])):
        df["true_" + c] = df["true_" + c] + df[column] / (force * length)
    return df


def with_truth(data: pd.DataFrame, truth_csv: Path, columns=TRUTH) -> pd.DataFrame:
    """The imported table with ``true_*`` columns (of ``columns``) from the record's truth
    file, matched by time."""
    truth = pd.read_csv(truth_csv)
    key = np.round(truth["t_record"].to_numpy() * 100).astype(np.int64)
    pos = pd.Series(np.arange(len(truth)), index=key)
    rows = pos.reindex(np.round(data["t_record"].to_numpy() * 100).astype(np.int64))
    if rows.isna().any():
        raise RuntimeError("imported samples without a truth sample at the same time")
    out = data.copy()
    for c in columns:
        if c in truth:
            out["true_" + c] = truth[c].to_numpy()[rows.to_numpy(dtype=np.int64)]
    out.attrs = data.attrs
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maneuvers", type=int, default=12)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--turbulence", default="light",
                    help="JSBSim MIL-F-8785C turbulence on top of the steady wind: none, "
                         "light (default: real flights always meet some), moderate, severe; "
                         "the filter finds the gusts (docs/reconstruction.md, turbulence)")
    ap.add_argument("--turn-fraction", type=float, default=1.0,
                    help="fraction of the sum-of-sines maneuvers flown in a turn (1.0)")
    ap.add_argument("--no-identify", action="store_true", help="stop after the reconstruction")
    ap.add_argument("--give-lags", action="store_true",
                    help="give the channel lags in the mapping file (default: estimated)")
    ap.add_argument("--no-installation", action="store_true",
                    help="leave the installation out of the mapping file (vane positions and "
                         "calibrations, IMU position: a user who knows none of them); the "
                         "reconstruction then estimates the vanes' positions along x")
    ap.add_argument("--keep", type=Path, default=None,
                    help="write the record into this new directory and keep it")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    sensors = SensorModel.real_like()
    t0 = time.perf_counter()
    df = Campaign("f16", maneuvers=args.maneuvers, seed=args.seed, sensors=sensors,
                  wind=Wind((5.0, 12.0), args.turbulence),
                  grid=ConditionGrid(altitudes_m=[3000.0, 7000.0],
                                     airspeeds_mps=[160.0, 220.0]),
                  protocol=FlightProtocol(mix={"3211": 2, "doublet": 1, "sum-of-sines": 2},
                                          sos_duration_s=(30.0, 40.0),
                                          turn_fraction=args.turn_fraction)).run(
        workers=args.workers, progress=False)
    t_sim = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as tmp:
        record = write_channel_record(thrust_in_truth(df), args.keep or Path(tmp) / "record",
                                      rate_hz=10.0)
        mapping = record / "mapping.toml"
        if not args.no_installation:
            mapping.write_text(mapping.read_text() + "\n"
                               + installation(sensors, args.give_lags))
        t0 = time.perf_counter()
        imported = import_record(mapping)
        t_import = time.perf_counter() - t0
        data = with_truth(imported.data, record / "truth.csv")
    print(f"campaign: f16, {args.maneuvers} maneuvers, seed {args.seed}, "
          f"SensorModel.real_like(), wind 5-12 m/s + {args.turbulence} turbulence "
          f"({t_sim:.0f} s); record at 10 Hz, imported: {data['maneuver'].nunique()} "
          f"maneuvers, {len(data):,} samples ({t_import:.1f} s); channels missing: "
          f"{', '.join(c for c in ('beta', 'psi', 'vn_gps') if c not in data)}\n")

    t0 = time.perf_counter()
    rec = reconstruct(data, workers=args.workers)
    t_rec = time.perf_counter() - t0
    d = rec.data
    print(f"reconstruct: {len(rec.maneuvers)} maneuvers, rejected {len(rec.rejected)}, "
          f"{t_rec:.0f} s; lags undone: "
          + (", ".join(f"{c} {v:.3f} s" for c, v in rec.lags_applied.items()) or "none")
          + " (simulated: " + ", ".join(f"{c} {v:g} s" for c, v in sensors.lag_s.items() if v)
          + ")\n")
    print("| quantity | raw sensor RMS error | raw error std | reconstructed RMS error | "
          "reconstructed error std |")
    print("|---|---|---|---|---|")
    for c, unit in (("alpha", "rad"), ("beta", "rad"), ("tas", "m/s")):
        raw = (data[c] - data["true_" + c]) if c in data else None
        raw_cells = ("no sensor | -" if raw is None
                     else f"{_rms(raw):.2e} {unit} | {raw.std():.2e} {unit}")
        e = d[c] - d["true_" + c]
        print(f"| {c} | {raw_cells} | {_rms(e):.2e} {unit} | {e.std():.2e} {unit} |")
    cal = d.attrs["reconstruction"]["air_data_calibration"]
    print("\ncampaign air-data calibration (value, sigma): "
          + (", ".join(f"{k} {v[0]:.3g} +- {v[1]:.2g}" for k, v in cal.items()) or "none")
          + f"\nturbulence: {rec.sensors()['gusts']}\n")

    print("\n| maneuver | type | heading change [deg] | wind [m/s] | horizontal wind "
          "error [m/s] | mean wind error [m/s] | vertical [m/s] | reported sigma n, e [m/s] | "
          "wind statement | gusts [m/s, m] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    errs, mean_errs = {}, {}
    for m, g in d.groupby("maneuver"):
        e = (g[["wind_n", "wind_e", "wind_d"]].to_numpy()
             - g[["true_wind_n", "true_wind_e", "true_wind_d"]].to_numpy())
        h = _rms(np.hypot(e[:, 0], e[:, 1]))
        errs[m] = h
        # the maneuver's mean wind (steady part) against the true mean: what a wind
        # estimate is judged by when the turbulence itself is not tracked
        mean_errs[m] = float(np.hypot(*e[:, :2].mean(axis=0)))
        obs = rec.maneuvers[m]["observability"]["wind"]
        turn = math.degrees(np.ptp(np.unwrap(g["true_psi"].to_numpy())))
        sig = rec.maneuvers[m]["biases"]
        print(f"| {m} | {g['maneuver_type'].iloc[0]} | {turn:.0f} | "
              f"{math.hypot(g['true_wind_n'].mean(), g['true_wind_e'].mean()):.1f} | "
              f"{h:.2f} | {mean_errs[m]:.2f} | {_rms(e[:, 2]):.2f} | "
              f"{sig['wind_n'][1]:.2f}, {sig['wind_e'][1]:.2f} | "
              f"{'WEAK' if 'WEAK' in obs else 'estimated'} | "
              + (f"{gu['std']:g}, {gu['length_m']:g}" if (gu := rec.maneuvers[m]['gusts'])['std']
                 else "still air") + " |")
    weak = [m for m in errs if "WEAK" in rec.maneuvers[m]["observability"]["wind"]]
    ok = [m for m in errs if m not in weak]
    for label, ms in (("turning (estimated)", ok), ("straight (WEAK)", weak)):
        if ms:
            print(f"\nhorizontal wind error, {label}: median {np.median([errs[m] for m in ms]):.2f}"
                  f" m/s, max {max(errs[m] for m in ms):.2f} m/s over {len(ms)} maneuvers; "
                  f"mean wind: median {np.median([mean_errs[m] for m in ms]):.2f} m/s, max "
                  f"{max(mean_errs[m] for m in ms):.2f} m/s")

    print("\n| coefficient | reconstructed RMS vs truth | b/n | identified: RMS vs truth | "
          "noise RMS | true/noise | at the true states / noise | R2 |")
    print("|---|---|---|---|---|---|---|---|")
    ident = {}
    t_id = float("nan")
    if not args.no_identify:
        t0 = time.perf_counter()
        result = identify(data)
        t_id = time.perf_counter() - t0
        ident = result.summary()["coefficients"]
    for c in COEF:
        e = d[c] - d["true_" + c]
        if e.isna().all():
            print(f"| {c} | n/a | | | | | | |")
            continue
        grp = e.groupby(d["maneuver"])
        bn = float(np.max(np.abs(grp.mean())) / np.sqrt(np.mean(grp.var())))
        i = ident.get(c, {})
        fmt = (lambda k, s: "-" if i.get(k) is None else format(i[k], s))
        at_truth = (rms_at_true_inputs(result, c) / i["noise_rms"]
                    if i.get("noise_rms") else float("nan"))
        print(f"| {c} | {_rms(e):.2e} | {bn:.1f} | {fmt('rms_true', '.2e')} | "
              f"{fmt('noise_rms', '.2e')} | {fmt('rms_true_over_noise', '.2f')} | "
              f"{at_truth:.2f} | {fmt('r2', '.3f')} |")
    if ident:
        print("\nmodels: " + "; ".join(r.model.structure.label()
                                      for r in result.results.values()))
    if ident and "beta_side_force" in result.validation.columns:
        both = pd.concat([result.identification, result.validation])
        side = both["beta_side_force"] != both["beta"]
        print(f"\nsideslip from the side force (identify, {int(side.sum()):,} samples with "
              f"gusts): RMS error {_rms((both['beta_side_force'] - both['true_beta'])[side]):.2e}"
              f" rad against the kinematic {_rms((both['beta'] - both['true_beta'])[side]):.2e}"
              f" rad there")
    print(f"\nseconds: simulate {t_sim:.0f}, import {t_import:.1f}, reconstruct {t_rec:.0f}, "
          f"identify {t_id:.0f}")


if __name__ == "__main__":
    main()
