"""Monte Carlo coverage of the pointwise 95 % intervals of SimplexSpline.confidence_interval
(issue 7; the table in docs/uncertainty.md): ``python benchmarks/bench_coverage.py --reps 4000``.

Fixed design points x (uniform in the unit box), R noise realisations y_r = f(x) + e_r.
Every realisation is refitted (Uncertainty.coefficients_for: the same constrained
estimator, from the fit's factorisation), sigma^2 is re-estimated as RSS_r / (N - p), and
the intervals  s_r(t) -/+ q * se_r(t)  at fixed test points t are checked against the true
f(t) (confidence) and against a new observation f(t) + e (prediction).
"""
import argparse
import time

import numpy as np

from simplexspline import SplineSpace, Triangulation


def smooth(x):
    return np.exp(0.6 * x[:, 0] - 0.4 * x[:, 1:].sum(1)) * np.cos(0.7 * x[:, 0] + 0.5 * x[:, -1])


def experiment(ndim, shape, npoints, reps, weights, truth, seed=1, smoothing=None,
               covariance=None):
    rng = np.random.default_rng(seed)
    space = SplineSpace(Triangulation.grid([0] * ndim, [1] * ndim, shape), 3, 1)
    if truth == "in-space":    # a smooth function of S^1_3 itself: no approximation bias
        dense = rng.uniform(0, 1, (max(4000, 20 * space.dim_coefficients), ndim))
        f = space.fit(dense, smooth(3 * dense)).predict
    else:                      # not in the space: the fit has some bias
        f = lambda z: smooth(3 * z)  # noqa: E731
    x = rng.uniform(0, 1, (npoints, ndim))
    t = np.vstack([rng.uniform(0, 1, (40, ndim)), np.full((1, ndim), 0.01),
                   np.full((1, ndim), 0.5)])                    # 42 test points
    if weights == "absolute":  # heteroscedastic noise, weights = 1 / variance
        sd, sdt = 0.02 + 0.2 * x[:, 0], 0.02 + 0.2 * t[:, 0]
        w, wt = 1.0 / sd**2, 1.0 / sdt**2
    else:                      # sigma = 0.1 unknown, estimated from the residuals
        sd, sdt, w, wt = np.full(len(x), 0.1), np.full(len(t), 0.1), None, 1.0
    Y = f(x)[:, None] + sd[:, None] * rng.standard_normal((len(x), reps))
    ne = space.normal_equations(x, Y[:, 0], w)
    spline = space.solve(ne, smoothing=smoothing)
    spline = spline.with_statistics(ne, absolute_weights=weights == "absolute",
                                    covariance=covariance)
    unc = spline.uncertainty
    # refit all realisations with the same estimator (same penalty weight if any)
    X = space.design_matrix(x)
    ww = np.ones(len(x)) if w is None else w
    C = unc.coefficients_for((X.T @ (ww[:, None] * Y)).T.reshape(reps, *spline.coefficients.shape))
    assert np.allclose(C[0], spline.coefficients, rtol=1e-8, atol=1e-10)
    C = C.reshape(reps, -1)
    s2 = (ww[:, None] * (Y - X @ C.T) ** 2).sum(axis=0) / unc.dof     # sigma^2 per realisation
    scale = np.ones(reps) if weights == "absolute" else s2
    q = unc.quantile(0.95)
    v1 = unc.unscaled_variance(t)                      # se^2 / sigma^2 at the test points
    ft = f(t)
    pred = space.design_matrix(t) @ C.T                # (T, R)
    conf = np.abs(pred - ft[:, None]) <= q * np.sqrt(v1[:, None] * scale)
    ynew = ft[:, None] + sdt[:, None] * rng.standard_normal(pred.shape)
    wt = np.broadcast_to(wt, sdt.shape)[:, None]
    predi = np.abs(ynew - pred) <= q * np.sqrt((v1[:, None] + 1.0 / wt) * scale)
    true_s2 = 1.0 if weights == "absolute" else 0.01
    se_true = np.sqrt(v1 * true_s2)                    # formula, at the true sigma^2
    point = conf.mean(axis=1)
    return dict(N=len(x), J=space.triangulation.nsimplex, p=round(unc.effective_parameters, 2),
                q=round(q, 4), confidence=conf.mean(), prediction=predi.mean(),
                point_min=point.min(), point_max=point.max(),
                sd_over_se=np.median(pred.std(axis=1) / se_true),
                sigma2_ratio=s2.mean() / true_s2 if weights != "absolute" else np.nan)


CASES = {
    "2d-estimated": dict(ndim=2, shape=(3, 3), npoints=240, weights="estimated", truth="in-space"),
    "2d-absolute": dict(ndim=2, shape=(3, 3), npoints=240, weights="absolute", truth="in-space"),
    "2d-not-in-space": dict(ndim=2, shape=(3, 3), npoints=240, weights="estimated", truth="smooth"),
    "3d-estimated": dict(ndim=3, shape=(4, 4, 4), npoints=12000, weights="estimated",
                         truth="in-space"),
    "3d-absolute": dict(ndim=3, shape=(4, 4, 4), npoints=12000, weights="absolute",
                        truth="in-space"),
    "3d-thin": dict(ndim=3, shape=(3, 3, 3), npoints=3000, weights="estimated", truth="in-space"),
    "2d-gcv-bayesian": dict(ndim=2, shape=(3, 3), npoints=240, weights="estimated", truth="smooth",
                            smoothing="gcv", covariance="bayesian"),
    "2d-gcv-frequentist": dict(ndim=2, shape=(3, 3), npoints=240, weights="estimated",
                               truth="smooth", smoothing="gcv", covariance="frequentist"),
    # the configuration of tests/spline/test_spline_statistics.py (slow: ~5 min, see notes)
    "3d-test-config": dict(ndim=3, shape=(4, 4, 4), npoints=3000, weights="estimated",
                           truth="in-space"),
}
DEFAULT = [k for k in CASES if k != "3d-test-config"]

if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--reps", type=int, default=1000)
    ap.add_argument("--cases", default=",".join(DEFAULT))
    args = ap.parse_args()
    print(f"{'case':20s} {'N':>5s} {'J':>4s} {'p':>7s} {'conf':>7s} {'pred':>7s} "
          f"{'pt min':>7s} {'pt max':>7s} {'sd/se':>6s} {'s2/true':>7s} {'time':>6s}")
    for name in args.cases.split(","):
        t0 = time.time()
        r = experiment(reps=args.reps, **CASES[name])
        print(f"{name:20s} {r['N']:5d} {r['J']:4d} {r['p']:7.2f} {r['confidence']:7.4f} "
              f"{r['prediction']:7.4f} {r['point_min']:7.3f} {r['point_max']:7.3f} "
              f"{r['sd_over_se']:6.3f} {r['sigma2_ratio']:7.4f} {time.time() - t0:5.1f}s",
              flush=True)
