"""Structure search: candidates sharing their folds' normal equations against a fresh
accumulation for every candidate (issue 19).

Runs :func:`~simplexspline.aero.selection.search.select_structure` from the knowledge-free
starting structures on reconstructed flight data, alternately with the kept blocks
(:mod:`simplexspline.aero.selection.fold_equations`, the default) and with every
candidate's fold equations accumulated afresh, in the same process. Prints per
coefficient the CPU seconds spent on the fold equations and on the whole search (medians
of ``--repeats``), and whether both select the same structure with the same scores.

    simplexspline simulate --aircraft f16 --maneuvers 60 -o f16.parquet
    simplexspline reconstruct f16.parquet -o f16_rec.parquet
    .venv/bin/python benchmarks/bench_search.py f16_rec.parquet --coefficients CX,Cl
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from simplexspline.aero.data.flight_data import read_flight_data
from simplexspline.aero.modelling.auto import AUTO_PRESET, restrict_to_data
from simplexspline.aero.selection import fold_equations as fe
from simplexspline.aero.selection.search import SelectionSettings, select_structure
from simplexspline.aero.variables import CANDIDATE_VARIABLES


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", help="reconstructed flight data (.parquet or .csv)")
    ap.add_argument("--coefficients", default="CX,Cl")
    ap.add_argument("--rounds", type=int, default=2, help="search rounds (2)")
    ap.add_argument("--repeats", type=int, default=3, help="runs of each variant (3)")
    args = ap.parse_args()
    df, _meta = read_flight_data(args.data)
    cols = {c: df[c].to_numpy(float) for c in CANDIDATE_VARIABLES if c in df.columns}
    cols = {k: v for k, v in cols.items() if np.all(np.isfinite(v))}
    mans = df["maneuver"].to_numpy()
    kept_get = fe.FoldEquations.get
    spent = [0.0]

    def kept(self, structure, laid, min_points):
        t = time.process_time()
        out = kept_get(self, structure, laid, min_points)
        spent[0] += time.process_time() - t
        return out

    def fresh(self, structure, laid, min_points):
        t = time.process_time()
        out = fe.fold_equations(laid.space, laid.scheduling, laid.multipliers, self.y,
                                self.folds, self.k)
        spent[0] += time.process_time() - t
        return out

    settings = SelectionSettings(max_rounds=args.rounds)
    print(f"| coefficient | candidates | fold equations CPU s: kept / fresh | search CPU s: "
          f"kept / fresh | same selection and scores (rtol 1e-6) |")
    print("|---|---|---|---|---|")
    try:
        for c in args.coefficients.split(","):
            start, _ = restrict_to_data(AUTO_PRESET[c], cols)
            y = df[c].to_numpy(float)
            runs: dict = {"kept": [], "fresh": []}
            for _ in range(args.repeats):
                for name, get in (("kept", kept), ("fresh", fresh)):
                    fe.FoldEquations.get = get
                    spent[0] = 0.0
                    t = time.process_time()
                    best, history = select_structure(start, cols, y, mans, settings)
                    runs[name].append((time.process_time() - t, spent[0], best,
                                       np.array([h.score for h in history])))
            k, f = runs["kept"], runs["fresh"]
            same = all(a[2] == b[2] and len(a[3]) == len(b[3])
                       and np.allclose(a[3], b[3], rtol=1e-6, atol=0) for a, b in zip(k, f))
            med = [float(np.median([r[i] for r in rs])) for rs in (k, f) for i in (1, 0)]
            print(f"| {c} | {len(k[0][3])} | {med[0]:.2f} / {med[2]:.2f} | "
                  f"{med[1]:.1f} / {med[3]:.1f} | {same} |", flush=True)
    finally:
        fe.FoldEquations.get = kept_get


if __name__ == "__main__":
    main()
