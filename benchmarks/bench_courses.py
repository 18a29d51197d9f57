"""Validation R^2 and error against the truth over many flight-test courses (issue 16).

The check on a real Citation II record asks for a positive validation R^2 for every
coefficient that ``identify`` models. This runs that rehearsal on a set of simulated
flight-test courses (:func:`bench_whole_flight.fly_and_identify` with ``--design
eigenmotion --turns``: stationary measurements at six airspeeds, eigenmotion inputs, turns;
real-format 10 Hz records without a sideslip vane, heading or GPS velocities), five
aircraft, 6 and 12 test points, still air and light turbulence, seeds that the defaults
were not developed on, and both mapping variants (the maneuver list, and segments found
by excitation). Prints one row per course and variant, and the totals: negative R^2,
geometric mean of RMS vs truth / noise, CL_alpha and Cm_alpha at the reference condition
against the simulator's, and identify's jackknife standard errors of the two (at the
identification data's medians): how often the truth lies within two of them, and how
often a wrong sign of Cm_alpha goes unflagged (zero outside two standard errors); and the
reconstructed alpha, beta and airspeed's RMS errors against the truth (issue 16 asks
them below the raw sensors'), with how often the airspeed's is.

Usage::

    python benchmarks/bench_courses.py                # the 14 courses of stop 47 (~12 min)
    python benchmarks/bench_courses.py --courses "737 6 24 none; global5000 12 1 light"
    python benchmarks/bench_courses.py --variants excitation   # half the time: no list
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from bench_whole_flight import COEF, fly_and_identify

#: aircraft, test points, seed, turbulence
COURSES = ("global5000 6 1 none; global5000 12 1 none; global5000 12 1 light; "
           "global5000 12 21 light; global5000 6 22 light; 737 12 1 light; 737 12 3 none; "
           "737 12 22 light; 737 6 24 none; c172p 12 5 light; c172p 6 5 none; "
           "f16 12 24 light; A4 12 25 none; A4 12 26 light")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--courses", default=COURSES,
                    help="';'-separated 'aircraft test-points seed turbulence'")
    ap.add_argument("--variants", default="excitation,list",
                    help="comma-separated mapping variants: excitation (no maneuver list, "
                    "segments detected), list; a segmentation change moves only the first")
    args = ap.parse_args()
    variants = [v.strip() for v in args.variants.split(",") if v.strip()]
    unknown = sorted(set(variants) - {"excitation", "list"})
    if unknown or not variants:
        ap.error(f"unknown variant(s) {unknown or variants}: use excitation, list or both")
    warnings.simplefilter("ignore")
    head = ("| course | variant | " + " | ".join(f"{c} R2 (true/noise)" for c in COEF)
            + " | CL_alpha (truth) | Cm_alpha (truth) | jackknife CL_alpha; Cm_alpha "
            "| reconstructed alpha, beta [rad], V [m/s] RMS error | s (course) |")
    lines = [head, "|---" * (head.count("|") - 1) + "|"]
    r2s, ratios = [], []
    within = {"CL_alpha": [], "Cm_alpha": []}
    wrong_sign = {"flagged": 0, "unflagged": 0}
    rec_errors = []         # (alpha, beta, V) reconstructed, (alpha, V) raw
    t_all = time.perf_counter()
    for spec in args.courses.split(";"):
        aircraft, points, seed, turbulence = spec.split()
        t0 = time.perf_counter()
        results, *_rest = fly_and_identify(aircraft, int(points), int(seed), turbulence,
                                           "eigenmotion", variants,
                                           turns=True)
        truth = _rest[2]
        for r in results:
            if "error" in r:
                lines.append(f"| {spec.strip()} | {r['variant']} | {r['error']} |")
                continue
            cells = []
            for c in COEF:
                e = r["coef"].get(c)
                if e is None:
                    cells.append("-")
                    continue
                r2s.append(e["r2"])
                ratios.append(e["rms_true_over_noise"])
                cells.append(("**" if e["r2"] < 0 else "") + f"{e['r2']:.2f}"
                             + ("**" if e["r2"] < 0 else "")
                             + f" ({e['rms_true_over_noise']:.2f})")
            cl = r.get("CL_alpha", [np.nan])[0]
            cm = (r.get("Cm_alpha") or [np.nan])[0]
            jack = []
            for n, (v, se) in r.get("jackknife", {}).items():
                within[n].append(abs(v - truth[n]) <= 2 * se)
                jack.append(f"{v:.2f} +- {se:.2f}")
                if n == "Cm_alpha" and np.sign(v) != np.sign(truth[n]):
                    wrong_sign["flagged" if abs(v) < 2 * se else "unflagged"] += 1
            rec = r["rec"]
            rec_errors.append((rec["alpha"], rec["beta"], rec["tas"], r["raw"]["alpha"],
                               r["raw"]["tas"]))
            lines.append(f"| {spec.strip()} | {r['variant']} | " + " | ".join(cells)
                         + f" | {cl:.2f} ({truth['CL_alpha']:.2f}) | {cm:.2f} "
                         f"({truth['Cm_alpha']:.2f}) | {'; '.join(jack) or '-'} "
                         f"| {rec['alpha']:.1e}, {rec['beta']:.1e}, {rec['tas']:.3f} "
                         f"| {time.perf_counter() - t0:.0f} |")
        print(lines[-1], flush=True)
    print()
    print("\n".join(lines))
    r2s = np.asarray(r2s)
    print(f"\n{len(r2s)} models: {int((r2s < 0).sum())} with a negative validation R^2; "
          f"geometric mean of RMS vs truth / noise {np.exp(np.mean(np.log(ratios))):.3f}; "
          f"{time.perf_counter() - t_all:.0f} s")
    for n, hits in within.items():
        if hits:
            print(f"{n}: the truth within two jackknife standard errors in {sum(hits)} of "
                  f"{len(hits)}")
    print(f"Cm_alpha of the wrong sign: {wrong_sign['flagged']} flagged (zero within two "
          f"standard errors), {wrong_sign['unflagged']} not")
    if rec_errors:
        e = np.asarray(rec_errors)
        gm = np.exp(np.mean(np.log(e), axis=0))
        print(f"reconstruction: V error below the raw airspeed's in "
              f"{int((e[:, 2] < e[:, 4]).sum())} of {len(e)} (geometric means: alpha "
              f"{gm[0]:.2e}, beta {gm[1]:.2e} rad, V {gm[2]:.3f} m/s; raw V {gm[4]:.3f})")


if __name__ == "__main__":
    main()
