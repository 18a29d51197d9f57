"""Statistics of the constrained least-squares estimator (paper Eq. 38-42).

The fit solves, in the C^0-reduced coordinates ``g`` (``c = G g``, see
:mod:`simplexspline.spline.fit.constrained`),

    minimise  g' Qg g / 2 - qg' g   subject to  A g = 0,

with ``Qg = G'X'WXG`` (plus ``lam G'G`` with a ridge), ``qg = G'X'Wy`` and ``A`` the
continuity conditions of order >= 1 (possibly redundant). The estimate is linear in the
data, ``g = K qg`` with

    K = Z (Z' Qg Z)^-1 Z',         Z a basis of null(A),

the top-left block of the inverse KKT matrix ``[Qg A'; A 0]`` (unique even when A has
redundant rows). With noise of covariance ``sigma^2 W^-1`` (weights = inverse noise variances
up to a common factor):

    Cov(g) = sigma^2 K                (no regularisation: K Qg K = K)
    Cov(g) = sigma^2 K Q0 K           (ridge / penalty, 'frequentist'; Q0 = G'X'WXG)
    Cov(g) = sigma^2 K                (ridge / penalty, 'bayesian': the posterior)
    Var(s(x)) = v' Cov(g) v,           v = G' b(x), b(x) the basis values at x,
    sigma^2 = RSS / (N - p),           RSS = (y - Xc)' W (y - Xc),  p = trace(K Q0),

``p`` the effective number of parameters: the trace of the hat matrix ``X G K G' X' W``,
which is the dimension of the constrained coefficient space without regularisation. With a
ridge or a smoothing penalty ``lam c'Pc`` (:mod:`simplexspline.spline.fit.penalty`), ``Qg``
includes ``G'(lam P)G`` and the estimate is biased; the 'frequentist' covariance is the
sandwich (variance of the estimate, ignoring bias), the 'bayesian' one (Wahba 1983) also
accounts for the smoothing bias on average and is the default for penalised fits.

Every prediction at a point of simplex j needs only the d_hat x d_hat block of the covariance
of that simplex's B-coefficients, ``C_j = G_j Cov(g) G_j'``. The blocks are computed on
demand, with bounded memory (:data:`CHUNK_BYTES`, :data:`BASIS_BYTES`), by
:mod:`simplexspline.spline.uncertainty.covariance`; afterwards a standard error costs ``d_hat^2`` flops
per point. This module holds the user-facing side: :class:`Uncertainty` (noise level,
standard errors, confidence and prediction intervals, coefficient covariances) and its
model-file section.
"""

from __future__ import annotations

import numpy as np

from simplexspline.errors import InputError, InsufficientDataError
from simplexspline.spline import kernels
from simplexspline.spline.bform import basis_values

from simplexspline.spline.fit.constrained import POLICIES
from simplexspline.spline.fit.normal_equations import NormalEquations
from simplexspline.spline.fit.penalty import fit_penalty
from simplexspline.spline.geometry.outside import locate
from simplexspline.spline.inputs import as_points
from simplexspline.spline.uncertainty.covariance import CovarianceEngine

__all__ = ["COVARIANCES", "FORMAT", "KINDS", "VERSION", "Uncertainty"]

#: Identifier and version of the optional statistics section of a model file.
FORMAT = "simplexspline.statistics"
VERSION = 1

#: Arrays of the statistics section (the others are scalars): packed upper triangles of the
#: Gram blocks (J, d_hat (d_hat + 1) / 2), point counts (J,), optional penalty blocks.
ARRAYS = ("gram", "counts", "penalty")

#: Interval kinds: for the fitted function (``'confidence'``) or for a new observation
#: (``'prediction'``).
KINDS = ("confidence", "prediction")

#: Covariance of a regularised (ridge / penalised) estimate: the sandwich (variance of the
#: estimate) or the Bayesian posterior.
COVARIANCES = ("frequentist", "bayesian")

#: :meth:`Uncertainty.covariance` (dense, J*d_hat x J*d_hat) refuses larger problems.
DENSE_LIMIT = 6000

#: Memory for the right-hand sides solved at once (bytes, about six arrays of the chunk).
CHUNK_BYTES = 96 << 20

#: Points per chunk when evaluating standard errors.
POINT_CHUNK = 1 << 15

#: The basis of the constrained coefficient space (M x p) is formed when it fits in this
#: many bytes; beyond, covariance blocks come from columns of K chunk by chunk.
BASIS_BYTES = 256 << 20


class Uncertainty:
    """Covariance of a fitted spline's B-coefficients and of its predictions.

    Holds the sufficient statistics of the fit (the per-simplex Gram blocks ``X_j'WX_j``,
    the residual sum of squares, the number of observations) and the fit's policy. Made by
    :meth:`from_fit` (usually through :meth:`SimplexSpline.with_statistics`) or read from a
    model file; the factorisation is built on first use.

    Parameters
    ----------
    space : SplineSpace
    gram : array_like, shape (J, d_hat, d_hat)
        Per-simplex Gram blocks ``X_j' W X_j`` (symmetrised).
    counts : array_like of int, shape (J,)
        Data points per simplex.
    nobs : int
        Number of observations N (with non-zero weight).
    rss : float
        Weighted residual sum of squares of the fit.
    policy : {'raise', 'minnorm', 'ridge'}
        The fit's ``on_insufficient`` policy.
    ridge : float
        Absolute ridge weight of the fit (``SolveInfo.ridge``; 0 without a ridge).
    penalty : array_like, shape (J, d_hat, d_hat), optional
        Absolute penalty blocks ``lam * P_j`` of a penalised fit (None: no penalty).
    covariance : {'frequentist', 'bayesian'}, optional
        For regularised fits (see the module notes); default 'bayesian' with a penalty,
        'frequentist' otherwise. Irrelevant without regularisation.
    absolute_weights : bool
        True: the weights are the inverse noise variances themselves, sigma^2 = 1 and the
        quantiles are normal. False: sigma^2 is estimated from the residuals, t quantiles.
    effective_parameters : float, optional
        p when already known (saved models); computed on first use otherwise.

    Examples
    --------
    >>> import numpy as np
    >>> from simplexspline import Triangulation, SplineSpace
    >>> rng = np.random.default_rng(0)
    >>> x = rng.random((500, 2))
    >>> y = np.sin(3 * x[:, 0]) + 0.1 * rng.normal(size=500)
    >>> space = SplineSpace(Triangulation.grid([0, 0], [1, 1], (2, 2)), degree=2, continuity=1)
    >>> ne = space.normal_equations(x, y)
    >>> spline = space.solve(ne).with_statistics(ne)
    >>> se = spline.standard_error([[0.5, 0.5]])          # standard error of s(0.5, 0.5)
    >>> bool(0.005 < se[0] < 0.05)
    True
    >>> lo, hi = spline.confidence_interval([[0.5, 0.5]], level=0.95)
    """

    def __init__(self, space, gram, counts, *, nobs: int, rss: float, policy: str = "raise",
                 ridge: float = 0.0, penalty=None, covariance: str | None = None,
                 absolute_weights: bool = False, effective_parameters: float | None = None):
        J, dhat = space.triangulation.nsimplex, space.nbasis
        gram = np.asarray(gram, dtype=float)
        if gram.shape != (J, dhat, dhat):
            raise InputError(f"gram must have shape {(J, dhat, dhat)}, got {gram.shape}")
        if not np.all(np.isfinite(gram)):
            raise InputError("gram blocks contain NaN or inf")
        counts = np.asarray(counts)
        if counts.shape != (J,) or not np.issubdtype(counts.dtype, np.integer) or (
                counts.size and counts.min() < 0):
            raise InputError(f"counts must be {J} non-negative integers")
        if policy not in POLICIES:
            raise InputError(f"policy must be one of {POLICIES}, got {policy!r}")
        if not (np.isfinite(ridge) and ridge >= 0):
            raise InputError(f"ridge must be a finite number >= 0, got {ridge!r}")
        if penalty is not None:
            penalty = np.asarray(penalty, dtype=float)
            if penalty.shape != (J, dhat, dhat) or not np.all(np.isfinite(penalty)):
                raise InputError(f"penalty must be finite blocks of shape {(J, dhat, dhat)}, "
                                 f"got {penalty.shape}")
            penalty = 0.5 * (penalty + penalty.transpose(0, 2, 1))
        if covariance is None:
            covariance = "bayesian" if penalty is not None else "frequentist"
        if covariance not in COVARIANCES:
            raise InputError(f"covariance must be one of {COVARIANCES}, got {covariance!r}")
        if not (np.isfinite(rss) and rss >= 0):
            raise InputError(f"rss must be a finite number >= 0, got {rss!r}")
        if int(nobs) != nobs or nobs < 0:
            raise InputError(f"nobs must be a non-negative integer, got {nobs!r}")
        self.space = space
        self.gram = 0.5 * (gram + gram.transpose(0, 2, 1))
        self.counts = counts.astype(np.int64)
        self.nobs = int(nobs)
        self.rss = float(rss)
        self.policy = policy
        self.ridge = float(ridge)
        self.penalty = penalty
        self.covariance_type = covariance
        self.absolute_weights = bool(absolute_weights)
        self._p = None if effective_parameters is None else float(effective_parameters)
        self._blocks = np.zeros((J, dhat, dhat))  # unscaled covariance blocks (sigma^2 = 1)
        self._leverage = np.zeros(J)  # trace(Q_j B_j), B_j the block of K: sums to p
        self._done = np.zeros(J, dtype=bool)
        self._engine = None

    def __repr__(self) -> str:
        p = "?" if self._p is None else f"{self._p:g}"
        reg = f", covariance={self.covariance_type!r}" if self.regularized else ""
        return (f"Uncertainty(N={self.nobs}, p={p}, policy={self.policy!r}{reg}, "
                f"absolute_weights={self.absolute_weights})")

    @property
    def regularized(self) -> bool:
        """True for a ridge or penalised fit (biased estimate)."""
        return self.ridge > 0 or self.penalty is not None

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_fit(cls, spline, normal_equations, *, absolute_weights: bool = False,
                 nobs: int | None = None, on_insufficient: str | None = None,
                 ridge: float | None = None, penalty=None, covariance: str | None = None,
                 check: bool = True) -> Uncertainty:
        """Statistics of ``spline`` fitted to the data accumulated in ``normal_equations``.

        Parameters
        ----------
        spline : SimplexSpline
            The fitted spline.
        normal_equations : NormalEquations
            The accumulator it was solved from (same triangulation and degree).
        absolute_weights : bool, default False
            Take the weights as the inverse noise variances (sigma^2 = 1, normal quantiles),
            like ``absolute_sigma`` of :func:`scipy.optimize.curve_fit`. By default sigma^2
            is estimated from the residuals (weights relative; ~1 if they were absolute and
            right).
        nobs : int, optional
            Number of observations N; default: all accumulated points. Give it when some
            points had zero weight (they count as points in the accumulator).
        on_insufficient : {'raise', 'minnorm', 'ridge'}, optional
            The fit's policy; default ``spline.info.policy`` (or ``'raise'``).
        ridge : float, optional
            The fit's relative ridge weight (as given to ``fit``); default: the absolute
            weight in ``spline.info``.
        penalty : array_like, shape (J, d_hat, d_hat), optional
            Absolute penalty blocks ``lam * P`` of a penalised fit; default: rebuilt from
            ``spline.info.regularization`` (needed only for custom penalties).
        covariance : {'frequentist', 'bayesian'}, optional
            For regularised fits; default 'bayesian' with a penalty, else 'frequentist'.
        check : bool, default True
            Check that ``spline``'s coefficients solve these normal equations (one solve).

        Raises
        ------
        InputError
            Normal equations of another space, or of other data than the fit's.
        InsufficientDataError
            No data, or coefficients left undetermined under ``'raise'``.
        """
        ne = normal_equations
        if not isinstance(ne, NormalEquations):
            raise InputError("with_statistics() takes the NormalEquations accumulator the "
                             "spline was solved from (space.normal_equations(x, y, weights))")
        ne.check_space(spline.triangulation, spline.degree)
        if ne.npoints == 0 or not np.any(ne.wsum > 0):
            raise InsufficientDataError(
                "no data (or only zero weights) in the normal equations: statistics need the "
                "data the spline was fitted to", np.arange(ne.counts.size), ne.counts)
        info = spline.info
        policy = on_insufficient or (info.policy if info is not None else "raise")
        Q, q = ne.XtWX, ne.XtWy
        if ridge is not None:
            if not (np.isfinite(ridge) and ridge >= 0):
                raise InputError(f"ridge must be a finite number >= 0, got {ridge!r}")
            nonempty = max(int((ne.counts > 0).sum()) * Q.shape[1], 1)
            lam = float(ridge) * float(np.einsum("jkk->", Q) / nonempty)
        elif info is not None:
            lam = float(info.ridge)
        else:
            lam = 0.0
        if penalty is None:
            penalty = fit_penalty(spline)
        coef = spline.coefficients
        rss = float(ne.ytWy - 2.0 * np.einsum("jk,jk->", coef, q)
                    + np.einsum("jk,jkl,jl->", coef, Q, coef))
        n = ne.npoints if nobs is None else nobs
        if nobs is not None and (int(nobs) != nobs or not 0 < nobs <= ne.npoints):
            raise InputError(f"nobs must be an integer in 1..{ne.npoints} (the accumulated "
                             f"points), got {nobs!r}")
        out = cls(spline.space, Q, ne.counts, nobs=int(n), rss=max(rss, 0.0), policy=policy,
                  ridge=lam, penalty=penalty, covariance=covariance,
                  absolute_weights=absolute_weights)
        if check:
            refit = out.coefficients_for(q)
            err = np.abs(refit - coef).max()
            size = max(np.abs(coef).max(), np.abs(refit).max(), 1e-300)
            if not err <= 1e-6 * size:
                raise InputError(
                    "the normal equations do not belong to this fit: solving them gives "
                    f"coefficients that differ by {err:.3g} (relative {err / size:.2g}) from "
                    "the spline's. Pass the accumulator the spline was solved from, and the "
                    "same on_insufficient / ridge / penalty")
        return out

    # ------------------------------------------------------------------ noise level
    @property
    def effective_parameters(self) -> float:
        """p = trace of the hat matrix: the dimension of the constrained coefficient space
        (minus undetermined directions under ``'minnorm'``); less with a ridge or penalty
        (the effective degrees of freedom).

        Computed from all covariance blocks on first use (M solves).
        """
        if self._p is None:
            self._ensure(np.arange(self.space.triangulation.nsimplex))
            p = float(self._leverage.sum())
            if not self.regularized and abs(p - round(p)) < 1e-6 * max(p, 1.0):
                p = float(round(p))  # an exact dimension (the trace of a projection)
            self._p = p
        return self._p

    @property
    def dof(self) -> float:
        """Residual degrees of freedom N - p."""
        return self.nobs - self.effective_parameters

    @property
    def sigma2_estimate(self) -> float:
        """RSS / (N - p): the estimated variance of an observation of unit weight (about 1
        when the weights are the true inverse noise variances).

        Raises
        ------
        InsufficientDataError
            When N <= p.
        """
        dof = self.dof
        if not dof > 0:
            raise InsufficientDataError(
                f"cannot estimate the noise variance: N = {self.nobs} observations for "
                f"p = {self.effective_parameters:g} effective parameters (N - p = {dof:g}). "
                "Add data, lower the degree or coarsen the triangulation, or fit with "
                "weights = inverse noise variances and absolute_weights=True")
        return self.rss / dof

    @property
    def sigma2(self) -> float:
        """The noise variance used for the covariance: 1 with ``absolute_weights``, else
        :attr:`sigma2_estimate`."""
        return 1.0 if self.absolute_weights else self.sigma2_estimate

    def quantile(self, level: float) -> float:
        """Two-sided quantile for a ``level`` interval: Student t with N - p degrees of
        freedom, or normal with ``absolute_weights``."""
        from scipy import stats  # lazy: scipy.stats is slow to import

        if not (isinstance(level, (int, float, np.floating)) and 0.0 < level < 1.0):
            raise InputError(f"level must be a probability in (0, 1), e.g. 0.95, got {level!r}")
        prob = 0.5 + 0.5 * float(level)
        if self.absolute_weights:
            return float(stats.norm.ppf(prob))
        self.sigma2_estimate  # noqa: B018 - raises when N <= p
        return float(stats.t.ppf(prob, self.dof))

    # ------------------------------------------------------------------ points
    def _locate(self, x, outside: str):
        tri = self.space.triangulation
        pts = as_points(x, name="x", ndim=tri.ndim)
        sid, _ = locate(tri, pts, outside)
        return pts, sid

    def unscaled_variance(self, x, *, outside: str = "nan") -> np.ndarray:
        """``v' Cov(g) v / sigma^2`` at each point: the variance of the prediction for
        sigma^2 = 1 (shape (N,)).

        NaN outside the triangulation (``outside='nan'``) and in simplices whose
        coefficients the data do not determine (``SolveInfo.undetermined_simplices``: the
        prediction there is fixed by the policy, not by data).
        """
        pts, sid = self._locate(x, outside)
        out = np.full(len(pts), np.nan)
        idx = np.nonzero(sid >= 0)[0]
        if len(idx) == 0:
            return out
        used = np.unique(sid[idx])
        self._ensure(used)
        tri, d = self.space.triangulation, self.space.degree
        grouped = len(idx) >= 8 * len(used)
        if grouped:  # many points per simplex: one BLAS product per simplex
            idx = idx[np.argsort(sid[idx], kind="stable")]
        with kernels.one_blas_thread():
            for s in range(0, len(idx), POINT_CHUNK):
                rows = idx[s:s + POINT_CHUNK]
                j = sid[rows]
                B = basis_values(tri._locator_barycentric(pts[rows], j), d)
                if grouped:
                    var = np.empty(len(rows))
                    starts = np.flatnonzero(np.r_[True, j[1:] != j[:-1]])
                    for a, e in zip(starts, np.r_[starts[1:], len(rows)]):
                        b = B[a:e]
                        var[a:e] = np.einsum("nk,nk->n", b @ self._blocks[j[a]], b)
                else:
                    var = ((self._blocks[j] @ B[:, :, None])[..., 0] * B).sum(axis=1)
                out[rows] = var
        bad = self._engine.undetermined_mask[np.where(sid >= 0, sid, 0)] & (sid >= 0)
        out[bad] = np.nan
        return np.maximum(out, 0.0, where=np.isfinite(out), out=out)

    def standard_error(self, x, *, outside: str = "nan") -> np.ndarray:
        """Standard error of the fitted spline's value at each point, shape (N,).

        Parameters
        ----------
        x : array_like, shape (N, n)
        outside : {'nan', 'raise', 'extrapolate'}
            As in :meth:`SimplexSpline.predict`.
        """
        return np.sqrt(self.sigma2 * self.unscaled_variance(x, outside=outside))

    def interval(self, center, x, level: float = 0.95, *, kind: str = "confidence",
                 weights=None, outside: str = "nan"):
        """``(lower, upper)`` = ``center -/+ quantile * se``, see
        :meth:`SimplexSpline.confidence_interval`."""
        if kind not in KINDS:
            raise InputError(f"kind must be one of {KINDS}, got {kind!r}")
        k = self.quantile(level)
        var = self.sigma2 * self.unscaled_variance(x, outside=outside)
        if kind == "prediction":
            w = 1.0 if weights is None else np.asarray(weights, dtype=float)
            if np.ndim(w) not in (0, 1) or (np.ndim(w) == 1 and w.shape != var.shape):
                raise InputError(f"weights must be a number or an array of shape "
                                 f"{var.shape}, got shape {np.shape(w)}")
            if not np.all(np.isfinite(w) & (w > 0)):
                raise InputError("weights of new observations must be finite and > 0 "
                                 "(inverse noise variances, relative like the fit's)")
            var = var + self.sigma2 / w
        half = k * np.sqrt(var)
        center = np.asarray(center, dtype=float)
        return center - half, center + half

    # ------------------------------------------------------------------ coefficients
    def covariance_blocks(self) -> np.ndarray:
        """Covariance of every simplex's B-coefficients, shape (J, d_hat, d_hat).

        ``blocks[j] = Cov(c_j)`` (Eq. 11 order), scaled by sigma^2. NaN for undetermined
        simplices. Computes all of them (M solves) on first use.
        """
        J = self.space.triangulation.nsimplex
        self._ensure(np.arange(J))
        out = self.sigma2 * self._blocks
        out[self._engine.undetermined_mask] = np.nan
        return out

    def covariance(self) -> np.ndarray:
        """Full covariance of the B-coefficients ``c`` (Eq. 24 order), shape
        (J*d_hat, J*d_hat). Only for small problems (J*d_hat <= DENSE_LIMIT).

        Continuity makes it singular: coefficients equated by C^0 are perfectly correlated.
        """
        n = self.space.dim_coefficients
        if n > DENSE_LIMIT:
            raise InputError(
                f"the dense covariance would be {n} x {n} (more than {DENSE_LIMIT} "
                "coefficients): use covariance_blocks() (per simplex) or standard_error(x)")
        eng = self._get_engine()
        with kernels.one_blas_thread():
            Kcols = eng.variance_columns(np.arange(eng.M), chunk_bytes=CHUNK_BYTES,
                                         basis_bytes=BASIS_BYTES)
        G = eng.gather
        cov = self.sigma2 * Kcols[np.ix_(G, G)]
        und = np.repeat(eng.undetermined_mask, self.space.nbasis)
        cov[und, :] = np.nan
        cov[:, und] = np.nan
        return cov

    def coefficients_for(self, XtWy) -> np.ndarray:
        """Refit to new observations at the same points (same weights): the estimator
        applied to ``X'Wy``.

        Parameters
        ----------
        XtWy : array_like, shape (J, d_hat) or (R, J, d_hat)
            Per-simplex right-hand sides (``NormalEquations.XtWy``), R realisations at once.

        Returns
        -------
        ndarray, shape (J, d_hat) or (R, J, d_hat)
            The coefficients the fit would give, from the factorisation already built.
        """
        J, dhat = self.space.triangulation.nsimplex, self.space.nbasis
        q = np.asarray(XtWy, dtype=float)
        single = q.ndim == 2
        q = q[None] if single else q
        if q.shape[1:] != (J, dhat):
            raise InputError(f"XtWy must have shape {(J, dhat)} or (R, {J}, {dhat}), got "
                             f"{np.shape(XtWy)}")
        eng = self._get_engine()
        qg = eng.Gt @ q.reshape(len(q), -1).T  # (M, R)
        with kernels.one_blas_thread():
            g = eng.solve_many(qg)
        coef = g[eng.gather].T.reshape(len(q), J, dhat)
        return coef[0] if single else coef

    @property
    def leverage(self) -> np.ndarray:
        """Per-simplex contributions ``trace(X_j'W X_j B_j)`` to the hat matrix's trace,
        shape (J,) (sum: :attr:`effective_parameters`)."""
        self.effective_parameters  # noqa: B018
        return self._leverage.copy()

    # ------------------------------------------------------------------ persistence
    def state(self) -> tuple[dict, dict]:
        """The model-file section: ``(header, arrays)`` (see docs/model-format.md)."""
        dhat = self.space.nbasis
        iu = np.triu_indices(dhat)
        header = {"format": FORMAT, "version": VERSION, "nobs": self.nobs, "rss": self.rss,
                  "policy": self.policy, "ridge": self.ridge,
                  "covariance": self.covariance_type,
                  "absolute_weights": self.absolute_weights,
                  "effective_parameters": self._p}
        arrays = {"gram": self.gram[:, iu[0], iu[1]], "counts": self.counts}
        if self.penalty is not None:
            arrays["penalty"] = self.penalty[:, iu[0], iu[1]]
        return header, arrays

    @classmethod
    def from_state(cls, space, header: dict, arrays: dict) -> Uncertainty:
        """Inverse of :meth:`state` (raises InputError on inconsistent contents)."""
        if header.get("format") != FORMAT:
            raise InputError(f"not a statistics section (format {header.get('format')!r})")
        if header.get("version") != VERSION:
            raise InputError(f"statistics section version {header.get('version')!r} is not "
                             f"supported (this simplexspline reads {VERSION}); upgrade "
                             "simplexspline")
        J, dhat = space.triangulation.nsimplex, space.nbasis
        npk = dhat * (dhat + 1) // 2
        iu = np.triu_indices(dhat)

        def unpack(name):
            packed = np.asarray(arrays[name], dtype=float)
            if packed.shape != (J, npk):
                raise InputError(f"statistics {name} must have shape {(J, npk)}, got "
                                 f"{packed.shape}")
            out = np.zeros((J, dhat, dhat))
            out[:, iu[0], iu[1]] = packed
            out[:, iu[1], iu[0]] = packed
            return out

        if "gram" not in arrays or "counts" not in arrays:
            raise InputError("the statistics section lacks its gram or counts arrays")
        gram = unpack("gram")
        penalty = unpack("penalty") if arrays.get("penalty") is not None else None
        counts = np.asarray(arrays["counts"])
        if counts.dtype.kind == "f" and np.all(counts == np.round(counts)):
            counts = counts.astype(np.int64)
        p = header.get("effective_parameters")
        return cls(space, gram, counts, nobs=header["nobs"], rss=float(header["rss"]),
                   policy=header["policy"], ridge=float(header["ridge"]),
                   penalty=penalty, covariance=header.get("covariance"),
                   absolute_weights=bool(header["absolute_weights"]),
                   effective_parameters=None if p is None else float(p))

    # ------------------------------------------------------------------ work
    def _get_engine(self) -> CovarianceEngine:
        if self._engine is None:
            self._engine = CovarianceEngine(self.space, self.gram, self.counts, self.policy,
                                   self.ridge, self.penalty,
                                   self.covariance_type == "frequentist")
        return self._engine

    def _ensure(self, simplices: np.ndarray) -> None:
        """Compute the covariance blocks of ``simplices`` not done yet."""
        with kernels.one_blas_thread():
            self._ensure_blocks(simplices)

    def _ensure_blocks(self, simplices: np.ndarray) -> None:
        eng = self._get_engine()
        todo = simplices[~self._done[simplices]]
        if len(todo) == 0:
            return
        rank = eng.fill_blocks(todo, self.gram, self._blocks, self._leverage,
                               chunk_bytes=CHUNK_BYTES, basis_bytes=BASIS_BYTES)
        if rank is None:  # column path: the blocks of ``todo``
            self._done[todo] = True
            return
        self._done[:] = True  # basis path: every block at once
        if self._p is None and not self.regularized:
            self._p = float(rank)
