"""A whole flight-test sortie, as a real record arrives, through import and identify (issue 16).

The rehearsal of the check on a real Citation II record: one continuous flight of a
twin-jet business aircraft (``global5000`` by default) through several test points
(:class:`~simplexspline.sim.whole_flight.WholeFlight`: 3211s, doublets and sums of sines
in all three axes flown from steady flight, with turns, climbs and speed changes between
them), the sensors of a real installation (:meth:`SensorModel.real_like`), one steady wind
and light turbulence, written at 10 Hz as one text file per channel in aviation units
(:func:`write_channel_record`: no sideslip vane, an empty heading channel, GPS latitude and
longitude only, no thrust, fuel used in lbs, taxiing on the ground at both ends). Then,
per variant of the mapping file:

* ``excitation``: no maneuver list: ``[segments] method = "excitation"`` (a user without
  a maneuver log; the import also cuts the turns between the detected maneuvers);
* ``list``: the flight-test engineer's maneuver list (``maneuvers.csv``; with ``--turns``
  it also logs the turns between the maneuvers, as the real record's list did: without a
  heading channel they are what observes the wind);

``import_record`` and ``identify`` with default settings (identify reconstructs), and the
derivatives of the identified models (``CL_alpha``, ``Cm_alpha``) against the simulator's
truth (a least-squares fit of the true coefficients over the flown maneuvers). Prints one
Markdown table.

With ``--design eigenmotion`` the sortie is a flight-test course's instead (the design of
the real training-flight records): a stationary measurement at each of six airspeeds at one
altitude (trimmed straight flight, 60-90 s, logged as maneuvers), and between them single
pulses and doublets at small amplitudes with long free responses (phugoid, short period,
aperiodic roll, Dutch roll: :meth:`FlightProtocol.eigenmotion`); no 3211s, no sums of
sines.

Usage::

    python benchmarks/bench_whole_flight.py                         # 24 maneuvers, seed 1
    python benchmarks/bench_whole_flight.py --design eigenmotion --maneuvers 12
    python benchmarks/bench_whole_flight.py --maneuvers 30 --variants excitation
    python benchmarks/bench_whole_flight.py --aircraft c172p --seed 5 --installation
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

from simplexspline.aero import identify, import_record
from simplexspline.aero.derivatives import derivatives
from simplexspline.sim import (FlightProtocol, SensorModel, Wind, get_aircraft,
                               write_channel_record)
from simplexspline.sim.whole_flight import WholeFlight

from bench_real_like import installation, thrust_in_truth, with_truth

COEF = ("CX", "CY", "CZ", "Cl", "Cm", "Cn")
TRUTH = ("alpha", "beta", "tas", *COEF)


def course_legs(aircraft: str, n: int = 6) -> list:
    """A flight-test course's stationary series: ``n`` airspeeds evenly spread between the
    profile's second and second-to-last grid airspeed, fastest first, at the grid altitude
    a third up (no aircraft constant)."""
    profile = get_aircraft(aircraft)
    alts, speeds = sorted(profile.altitudes_m), sorted(profile.airspeeds_mps)
    lo, hi = speeds[min(1, len(speeds) - 1)], speeds[max(0, len(speeds) - 2)]
    return [(alts[len(alts) // 3], float(v)) for v in np.linspace(hi, lo, n)]


def _rms(x) -> float:
    return float(np.sqrt(np.nanmean(np.square(np.asarray(x, dtype=float)))))


def true_slopes(df: pd.DataFrame, segments: list) -> dict:
    """CL_alpha and Cm_alpha of the simulator: least squares of the true coefficients over
    the flown maneuvers on 1, alpha, de, qhat, alphadot_hat, Mach and de*Mach."""
    t = df["t"].to_numpy()
    keep = np.zeros(len(df), bool)
    for s in segments:
        if s["type"] not in ("steady", "turn", "transition"):
            keep |= (t >= s["start_s"]) & (t <= s["end_s"])
    g = df[keep]
    a, v = g["true_alpha"].to_numpy(), g["true_tas"].to_numpy()
    c = df.attrs["cbar"]
    adot = np.gradient(df["true_alpha"].to_numpy(), t)[keep]
    mach, de = g["true_mach"].to_numpy(), g["true_de"].to_numpy()
    x = np.column_stack([np.ones_like(a), a, de, g["true_q"].to_numpy() * c / (2 * v),
                         adot * c / (2 * v), mach, de * mach])
    out = {}
    for name in ("CL", "Cm"):
        beta = np.linalg.lstsq(x, g[f"true_{name}"].to_numpy(), rcond=None)[0]
        out[f"{name}_alpha"] = float(beta[1])
    return out


def lift_slope(models, at: pd.DataFrame) -> np.ndarray:
    """dCL/dalpha of the CX and CZ models, CL = CX sin(alpha) - CZ cos(alpha)."""
    d = derivatives(models, at, wrt=["alpha"], outside="extrapolate")
    a = d["alpha"].to_numpy()
    cx = models["CX"].predict(d)
    cz = models["CZ"].predict(d)
    return (d["CX_alpha"].to_numpy() * np.sin(a) + cx * np.cos(a)
            - d["CZ_alpha"].to_numpy() * np.cos(a) + cz * np.sin(a))


def match(found: list, flown: list) -> dict:
    """Found segments against flown maneuvers (record time spans)."""
    hit = [False] * len(flown)
    spurious, merged = 0, 0
    for a, b in found:
        cover = [max(0.0, min(b, e) - max(a, s)) for s, e in flown]
        inside = [i for i, (s, e) in enumerate(flown) if cover[i] > 0.5 * (e - s)]
        for i in inside:
            hit[i] = True
        if sum(cover) < 0.2 * (b - a):
            spurious += 1
        if len(inside) > 1:
            merged += 1
    return {"found": len(found), "flown": len(flown), "detected": sum(hit),
            "spurious": spurious, "merged": merged}


def run_variant(record: Path, variant: str, flown: list, legs: list, truth: dict) -> dict:
    mapping = record / f"mapping-{variant}.toml"
    text = (record / "mapping.toml").read_text()
    if variant == "excitation":
        text = text.replace('method = "list"\nlist = "maneuvers.csv"',
                            'method = "excitation"')
    mapping.write_text(text)
    out = {"variant": variant}
    t0 = time.perf_counter()
    imported = import_record(mapping)
    out["t_import"] = time.perf_counter() - t0
    data = with_truth(imported.data, record / "truth.csv", TRUTH)
    found = [(g["t_record"].iloc[0], g["t_record"].iloc[-1])
             for _, g in data.groupby("maneuver")]
    out["match"] = match(found, flown)
    out["raw"] = {c: _rms(data[c] - data["true_" + c]) for c in ("alpha", "tas")}
    t0 = time.perf_counter()
    try:
        res = identify(data)
    except Exception as exc:  # the point of the rehearsal: say what broke
        out["error"] = f"{type(exc).__name__}: {exc}"
        out["t_identify"] = time.perf_counter() - t0
        return out
    out["t_identify"] = time.perf_counter() - t0
    rec = pd.concat([res.identification, res.validation])
    out["rejected"] = len((res.provenance["reconstruction"] or {}).get("rejected") or {})
    out["thrust_subtracted"] = (res.provenance["reconstruction"] or {}).get(
        "thrust_subtracted")
    out["rec"] = {c: _rms(rec[c] - rec["true_" + c]) for c in ("alpha", "beta", "tas")}
    whole = res.summary()
    summ = whole["coefficients"]
    # which maneuvers validate (the split follows envelope cells in alpha, beta and Mach,
    # so a change of the reconstruction can move it, and with it every R2 on a sparse course)
    kinds = rec.groupby("maneuver")["maneuver_type"].first() \
        if "maneuver_type" in rec.columns else None
    out["validation"] = ", ".join(
        f"{m}" + ("" if kinds is None else f" ({kinds.loc[m]})")
        for m in whole["validation_maneuvers"]) + "".join(
        f"; {c} left out {m}" for c, m in whole["left_out_validation_maneuvers"].items())
    # R2 on the whole validation (a left-out maneuver's prediction included); the error
    # against the truth of the delivered model, on the maneuvers it never saw ('shared')
    out["coef"] = {c: {k: summ[c].get(k) for k in ("r2", "rms_true_over_noise", "label")}
                   | {"excited": summ[c].get("diagnostics", {}).get("excitation", {})
                      .get("excited"), "left_out": "left_out" in summ[c]}
                   | ({"rms_true_over_noise": summ[c]["shared"]["rms_true_over_noise"]}
                      if "shared" in summ[c] else {}) for c in summ}
    out["warnings"] = list(res.warnings)
    models = {c: r.model for c, r in res.results.items()}
    t0 = time.perf_counter()
    ref = derivatives(models, wrt=["alpha"])
    at = []
    ident = res.identification
    hv = np.column_stack([ident["h"] / 1000.0, ident["tas"] / 20.0])
    centres = np.array([[h / 1000.0, v / 20.0] for h, v in legs])
    leg = np.argmin(((hv[:, None, :] - centres[None]) ** 2).sum(-1), axis=1)
    for k in range(len(legs)):
        g = ident[leg == k]
        if len(g):
            at.append({v: float(np.median(g[v])) for v in g.columns
                       if v in ("alpha", "mach", "de", "tas", "h", "rho", "mass")}
                      | {"beta": 0.0, "da": 0.0, "dr": 0.0})
    at = pd.DataFrame(at)
    out["Cm_alpha"] = [float(ref["Cm_alpha"].iloc[0])] + derivatives(
        models, at, wrt=["alpha"], outside="extrapolate")["Cm_alpha"].tolist() \
        if "Cm" in models else None
    if "CX" in models and "CZ" in models:
        out["CL_alpha"] = lift_slope(models, ref).tolist()[:1] + lift_slope(models, at).tolist()
    out["t_derivatives"] = time.perf_counter() - t0
    # identify's own: at the identification data's medians, with the jackknife's errors
    jack = res.derivatives
    out["jackknife"] = {} if jack is None else {
        n: (float(jack.loc[n, "value"]), float(jack.loc[n, "standard_error"]))
        for n in ("CL_alpha", "Cm_alpha") if n in jack.index}
    out["truth"] = truth
    return out


def table(results: list, sim: dict) -> str:
    cols = [r["variant"] for r in results]
    lines = ["| | " + " | ".join(cols) + " |", "|---" * (len(cols) + 1) + "|"]

    def row(name, f):
        cells = []
        for r in results:
            try:
                cells.append(f(r))
            except (KeyError, TypeError, IndexError):
                cells.append("-")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")

    row("maneuvers found / flown (detected, spurious, merged)",
        lambda r: "{found} / {flown} ({detected}, {spurious}, {merged})".format(**r["match"]))
    row("identify", lambda r: r.get("error", "ran to the end"))
    row("maneuvers rejected by the reconstruction", lambda r: str(r["rejected"]))
    row("validation maneuvers (type)", lambda r: r["validation"])
    for c, unit in (("alpha", "rad"), ("beta", "rad"), ("tas", "m/s")):
        row(f"{c} RMS error, reconstructed (raw) [{unit}]",
            lambda r, c=c: f"{r['rec'][c]:.2e}" + (f" ({r['raw'][c]:.2e})" if c in r["raw"]
                                                   else " (no sensor)"))
    for c in COEF:
        row(f"{c} validation R2 (RMS vs truth / noise)",
            lambda r, c=c: (f"{r['coef'][c]['r2']:.3f} ({r['coef'][c]['rms_true_over_noise']:.2f})"
                            + ("" if r["coef"][c]["excited"] else ", barely excited")
                            + (", one maneuver left out" if r["coef"][c]["left_out"] else "")))
    row("CL_alpha [1/rad] reference; per leg (truth "
        f"{sim['truth']['CL_alpha']:.2f})",
        lambda r: f"{r['CL_alpha'][0]:.2f}; " + ", ".join(f"{x:.2f}" for x in r["CL_alpha"][1:]))
    row(f"Cm_alpha [1/rad] reference; per leg (truth {sim['truth']['Cm_alpha']:.2f})",
        lambda r: f"{r['Cm_alpha'][0]:.2f}; " + ", ".join(f"{x:.2f}" for x in r["Cm_alpha"][1:]))
    row("CL_alpha, Cm_alpha [1/rad] at the identification data's medians +- jackknife "
        "standard error (identify's)",
        lambda r: "; ".join(f"{v:.2f} +- {se:.2f}" for v, se in
                            (r["jackknife"][n] for n in ("CL_alpha", "Cm_alpha"))))
    row("seconds: import, identify (reconstruct + search + fit), derivatives",
        lambda r: f"{r['t_import']:.1f}, {r['t_identify']:.0f}, {r['t_derivatives']:.1f}")
    return "\n".join(lines)


def fly_and_identify(aircraft: str, maneuvers: int, seed: int, turbulence: str,
                     design: str, variants, *, keep: Path | None = None,
                     installation_given: bool = False, turns: bool = False):
    """Fly one sortie or course, write it as a real-format record (into ``keep`` if given)
    and import and identify it per mapping variant: (results per variant, the
    WholeFlight, the simulated frame, the true slopes, the flown maneuvers' spans, the
    simulation's seconds)."""
    t0 = time.perf_counter()
    sensors = SensorModel.real_like()
    if design == "eigenmotion":
        plan = {"legs": course_legs(aircraft), "stationary_s": (60.0, 90.0),
                "protocol": FlightProtocol.eigenmotion()}
    else:
        plan = {"protocol": FlightProtocol(mix={"3211": 2, "doublet": 1, "sum-of-sines": 1},
                                           sos_duration_s=(30.0, 40.0))}
    flight = WholeFlight(aircraft, maneuvers=maneuvers, seed=seed, sensors=sensors,
                         wind=Wind((5.0, 12.0), turbulence), **plan)
    df = flight.run()
    t_sim = time.perf_counter() - t0
    segments = df.attrs["flight"]["segments"]
    truth = true_slopes(df, segments)   # the aerodynamic slopes: before the thrust
    thrust_in_truth(df)    # the record has no thrust: the truth holds it as the data do
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        record = write_channel_record(df, keep or Path(tmp) / "record", rate_hz=10.0,
                                      turns=turns)
        if installation_given:
            mapping = record / "mapping.toml"
            mapping.write_text(mapping.read_text() + "\n" + installation(sensors, False))
        spans = pd.read_csv(record / "maneuvers.csv")
        flown = list(zip(spans["start"], spans["end"]))
        for variant in variants:
            results.append(run_variant(record, variant.strip(), flown, flight.legs, truth))
    return results, flight, df, truth, flown, t_sim


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--aircraft", default="global5000")
    ap.add_argument("--maneuvers", type=int, default=24)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--turbulence", default="light")
    ap.add_argument("--variants", default="excitation,list",
                    help="comma-separated: excitation (no maneuver list), list")
    ap.add_argument("--keep", type=Path, default=None,
                    help="write the record into this new directory and keep it")
    ap.add_argument("--design", choices=("sortie", "eigenmotion"), default="sortie",
                    help="sortie: 3211s, doublets and sums of sines over four test points; "
                    "eigenmotion: a flight-test course (stationary series and eigenmotions)")
    ap.add_argument("--installation", action="store_true",
                    help="give the installation in the mapping file (vane positions and "
                    "calibrations, IMU position; not the lags), as bench_real_like does")
    ap.add_argument("--turns", action="store_true",
                    help="the maneuver list also logs the turns between maneuvers (type "
                    "'turn'), as the real Citation II record's list did; without a heading "
                    "channel they observe the wind")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    results, flight, df, truth, flown, t_sim = fly_and_identify(
        args.aircraft, args.maneuvers, args.seed, args.turbulence, args.design,
        args.variants.split(","), keep=args.keep, installation_given=args.installation,
        turns=args.turns)
    print(f"whole flight ({args.design}): {args.aircraft}, {len(flown)} maneuvers flown "
          f"(stationary measurements included), seed {args.seed}, "
          f"{df.attrs['flight']['duration_s'] / 60:.1f} min airborne, legs "
          + ", ".join(f"{h:g} m/{v:g} m/s" for h, v in flight.legs)
          + f"; SensorModel.real_like() (installation "
          + ("given" if args.installation else "not given") + "), steady wind "
          f"{math.hypot(*df.attrs['simulator']['wind']['drawn']['ned_mps'][:2]):.1f} m/s + "
          f"{args.turbulence} turbulence; simulated in {t_sim:.0f} s; the coefficients include "
          "the thrust and its moments (no thrust channel), their truth too\n")
    print(table(results, {"truth": truth}))
    for r in results:
        for w in r.get("warnings", []):
            print(f"\n[{r['variant']}] warning: {w}")


if __name__ == "__main__":
    main()
