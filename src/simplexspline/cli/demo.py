"""`simplexspline demo`: fit a 3-D function from scattered noisy samples and validate."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from simplexspline import SplineSpace, Triangulation
from simplexspline.cli import arguments


def _truth(x: np.ndarray) -> np.ndarray:
    """A smooth nonlinear test function on [-1, 1]^3 (shaped like a lift curve in x0)."""
    return (np.tanh(3.0 * x[:, 0]) * (1.0 + 0.3 * x[:, 1]) + 0.5 * np.sin(2.0 * x[:, 1] * x[:, 2])
            + 0.2 * x[:, 2] ** 2)


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the command's parser to ``sub``; :func:`run` executes it."""
    p = sub.add_parser(
        "demo",
        help="fit a 3-D function from scattered noisy samples and print validation errors",
        description="Built-in demonstration of the spline core: scattered noisy samples of a "
        "known 3-D function, a fitted triangulation, an S^r_d spline fitted by constrained "
        "least squares, and validation against held-out samples and the noise-free truth.",
    )
    p.add_argument("--samples", type=arguments.count, default=200_000,
                   help="number of samples (200000)")
    p.add_argument("--noise", type=arguments.non_negative_number, default=0.02,
                   help="noise standard deviation (0.02)")
    p.add_argument("--degree", type=arguments.non_negative, default=3,
                   help="polynomial degree d (3)")
    p.add_argument("--continuity", type=int, default=1, help="continuity order r (1)")
    p.add_argument("--cells", type=arguments.count, default=3, help="grid cells per axis (3)")
    p.add_argument("--seed", type=arguments.seed, default=0, help="random seed (0)")
    p.add_argument("-o", "--output", type=Path, default=None,
                   help="save the fitted model to this .json or .npz file")
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``simplexspline demo`` with the parsed arguments; returns the exit code."""
    rng = np.random.default_rng(args.seed)
    n_all = args.samples
    # Scattered, non-uniform samples inside the unit ball scaled to [-1, 1]^3 (data do not
    # fill the box, like flight data do not fill the envelope).
    x = rng.normal(size=(n_all, 3))
    x *= (rng.random(n_all) ** (1 / 3) / np.linalg.norm(x, axis=1))[:, None]
    truth = _truth(x)
    y = truth + args.noise * rng.normal(size=n_all)
    n_id = int(0.8 * n_all)
    t0 = time.perf_counter()
    tri = Triangulation.fit(x[:n_id], args.cells, min_points=1)
    space = SplineSpace(tri, args.degree, args.continuity)
    t1 = time.perf_counter()
    spline = space.fit(x[:n_id], y[:n_id], on_insufficient="minnorm")
    t2 = time.perf_counter()
    xv, yv, tv = x[n_id:], y[n_id:], truth[n_id:]
    pred = spline.predict(xv)
    inside = np.isfinite(pred)
    t3 = time.perf_counter()
    res = yv[inside] - pred[inside]
    err = tv[inside] - pred[inside]
    span = float(yv.max() - yv.min())
    rms = float(np.sqrt(np.mean(res**2)))
    rms_true = float(np.sqrt(np.mean(err**2)))
    print(f"simplexspline demo: f(x) on the unit ball in 3-D, {n_all} samples, noise sigma "
          f"{args.noise}")
    print(f"  triangulation : {tri.nsimplex} simplices ({args.cells}^3 Kuhn grid fitted to "
          f"the data), min quality {tri.quality().min():.2f}")
    print(f"  spline space  : S^{args.continuity}_{args.degree}, {space.dim_coefficients} "
          f"B-coefficients, {space.H.shape[0]} independent continuity conditions "
          f"(of {space.H_full.shape[0]}), dimension {space.dimension}")
    print(f"  time          : set-up {t1 - t0:.3f} s, fit of {n_id} points {t2 - t1:.3f} s, "
          f"predict {len(xv)} points {t3 - t2:.3f} s")
    print()
    print("  validation on held-out samples        value")
    print(f"  points inside the triangulation    {int(inside.sum()):>8d} of {len(xv)}")
    print(f"  RMS of residual (vs measured)      {rms:>12.5f}")
    print(f"  relative RMS (RMS / range)         {rms / span:>12.5%}")
    print(f"  RMS error vs noise-free truth      {rms_true:>12.5f}")
    print(f"  max error vs noise-free truth      {float(np.abs(err).max()):>12.5f}")
    print(f"  noise sigma (the floor for RMS)    {args.noise:>12.5f}")
    if args.output is not None:
        spline.metadata.update({"variables": ["x0", "x1", "x2"], "source": "simplexspline demo"})
        spline.save(args.output)
        print(f"\n  model saved to {args.output}")
    return 0
