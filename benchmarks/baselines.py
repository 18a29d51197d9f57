"""Baseline model types for the comparison benchmark (``bench_compare.py``).

Benchmark-only code, not part of the package. Every model takes the same inputs as the
simplex spline: the explanatory variables scaled to the unit box of the identification
data, ``u`` of shape (N, n), clamped to [0, 1] at evaluation. Every model has

* ``predict(u) -> (N,)``,
* ``nparams`` (numbers needed to evaluate it) and ``arrays()`` (those numbers as named
  arrays), and ``save(path)``: an uncompressed ``.npz`` written atomically (never pickle).

Model types:

* :class:`PolynomialModel` chosen by :func:`stepwise_regression`: forward-backward
  selection of monomial terms up to a total order, with entry and removal by k-fold
  cross-validation over maneuvers (``criterion='cv'``) or by the classical partial F-test
  (``criterion='F'``);
* :class:`TensorBSpline`: cubic tensor-product B-splines with quantile knots, fitted by
  (ridge-regularised) least squares (:func:`fit_tensor_bspline`), the number of knots chosen
  by cross-validation over maneuvers (:func:`select_tensor_bspline`);
* :class:`RBFModel`: :class:`scipy.interpolate.RBFInterpolator` (thin-plate spline) on a
  subsample, its smoothing chosen on held-out maneuvers (:func:`fit_rbf`);
* :class:`MLPModel`: :class:`sklearn.neural_network.MLPRegressor` (:func:`fit_mlp`);
* :class:`MARSModel`: multivariate adaptive regression splines (Friedman 1991; the
  ``py-earth2`` package, the compiled py-earth implementation), pairwise interactions, the
  GCV penalty chosen by cross-validation over maneuvers (:func:`fit_mars`);
* :class:`BoostedModel`: LightGBM (:func:`fit_lightgbm`) and the explainable boosting
  machine of ``interpret`` (:func:`fit_ebm`).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.linalg as sla
from scipy.interpolate import BSpline

from simplexspline._files import atomic_write

__all__ = [
    "MLPModel",
    "PolynomialModel",
    "RBFModel",
    "StepwiseResult",
    "TensorBSpline",
    "BoostedModel",
    "MARSModel",
    "fit_ebm",
    "fit_mars",
    "fit_lightgbm",
    "fit_mlp",
    "fit_rbf",
    "difference_penalty",
    "fit_tensor_bspline",
    "monomial_exponents",
    "save_npz",
    "select_tensor_bspline",
    "stepwise_regression",
]


def save_npz(path, arrays: dict) -> Path:
    """Write named arrays to an uncompressed ``.npz`` atomically (temp file + rename)."""
    def write(tmp):
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)
    return atomic_write(path, write)


class _Saveable:
    def arrays(self) -> dict:  # pragma: no cover - overridden
        raise NotImplementedError

    def save(self, path) -> Path:
        """Write :meth:`arrays` to ``path`` (``.npz``, atomic, no pickle)."""
        return save_npz(path, self.arrays())


def _chunks(n: int, size: int):
    for lo in range(0, n, size):
        yield slice(lo, min(n, lo + size))


def _spd_solve(G: np.ndarray, b: np.ndarray, ridge: float) -> np.ndarray:
    """Solve (G + ridge * mean(diag G) I) x = b for SPD G (lstsq when Cholesky fails)."""
    lam = ridge * float(np.mean(np.diag(G))) if G.size else 0.0
    A = G + lam * np.eye(len(G))
    try:
        return sla.cho_solve(sla.cho_factor(A, check_finite=False), b, check_finite=False)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(A, b, rcond=None)[0]


# ----------------------------------------------------------------------------- polynomials
def monomial_exponents(n: int, order: int) -> np.ndarray:
    """Exponents of all monomials in ``n`` variables of total degree <= ``order``.

    Returns
    -------
    ndarray of int, shape (C(n + order, n), n)
        Sorted by total degree, then lexicographically (descending); row 0 is the
        constant.
    """
    rows = [e for e in itertools.product(range(order + 1), repeat=n) if sum(e) <= order]
    rows.sort(key=lambda e: (sum(e), tuple(-v for v in e)))
    return np.array(rows, dtype=np.int64).reshape(-1, n)


def _monomials(z: np.ndarray, exponents: np.ndarray) -> np.ndarray:
    """Monomial values, shape (N, K), of points z (N, n)."""
    order = int(exponents.max()) if exponents.size else 0
    powers = z[:, :, None] ** np.arange(order + 1)  # (N, n, order+1)
    out = np.ones((len(z), len(exponents)))
    for j in range(z.shape[1]):
        out *= powers[:, j, exponents[:, j]]
    return out


@dataclass
class PolynomialModel(_Saveable):
    """``C = sum_k beta_k prod_j z_j^e_kj`` with ``z = 2 u - 1`` (the unit box mapped to
    [-1, 1], for conditioning).

    Attributes
    ----------
    exponents : ndarray of int, shape (K, n)
    beta : ndarray, shape (K,)
    """

    exponents: np.ndarray
    beta: np.ndarray

    @property
    def nparams(self) -> int:
        return int(self.beta.size)

    def terms(self, names) -> list:
        """Readable terms, e.g. ``['1', 'alpha', 'alpha^2*de']``."""
        out = []
        for e in self.exponents:
            parts = [n if k == 1 else f"{n}^{k}" for n, k in zip(names, e) if k]
            out.append("*".join(parts) or "1")
        return out

    def predict(self, u: np.ndarray) -> np.ndarray:
        u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
        z = 2.0 * u - 1.0
        out = np.empty(len(z))
        for s in _chunks(len(z), 65536):
            out[s] = _monomials(z[s], self.exponents) @ self.beta
        return out

    def arrays(self) -> dict:
        return {"exponents": self.exponents, "beta": self.beta}


@dataclass
class StepwiseResult:
    """Result of :func:`stepwise_regression`.

    Attributes
    ----------
    model : PolynomialModel
    steps : list of (str, int, float)
        ('add' | 'remove', candidate term index, criterion value after the step).
    score : float
        Final CV RMS (criterion 'cv') or residual RMS on the fitted data (criterion 'F').
    """

    model: PolynomialModel
    steps: list = field(default_factory=list)
    score: float = float("nan")


def _fold_normal_equations(z, y, folds, exponents, chunk=32768):
    k = int(folds.max()) + 1
    K = len(exponents)
    G = np.zeros((k, K, K))
    b = np.zeros((k, K))
    yy = np.zeros(k)
    cnt = np.zeros(k)
    for s in _chunks(len(z), chunk):
        X = _monomials(z[s], exponents)
        ys, fs = y[s], folds[s]
        for f in range(k):
            m = fs == f
            if not m.any():
                continue
            Xf = X[m]
            G[f] += Xf.T @ Xf
            b[f] += Xf.T @ ys[m]
            yy[f] += ys[m] @ ys[m]
            cnt[f] += m.sum()
    return G, b, yy, cnt


def stepwise_regression(u: np.ndarray, y: np.ndarray, folds: np.ndarray, *, order: int = 3,
                        criterion: str = "cv", min_improvement: float = 1e-3,
                        f_enter: float = 4.0, f_remove: float = 3.9,
                        max_terms: int | None = None) -> StepwiseResult:
    """Forward-backward stepwise selection of polynomial terms, least squares fit.

    Parameters
    ----------
    u : ndarray, shape (N, n)
        Inputs scaled to the unit box.
    y : ndarray, shape (N,)
    folds : ndarray of int, shape (N,)
        Fold per sample (whole maneuvers per fold) for ``criterion='cv'``.
    order : int
        Largest total degree of the candidate monomials (``C(n + order, n)`` candidates).
    criterion : {'cv', 'F'}
        ``'cv'``: a term enters when it lowers the k-fold CV RMS by more than
        ``min_improvement`` (relative) and leaves when removing it lowers the CV RMS.
        ``'F'``: classical partial F-test (enter when F >= ``f_enter``, leave when
        F < ``f_remove``), samples taken as independent.
    max_terms : int, optional
        Stop adding at this many terms.

    Returns
    -------
    StepwiseResult
        The model holds the selected terms fitted by least squares on all samples.
    """
    if criterion not in ("cv", "F"):
        raise ValueError(f"criterion must be 'cv' or 'F', got {criterion!r}")
    if f_remove > f_enter:
        raise ValueError("f_remove must not exceed f_enter (the selection could cycle)")
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    z = 2.0 * u - 1.0
    ymean = float(np.mean(y))
    yc = y - ymean
    exps = monomial_exponents(u.shape[1], order)
    K = len(exps)
    folds = np.asarray(folds, dtype=int) if criterion == "cv" else np.zeros(len(y), int)
    Gf, bf, yyf, cnt = _fold_normal_equations(z, yc, folds, exps)
    G, b, yy, N = Gf.sum(0), bf.sum(0), float(yyf.sum()), float(cnt.sum())
    max_terms = K if max_terms is None else max_terms

    def rss(S) -> float:
        S = list(S)
        beta = _spd_solve(G[np.ix_(S, S)], b[S], 1e-13)
        return max(yy - 2 * beta @ b[S] + beta @ G[np.ix_(S, S)] @ beta, 0.0)

    def cv(S) -> float:
        S = list(S)
        sse = 0.0
        for f in range(len(Gf)):
            Gt = (G - Gf[f])[np.ix_(S, S)]
            beta = _spd_solve(Gt, (b - bf[f])[S], 1e-13)
            sse += yyf[f] - 2 * beta @ bf[f][S] + beta @ Gf[f][np.ix_(S, S)] @ beta
        return math.sqrt(max(sse, 0.0) / N)

    S = [0]
    steps = []
    if criterion == "cv":
        current = cv(S)
        while len(S) < max_terms:
            cand = [t for t in range(K) if t not in S]
            if not cand:
                break
            sc = [cv(S + [t]) for t in cand]
            i = int(np.argmin(sc))
            if not sc[i] < current * (1.0 - min_improvement):
                break
            S.append(cand[i])
            current = sc[i]
            steps.append(("add", cand[i], current))
            while len(S) > 2:  # backward: drop terms whose removal lowers the CV RMS
                sc = [cv([s for s in S if s != t]) for t in S[1:]]
                i = int(np.argmin(sc))
                if not sc[i] < current:
                    break
                t = S[1:][i]
                S.remove(t)
                current = sc[i]
                steps.append(("remove", t, current))
        score = current
    else:
        r = rss(S)
        while len(S) < max_terms:
            cand = [t for t in range(K) if t not in S]
            if not cand:
                break
            rs = np.array([rss(S + [t]) for t in cand])
            dof = N - len(S) - 1
            F = (r - rs) / np.maximum(rs / dof, 1e-300)
            i = int(np.argmax(F))
            if not F[i] >= f_enter:
                break
            S.append(cand[i])
            r = float(rs[i])
            steps.append(("add", cand[i], r))
            while len(S) > 2:
                rs = np.array([rss([s for s in S if s != t]) for t in S[1:]])
                F = (rs - r) / max(r / (N - len(S)), 1e-300)
                i = int(np.argmin(F))
                if not F[i] < f_remove:
                    break
                t = S[1:][i]
                S.remove(t)
                r = float(rs[i])
                steps.append(("remove", t, r))
        score = math.sqrt(r / N)
    S = sorted(S)
    beta = _spd_solve(G[np.ix_(S, S)], b[S], 1e-13)
    beta[0] += ymean  # the constant (S[0] == 0) absorbs the centring
    return StepwiseResult(PolynomialModel(exps[S], beta), steps, score)


# ----------------------------------------------------------------------- tensor B-splines
def quantile_knots(x: np.ndarray, interior: int, degree: int = 3,
                   lower: float = 0.0, upper: float = 1.0) -> np.ndarray:
    """Clamped knot vector on [lower, upper] with ``interior`` knots at data quantiles.

    Coincident quantiles (discrete data) are thinned so that interior knots stay simple.
    """
    q = np.quantile(np.asarray(x, dtype=float), np.linspace(0, 1, interior + 2)[1:-1])
    q = np.unique(np.clip(q, lower, upper))
    q = q[(q > lower) & (q < upper)]
    return np.r_[[lower] * (degree + 1), q, [upper] * (degree + 1)]


@dataclass
class TensorBSpline(_Saveable):
    """Tensor-product B-spline ``C = sum_i c_i prod_j B_{i_j}(u_j)``.

    Attributes
    ----------
    knots : list of ndarray
        Clamped knot vector per variable (on [0, 1]).
    coefficients : ndarray, shape (m_1, ..., m_n)
    degree : int
    """

    knots: list
    coefficients: np.ndarray
    degree: int = 3

    @property
    def shape(self) -> tuple:
        return tuple(len(t) - self.degree - 1 for t in self.knots)

    @property
    def nparams(self) -> int:
        return int(self.coefficients.size)

    def arrays(self) -> dict:
        out = {"coefficients": self.coefficients, "degree": np.array(self.degree)}
        out.update({f"knots_{j}": t for j, t in enumerate(self.knots)})
        return out

    def predict(self, u: np.ndarray) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        coef = self.coefficients.ravel()
        out = np.empty(len(u))
        for s in _chunks(len(u), 16384):
            base, w = tensor_basis(u[s], self.knots, self.degree)
            out[s] = np.einsum("ij,ij->i", w, coef[base[:, None] + self._offsets()])
        return out

    def _offsets(self) -> np.ndarray:
        return _offsets(self.shape, self.degree)


def _offsets(shape, degree) -> np.ndarray:
    strides = np.cumprod((1,) + tuple(shape[::-1]))[:-1][::-1]
    grid = np.array(list(itertools.product(range(degree + 1), repeat=len(shape))))
    return grid @ np.asarray(strides)


def tensor_basis(u: np.ndarray, knots, degree: int = 3):
    """Row-wise Kronecker product of the 1-D B-spline design matrices.

    Parameters
    ----------
    u : ndarray, shape (N, n)
        Points (clamped to each knot vector's range).
    knots : list of ndarray
    degree : int

    Returns
    -------
    base : ndarray of int, shape (N,)
        Flat (C-order) index of the first non-zero tensor basis function of each row.
    values : ndarray, shape (N, (degree + 1)^n)
        The non-zero basis values; column ``a`` belongs to flat index ``base + offsets[a]``
        (see :func:`_offsets`).
    """
    k1 = degree + 1
    shape = tuple(len(t) - k1 for t in knots)
    strides = np.cumprod((1,) + shape[::-1])[:-1][::-1]
    n = len(u)
    base = np.zeros(n, dtype=np.int64)
    values = np.ones((n, 1))
    for j, t in enumerate(knots):
        x = np.clip(u[:, j], t[0], t[-1])
        D = BSpline.design_matrix(x, t, degree)
        first = D.indices[::k1].astype(np.int64)
        base += first * strides[j]
        v = D.data.reshape(n, k1)
        values = (values[:, :, None] * v[:, None, :]).reshape(n, -1)
    return base, values


def _tensor_normal_equations(u, y, folds, knots, degree=3):
    """Per-fold Gram matrices: samples grouped by knot cell, one BLAS product per cell."""
    shape = tuple(len(t) - degree - 1 for t in knots)
    M = int(np.prod(shape))
    k = int(folds.max()) + 1
    offs = _offsets(shape, degree)
    G = np.zeros((k, M, M))
    b = np.zeros((k, M))
    yy = np.zeros(k)
    support = np.zeros(M, dtype=np.int64)
    for s in _chunks(len(u), 65536):
        base, w = tensor_basis(u[s], knots, degree)
        ys, fs = y[s], folds[s]
        key = base * k + fs
        order = np.argsort(key, kind="stable")
        keys, start = np.unique(key[order], return_index=True)
        stop = np.r_[start[1:], len(order)]
        for kk, a, e in zip(keys, start, stop):
            rows = order[a:e]
            f = int(kk % k)
            idx = int(kk // k) + offs
            W = w[rows]
            G[f][np.ix_(idx, idx)] += W.T @ W
            b[f, idx] += W.T @ ys[rows]
            support[idx] += len(rows)
        for f in range(k):
            yy[f] += ys[fs == f] @ ys[fs == f]
    return G, b, yy, support


def difference_penalty(shape, order: int = 2) -> np.ndarray:
    """P-spline roughness penalty ``sum_j ||D_j c||^2`` on a tensor coefficient grid.

    ``D_j`` takes ``order``-th differences of the coefficients along axis ``j``
    (Eilers & Marx); returns the dense (M, M) matrix ``sum_j D_j' D_j``, M = prod(shape).
    """
    import scipy.sparse as sps

    M = int(np.prod(shape))
    P = sps.csr_matrix((M, M))
    for j, m in enumerate(shape):
        if m <= order:
            continue
        D = sps.csr_matrix(np.diff(np.eye(m), order, axis=0))
        mats = [sps.identity(k, format="csr") for k in shape]
        mats[j] = (D.T @ D).tocsr()
        K = mats[0]
        for A in mats[1:]:
            K = sps.kron(K, A, format="csr")
        P = P + K
    return P.toarray()


def _penalised_solve(G, b, P, penalty: float, ridge: float):
    if penalty > 0:
        lam = penalty * float(np.trace(G)) / max(float(np.trace(P)), 1e-300)
        G = G + lam * P
    return _spd_solve(G, b, ridge)


def fit_tensor_bspline(u: np.ndarray, y: np.ndarray, interior, *, degree: int = 3,
                       penalty: float = 0.0, ridge: float = 1e-8) -> TensorBSpline:
    """Least-squares tensor-product B-spline with quantile knots.

    Parameters
    ----------
    u : ndarray, shape (N, n)
        Inputs in the unit box.
    y : ndarray, shape (N,)
    interior : int or sequence of int
        Interior knots per variable.
    penalty : float
        Weight of the second-difference penalty (:func:`difference_penalty`) relative to
        trace(X'X) / trace(P); 0: none.
    ridge : float
        Ridge weight relative to the mean diagonal of X'X: it only decides the
        coefficients of basis functions without (enough) data.
    """
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    n = u.shape[1]
    interior = [interior] * n if np.isscalar(interior) else list(interior)
    knots = [quantile_knots(u[:, j], interior[j], degree) for j in range(n)]
    G, b, _yy, _support = _tensor_normal_equations(u, y, np.zeros(len(y), int), knots,
                                                   degree)
    shape = tuple(len(t) - degree - 1 for t in knots)
    P = difference_penalty(shape) if penalty > 0 else None
    c = _penalised_solve(G[0], b[0], P, penalty, ridge)
    return TensorBSpline(knots, c.reshape(shape), degree)


def select_tensor_bspline(u: np.ndarray, y: np.ndarray, folds: np.ndarray, *,
                          degree: int = 3, max_interior: int = 8,
                          penalties=(0.0, 1e-6, 1e-4, 1e-2, 1e-1, 1.0),
                          max_coefficients: int = 4096, samples_per_coefficient: float = 20.0,
                          ridge: float = 1e-8) -> tuple[TensorBSpline | None, list]:
    """Choose the number of interior knots (the same for every variable) and the weight of
    the difference penalty by k-fold CV over maneuvers, then fit on all samples.

    Candidates: 0, 1, ... ``max_interior`` interior knots per variable while the tensor
    grid has at most ``max_coefficients`` coefficients and the data give at least
    ``samples_per_coefficient`` samples per coefficient, each with every weight in
    ``penalties`` (0: tiny ridge only). The knot search stops after two knot counts that
    do not improve the best CV RMS.

    Returns
    -------
    model : TensorBSpline or None
        None when no candidate fits the budget (the data do not allow a tensor spline).
    history : list of dict
        Per candidate: interior knots, penalty, coefficients, CV RMS, basis functions
        without data.
    """
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    n = u.shape[1]
    history = []
    best = None
    worse = 0
    for q in range(max_interior + 1):
        M = (q + degree + 1) ** n
        if M > max_coefficients or len(y) < samples_per_coefficient * M:
            break
        knots = [quantile_knots(u[:, j], q, degree) for j in range(n)]
        shape = tuple(len(t) - degree - 1 for t in knots)
        G, b, yy, support = _tensor_normal_equations(u, y, folds, knots, degree)
        Gt, bt = G.sum(0), b.sum(0)
        P = difference_penalty(shape)
        improved = False
        for pen in penalties:
            sse = 0.0
            for f in range(len(G)):
                c = _penalised_solve(Gt - G[f], bt - b[f], P, pen, ridge)
                sse += yy[f] - 2 * c @ b[f] + c @ G[f] @ c
            score = math.sqrt(max(sse, 0.0) / len(y))
            history.append({"interior": q, "penalty": pen, "coefficients": M,
                            "cv_rms": score, "empty_basis": int(np.sum(support == 0))})
            if best is None or score < best[0]:
                c = _penalised_solve(Gt, bt, P, pen, ridge)
                best = (score, TensorBSpline(knots, c.reshape(shape), degree))
                improved = True
        worse = 0 if improved else worse + 1
        if worse >= 2:
            break
    return (None if best is None else best[1]), history


# ----------------------------------------------------------------------------- RBF
@dataclass
class RBFModel(_Saveable):
    """A fitted :class:`scipy.interpolate.RBFInterpolator` (global, not ``neighbors``).

    Attributes
    ----------
    interpolator : RBFInterpolator
    smoothing : float
    history : list of (smoothing, held-out RMS)
    """

    interpolator: object
    smoothing: float
    history: list = field(default_factory=list)

    @property
    def ncentres(self) -> int:
        return int(self.interpolator.y.shape[0])

    @property
    def nparams(self) -> int:
        """Centre coordinates + kernel and polynomial coefficients."""
        it = self.interpolator
        return int(it.y.size + it._coeffs.size)

    def arrays(self) -> dict:
        it = self.interpolator
        return {"centres": it.y, "coefficients": it._coeffs, "shift": it._shift,
                "scale": it._scale, "powers": it.powers, "smoothing": np.array(self.smoothing),
                "kernel": np.array(it.kernel), "epsilon": np.array(it.epsilon)}

    def predict(self, u: np.ndarray) -> np.ndarray:
        u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
        return self.interpolator(u)


def fit_rbf(u: np.ndarray, y: np.ndarray, maneuvers: np.ndarray, *, points: int = 3000,
            smoothings=(1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0),
            kernel: str = "thin_plate_spline", holdout: float = 0.25,
            check_points: int = 20000, seed: int = 0) -> RBFModel:
    """Thin-plate-spline RBF on a random subsample, smoothing chosen on held-out maneuvers.

    The identification maneuvers are split (``holdout`` of them held out); for every
    smoothing value an RBF is fitted on ``points`` random samples of the others and scored
    on ``check_points`` random samples of the held-out maneuvers. The final RBF is fitted
    with the best smoothing on ``points`` random samples of all identification samples.
    """
    from scipy.interpolate import RBFInterpolator

    rng = np.random.default_rng(seed)
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    ids = np.unique(maneuvers)
    held = rng.permutation(ids)[:max(1, round(holdout * len(ids)))]
    is_held = np.isin(maneuvers, held)
    tr = np.flatnonzero(~is_held)
    te = np.flatnonzero(is_held)
    tr = rng.choice(tr, min(points, len(tr)), replace=False)
    te = rng.choice(te, min(check_points, len(te)), replace=False)
    history = []
    for s in smoothings:
        rbf = RBFInterpolator(u[tr], y[tr], kernel=kernel, smoothing=s)
        history.append((s, float(np.sqrt(np.mean((rbf(u[te]) - y[te]) ** 2)))))
    best = min(history, key=lambda h: h[1])[0]
    sel = rng.choice(len(y), min(points, len(y)), replace=False)
    return RBFModel(RBFInterpolator(u[sel], y[sel], kernel=kernel, smoothing=best), best,
                    history)


# ----------------------------------------------------------------------------- MLP
@dataclass
class MLPModel(_Saveable):
    """A scikit-learn MLPRegressor on standardised inputs and target.

    Attributes
    ----------
    regressor : MLPRegressor
    x_mean, x_std : ndarray, shape (n,)
    y_mean, y_std : float
    samples : int
        Training samples used.
    """

    regressor: object
    x_mean: np.ndarray
    x_std: np.ndarray
    y_mean: float
    y_std: float
    samples: int = 0

    @property
    def nparams(self) -> int:
        r = self.regressor
        return int(sum(w.size for w in r.coefs_) + sum(c.size for c in r.intercepts_))

    def arrays(self) -> dict:
        r = self.regressor
        out = {"x_mean": self.x_mean, "x_std": self.x_std,
               "y_mean": np.array(self.y_mean), "y_std": np.array(self.y_std),
               "activation": np.array(r.activation)}
        for i, (w, c) in enumerate(zip(r.coefs_, r.intercepts_)):
            out[f"W{i}"], out[f"b{i}"] = w, c
        return out

    def predict(self, u: np.ndarray) -> np.ndarray:
        u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
        z = (u - self.x_mean) / self.x_std
        return self.y_mean + self.y_std * self.regressor.predict(z)


def fit_mlp(u: np.ndarray, y: np.ndarray, *, hidden=(64, 64), max_iter: int = 60,
            max_samples: int | None = 200_000, batch_size: int = 512,
            learning_rate_init: float = 1e-3, seed: int = 0) -> MLPModel:
    """MLPRegressor (ReLU, Adam, early stopping on a random 10 % of the samples).

    ``max_samples``: train on at most this many random samples (None: all).
    """
    import warnings

    from sklearn.exceptions import ConvergenceWarning
    from sklearn.neural_network import MLPRegressor

    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    rng = np.random.default_rng(seed)
    if max_samples is not None and len(y) > max_samples:
        sel = np.sort(rng.choice(len(y), max_samples, replace=False))
        u, y = u[sel], y[sel]
    x_mean, x_std = u.mean(0), u.std(0)
    x_std[x_std == 0] = 1.0
    y_mean, y_std = float(y.mean()), float(y.std()) or 1.0
    reg = MLPRegressor(hidden_layer_sizes=tuple(hidden), activation="relu", solver="adam",
                       batch_size=batch_size, learning_rate_init=learning_rate_init,
                       max_iter=max_iter, early_stopping=True, validation_fraction=0.1,
                       n_iter_no_change=8, tol=1e-6, random_state=seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        reg.fit((u - x_mean) / x_std, (y - y_mean) / y_std)
    return MLPModel(reg, x_mean, x_std, y_mean, y_std, len(y))


# ----------------------------------------------------------------------------- MARS
@dataclass
class MARSModel:
    """Multivariate adaptive regression splines (Friedman 1991) on the unit-box inputs:
    a sum of hinge functions ``max(0, +-(u_j - t))``, linear terms and their pairwise
    products, with knots ``t`` placed by the forward pass where they lower the squared
    error most and terms removed by the backward (GCV) pass.

    Attributes
    ----------
    regressor : pyearth.Earth
        The fitted model.
    samples : int
        Training samples used.
    penalty : float
        GCV cost per knot (Friedman's ``d``), chosen by cross-validation.
    history : list of dict
        ``{'penalty', 'cv_rms', 'terms'}`` per penalty tried.
    """

    regressor: object
    samples: int
    penalty: float
    history: list = field(default_factory=list)

    @property
    def terms(self) -> int:
        """Basis functions kept by the backward pass (the intercept included)."""
        return int(sum(not b.is_pruned() for b in self.regressor.basis_))

    @property
    def nparams(self) -> int:
        """Numbers needed to evaluate: per kept basis function its coefficient and per
        factor the variable and knot (a linear factor: the variable)."""
        n = 0
        for b in self.regressor.basis_:
            if b.is_pruned():
                continue
            n += 1
            f = b
            while f.get_parent() is not None:      # the factors, up to the intercept
                n += 2 if f.has_knot() else 1
                f = f.get_parent()
        return n

    def predict(self, u: np.ndarray) -> np.ndarray:
        u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
        return np.asarray(self.regressor.predict(u), dtype=float).ravel()

    def save(self, path) -> Path:
        """The model as the Python function py-earth exports (open text, never pickled),
        written atomically."""
        from pyearth.export import export_python_string

        path = Path(path).with_suffix(".py")
        text = export_python_string(self.regressor, function_name="model") + "\n"
        return atomic_write(path, lambda tmp: Path(tmp).write_text(text))


def _earth(penalty: float, max_terms: int, max_degree: int, thresh: float):
    from pyearth import Earth

    return Earth(max_degree=max_degree, max_terms=max_terms, penalty=penalty,
                 thresh=thresh, use_fast=True)


def fit_mars(u: np.ndarray, y: np.ndarray, folds: np.ndarray, *,
             penalties=(3.0, 10.0, 30.0), max_samples: int = 20_000, max_terms: int = 60,
             max_degree: int = 2, thresh: float = 1e-6, seed: int = 0) -> MARSModel:
    """MARS with pairwise interactions (``max_degree=2``), on at most ``max_samples``
    random samples.

    The forward pass runs until ``max_terms`` basis functions or until a term improves
    R^2 by less than ``thresh``: py-earth's default 1e-3 stops a fit of flight data, whose
    coefficients are explained to R^2 > 0.99 by a few terms, long before the shape is
    followed. The backward pass keeps the subset with the least generalised
    cross-validation (GCV) score; GCV treats the samples as independent, and 100 Hz
    samples are not, so its cost per knot (``penalty``) is chosen among ``penalties`` by
    k-fold cross-validation over whole maneuvers (``folds``, as the other types are
    tuned), and the model is fitted again on all the samples with the best.
    """
    import warnings

    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    rng = np.random.default_rng(seed)
    if len(y) > max_samples:
        sel = np.sort(rng.choice(len(y), max_samples, replace=False))
        u, y, folds = u[sel], y[sel], np.asarray(folds)[sel]
    history = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")      # py-earth's own deprecation notices
        for pen in penalties:
            sse, n, terms = 0.0, 0, []
            for f in np.unique(folds):
                held = folds == f
                m = _earth(pen, max_terms, max_degree, thresh).fit(u[~held], y[~held])
                r = m.predict(u[held]).ravel() - y[held]
                sse += float(r @ r)
                n += int(held.sum())
                terms.append(int(sum(not b.is_pruned() for b in m.basis_)))
            history.append({"penalty": pen, "cv_rms": math.sqrt(sse / n),
                            "terms": float(np.mean(terms))})
        best = min(history, key=lambda h: h["cv_rms"])
        reg = _earth(best["penalty"], max_terms, max_degree, thresh).fit(u, y)
    return MARSModel(reg, len(y), best["penalty"], history)


# ----------------------------------------------------------------------------- boosting
@dataclass
class BoostedModel:
    """A gradient-boosted tree ensemble (LightGBM) or an explainable boosting machine
    (``interpret``) on the unit-box inputs.

    Attributes
    ----------
    regressor : object
        The fitted ``lightgbm.LGBMRegressor`` or ``ExplainableBoostingRegressor``.
    kind : {'lightgbm', 'ebm'}
    samples : int
        Training samples used.
    rounds : int
        Boosting rounds kept (LightGBM: the early-stopping best; EBM: 0).
    """

    regressor: object
    kind: str
    samples: int = 0
    rounds: int = 0

    @property
    def nparams(self) -> int:
        """Numbers needed to evaluate: per tree node split threshold, feature and leaf value
        (LightGBM); the shape functions' bin edges and scores (EBM)."""
        r = self.regressor
        if self.kind == "lightgbm":
            trees = r.booster_.dump_model()["tree_info"]
            return int(sum(3 * t["num_leaves"] for t in trees))
        terms = sum(np.asarray(t).size for t in r.term_scores_)
        edges = sum(np.asarray(b).size for bins in r.bins_ for b in bins)
        return int(terms + edges)

    def predict(self, u: np.ndarray) -> np.ndarray:
        u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
        return np.asarray(self.regressor.predict(u), dtype=float)

    def save(self, path) -> Path:
        """The model in its library's own open text format (LightGBM's model text, EBM's
        JSON), written atomically; never pickled."""
        path = Path(path).with_suffix(".txt" if self.kind == "lightgbm" else ".json")
        if self.kind == "lightgbm":
            text = self.regressor.booster_.model_to_string()
            return atomic_write(path, lambda tmp: Path(tmp).write_text(text))
        return atomic_write(path, lambda tmp: self.regressor.to_json(tmp))


def fit_lightgbm(u: np.ndarray, y: np.ndarray, maneuvers: np.ndarray, *,
                 holdout: float = 0.2, max_rounds: int = 5000, seed: int = 0,
                 threads: int = 1) -> BoostedModel:
    """LightGBM with early stopping on held-out maneuvers.

    ``holdout`` of the identification maneuvers are the early-stopping set (whole
    maneuvers: samples 10 ms apart are not independent); boosting stops after 100 rounds
    without improvement, keeping the best round. Learning rate 0.05, 63 leaves, at least 50
    samples per leaf (LightGBM's usual starting point for ~1e5 samples).
    """
    import lightgbm

    rng = np.random.default_rng(seed)
    ids = np.unique(maneuvers)
    held = rng.permutation(ids)[:max(1, round(holdout * len(ids)))]
    is_held = np.isin(maneuvers, held)
    reg = lightgbm.LGBMRegressor(n_estimators=max_rounds, learning_rate=0.05, num_leaves=63,
                                 min_child_samples=50, subsample=0.8, subsample_freq=1,
                                 colsample_bytree=1.0, random_state=seed, n_jobs=threads,
                                 verbose=-1)
    stop = [lightgbm.early_stopping(100, verbose=False)]
    try:                     # LightGBM >= 4.6 names the evaluation data eval_X, eval_y
        reg.fit(u[~is_held], y[~is_held], eval_X=(u[is_held],), eval_y=(y[is_held],),
                callbacks=stop)
    except TypeError:
        reg.fit(u[~is_held], y[~is_held], eval_set=[(u[is_held], y[is_held])],
                callbacks=stop)
    return BoostedModel(reg, "lightgbm", int((~is_held).sum()), int(reg.best_iteration_))


def fit_ebm(u: np.ndarray, y: np.ndarray, *, max_samples: int = 5_000, seed: int = 0,
            threads: int = 1, outer_bags: int = 2, interactions: int = 5) -> BoostedModel:
    """An explainable boosting machine (``interpret``'s ExplainableBoostingRegressor:
    shape functions per variable plus ``interactions`` automatically chosen pairwise
    interactions; ``interpret``'s own early stopping on an inner validation split) on at
    most ``max_samples`` random samples. The library's defaults (14 outer bags, 90 % of the
    pairs as interactions) do not fit in a benchmark here: one fit of 5,000 samples of 12
    variables took 81 s with 2 bags and 5 interactions, 146 s with 4 and 10 (2-core machine
    shared with other jobs), so 2 bags, 5 interactions and 5,000 samples by default."""
    from interpret.glassbox import ExplainableBoostingRegressor

    rng = np.random.default_rng(seed)
    if len(y) > max_samples:
        sel = np.sort(rng.choice(len(y), max_samples, replace=False))
        u, y = u[sel], y[sel]
    reg = ExplainableBoostingRegressor(random_state=seed, n_jobs=threads,
                                       outer_bags=outer_bags, interactions=interactions)
    reg.fit(u, y)
    return BoostedModel(reg, "ebm", len(y))
