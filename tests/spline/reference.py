"""Dense, deliberately naive reference implementations for the spline tests.

Nothing here imports :mod:`simplexspline`: every function is written directly from the
paper's equations (de Visser, Mulder, Chu, AIAA 2010-7950, Sections II-III) so that the
package can be checked against an independent implementation.  Only for small problems.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

# --------------------------------------------------------------------------------------
# Multi-indices and the B-form (Eq. 9-17)
# --------------------------------------------------------------------------------------


def multi_indices(n: int, d: int) -> np.ndarray:
    """All kappa in N^(n+1) with |kappa| = d, in the order of Eq. 11 (lexicographically
    descending: (d,0..0) first, (0..0,d) last)."""
    out = [k for k in itertools.product(range(d, -1, -1), repeat=n + 1) if sum(k) == d]
    return np.array(out, dtype=int).reshape(-1, n + 1)


def num_basis(n: int, d: int) -> int:
    return math.comb(d + n, n)


def index_map(n: int, d: int) -> dict:
    return {tuple(k): i for i, k in enumerate(multi_indices(n, d))}


def basis_values(b: np.ndarray, d: int) -> np.ndarray:
    """B^d_kappa(b) = d!/kappa! b^kappa for b of shape (N, n+1) (Eq. 14)."""
    b = np.atleast_2d(np.asarray(b, dtype=float))
    K = multi_indices(b.shape[1] - 1, d)
    coef = np.array([math.factorial(d) / np.prod([math.factorial(k) for k in kap]) for kap in K])
    return coef[None, :] * np.prod(b[:, None, :] ** K[None, :, :], axis=2)


def bnet_points(V: np.ndarray, d: int) -> np.ndarray:
    """Eq. 17: positions sum_i kappa_i v_i / d of the B-coefficients; V (n+1, n)."""
    V = np.asarray(V, dtype=float)
    K = multi_indices(V.shape[1], d)
    if d == 0:
        return V.mean(axis=0, keepdims=True)
    return K @ V / d


# --------------------------------------------------------------------------------------
# Simplices and triangulations
# --------------------------------------------------------------------------------------


def barycentric(V: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Barycentric coordinates of points x (N, n) w.r.t. the simplex V (n+1, n) (Eq. 3-4)."""
    V = np.asarray(V, dtype=float)
    x = np.atleast_2d(np.asarray(x, dtype=float))
    n = V.shape[1]
    A = np.vstack([V.T, np.ones(n + 1)])
    rhs = np.vstack([x.T, np.ones(len(x))])
    return np.linalg.solve(A, rhs).T


def simplex_volume(V: np.ndarray) -> float:
    V = np.asarray(V, dtype=float)
    n = V.shape[1]
    return abs(np.linalg.det((V[1:] - V[0]).T)) / math.factorial(n)


def _facet_area(F: np.ndarray) -> float:
    """(n-1)-volume of the facet with vertices F (n, n) embedded in R^n."""
    E = (F[1:] - F[0]).T  # (n, n-1)
    k = E.shape[1]
    if k == 0:
        return 1.0
    return math.sqrt(max(np.linalg.det(E.T @ E), 0.0)) / math.factorial(k)


def quality(V: np.ndarray) -> float:
    """Normalised radius ratio n * r_in / r_circ of the simplex V (n+1, n)."""
    V = np.asarray(V, dtype=float)
    n = V.shape[1]
    vol = simplex_volume(V)
    area = sum(_facet_area(np.delete(V, i, axis=0)) for i in range(n + 1))
    r_in = n * vol / area
    # circumcentre c: |c - v_i|^2 equal for all i  ->  2 (v_i - v_0) . c = |v_i|^2 - |v_0|^2
    A = 2.0 * (V[1:] - V[0])
    rhs = (V[1:] ** 2).sum(1) - (V[0] ** 2).sum()
    c = np.linalg.solve(A, rhs)
    r_circ = np.linalg.norm(c - V[0])
    return n * r_in / r_circ


def regular_simplex(n: int, scale: float = 1.0) -> np.ndarray:
    """Vertices (n+1, n) of a regular n-simplex with edge length scale*sqrt(2)."""
    E = np.eye(n + 1)
    centred = E - E.mean(axis=0)
    Q, _ = np.linalg.qr(centred.T)  # orthonormal basis of the hyperplane sum = 0 (first n)
    return scale * centred @ Q[:, :n]


def locate(vertices: np.ndarray, simplices: np.ndarray, x: np.ndarray, tol: float = 1e-12):
    """Brute force: index of the first simplex containing each point (-1 if none)."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    out = np.full(len(x), -1, dtype=np.intp)
    for j, s in enumerate(simplices):
        b = barycentric(vertices[s], x)
        inside = (b.min(axis=1) >= -tol) & (out < 0)
        out[inside] = j
    return out


@dataclass
class Facets:
    simplices: np.ndarray  # (F, 2)
    out_positions: np.ndarray  # (F, 2)
    vertices: np.ndarray  # (F, n) sorted global ids
    boundary: list = field(default_factory=list)  # (simplex, local pos) of boundary facets


def interior_facets(simplices: np.ndarray) -> Facets:
    simplices = np.asarray(simplices)
    table: dict = {}
    for j, s in enumerate(simplices):
        for i in range(len(s)):
            key = tuple(sorted(np.delete(s, i).tolist()))
            table.setdefault(key, []).append((j, i))
    sims, outs, verts, boundary = [], [], [], []
    for key, owners in table.items():
        if len(owners) == 2:
            (j1, i1), (j2, i2) = owners
            sims.append((j1, j2))
            outs.append((i1, i2))
            verts.append(key)
        elif len(owners) == 1:
            boundary.append(owners[0])
        else:  # pragma: no cover - only for invalid triangulations
            raise ValueError(f"facet {key} shared by {len(owners)} simplices")
    n = simplices.shape[1] - 1
    return Facets(
        np.array(sims, dtype=int).reshape(-1, 2),
        np.array(outs, dtype=int).reshape(-1, 2),
        np.array(verts, dtype=int).reshape(-1, n),
        boundary,
    )


def kuhn_grid(lower, upper, shape):
    """Kuhn/Freudenthal triangulation of a box: n! simplices per cell with vertices
    z, z + e_pi1, z + e_pi1 + e_pi2, ..., z + 1 (in cell units)."""
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    shape = tuple(int(s) for s in shape)
    n = len(shape)
    grids = np.meshgrid(*[np.linspace(lower[i], upper[i], shape[i] + 1) for i in range(n)],
                        indexing="ij")
    vertices = np.stack([g.ravel() for g in grids], axis=1)
    dims = tuple(s + 1 for s in shape)
    simplices = []
    for cell in itertools.product(*[range(s) for s in shape]):
        for perm in itertools.permutations(range(n)):
            z = list(cell)
            ids = [np.ravel_multi_index(z, dims)]
            for p in perm:
                z[p] += 1
                ids.append(np.ravel_multi_index(z, dims))
            simplices.append(ids)
    return vertices, np.array(simplices, dtype=int)


def star_triangulation(n: int, rng: np.random.Generator):
    """A simplex split at an interior point into n+1 simplices (an interior vertex)."""
    V = regular_simplex(n, scale=1.5) + 0.05 * rng.standard_normal((n + 1, n))
    w = rng.dirichlet(np.full(n + 1, 8.0))
    centre = w @ V
    vertices = np.vstack([V, centre])
    simplices = np.array([[k for k in range(n + 1) if k != i] + [n + 1] for i in range(n + 1)])
    return vertices, simplices


# --------------------------------------------------------------------------------------
# Regression matrix, smoothness matrix, solvers (Eq. 20-42)
# --------------------------------------------------------------------------------------


def design_matrix(vertices, simplices, x, d, where=None) -> np.ndarray:
    """Dense X (N, J*d_hat) of Eq. 36; where: simplex index of each point (default locate)."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    n = vertices.shape[1]
    dh = num_basis(n, d)
    if where is None:
        where = locate(vertices, simplices, x)
    if np.any(where < 0):
        raise ValueError("points outside the triangulation")
    X = np.zeros((len(x), len(simplices) * dh))
    for j in np.unique(where):
        rows = np.flatnonzero(where == j)
        b = barycentric(vertices[simplices[j]], x[rows])
        X[rows, j * dh:(j + 1) * dh] = basis_values(b, d)
    return X


def smoothness_matrix(vertices, simplices, d: int, r: int) -> np.ndarray:
    """Dense unreduced H (E*R, J*d_hat) from Eq. 20/21 with position-by-position vertex
    mapping, written independently of the package."""
    vertices = np.asarray(vertices, dtype=float)
    simplices = np.asarray(simplices)
    n = vertices.shape[1]
    J = len(simplices)
    dh = num_basis(n, d)
    idx = index_map(n, d)
    fac = interior_facets(simplices)
    rows = []
    for (s1, s2), (o1, o2), shared in zip(fac.simplices, fac.out_positions, fac.vertices):
        p1 = [int(np.flatnonzero(simplices[s1] == g)[0]) for g in shared]
        p2 = [int(np.flatnonzero(simplices[s2] == g)[0]) for g in shared]
        sigma = vertices[simplices[s1][o1]]
        bs = barycentric(vertices[simplices[s2]], sigma[None, :])[0]
        for m in range(r + 1):
            gammas = multi_indices(n, m)
            Bg = basis_values(bs[None, :], m)[0]
            for kp in multi_indices(n - 1, d - m):
                row = np.zeros(J * dh)
                k1 = np.zeros(n + 1, dtype=int)
                k1[p1] = kp
                k1[o1] = m
                row[s1 * dh + idx[tuple(k1)]] += 1.0
                base = np.zeros(n + 1, dtype=int)
                base[p2] = kp
                for g, bg in zip(gammas, Bg):
                    row[s2 * dh + idx[tuple(base + g)]] -= bg
                rows.append(row)
    if not rows:
        return np.zeros((0, J * dh))
    return np.array(rows)


def conditions_per_facet(n: int, d: int, r: int) -> int:
    """R of Eq. 22."""
    return sum(math.comb(d - m + n - 1, n - 1) for m in range(r + 1))


def svd_rank(A: np.ndarray, rtol: float = 1e-10) -> int:
    A = np.asarray(A, dtype=float)
    if A.size == 0:
        return 0
    s = np.linalg.svd(A, compute_uv=False)
    return int(np.sum(s > rtol * max(s[0], 1e-300)))


def nullspace_solution(X, y, H, w=None, rcond=None) -> np.ndarray:
    """min ||W^(1/2)(y - X c)|| s.t. H c = 0 via an orthonormal null-space basis of H;
    the minimum-norm minimiser if the problem is not fully determined."""
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    sw = np.ones(len(y)) if w is None else np.sqrt(np.asarray(w, dtype=float))
    if H.shape[0] == 0:
        Z = np.eye(X.shape[1])
    else:
        Z = scipy.linalg.null_space(H, rcond=1e-10 if rcond is None else rcond)
    A = sw[:, None] * (X @ Z)
    a = np.linalg.pinv(A, rcond=1e-12) @ (sw * y)
    return Z @ a


def kkt_solution(X, y, H, w=None) -> np.ndarray:
    """Eq. 40-42: c = C1 X'WY with [C1 C2; C3 C4] = pinv of the KKT matrix."""
    X = np.asarray(X, dtype=float)
    w = np.ones(len(y)) if w is None else np.asarray(w, dtype=float)
    XtWX = X.T @ (w[:, None] * X)
    XtWy = X.T @ (w * y)
    m = H.shape[0]
    K = np.block([[XtWX, H.T], [H, np.zeros((m, m))]])
    sol = np.linalg.pinv(K, rcond=1e-13) @ np.concatenate([XtWy, np.zeros(m)])
    return sol[: X.shape[1]]


# --------------------------------------------------------------------------------------
# Polynomials with exact derivatives
# --------------------------------------------------------------------------------------


class Poly:
    """p(x) = sum_e a_e prod_i (x_i - x0_i)^{e_i} over exponents with |e| <= degree."""

    def __init__(self, exps: np.ndarray, coefs: np.ndarray, centre: np.ndarray):
        self.exps = np.asarray(exps, dtype=int).reshape(-1, len(centre))
        self.coefs = np.asarray(coefs, dtype=float)
        self.centre = np.asarray(centre, dtype=float)

    @classmethod
    def random(cls, n: int, degree: int, rng: np.random.Generator, centre=None, exact=False):
        exps = [e for k in range(degree + 1) for e in multi_indices(n - 1, k)] if n > 0 else []
        exps = np.array(exps, dtype=int).reshape(-1, n)
        coefs = rng.uniform(-1.0, 1.0, len(exps))
        if exact:  # make sure the top degree really is present
            top = np.flatnonzero(exps.sum(1) == degree)
            coefs[top[0]] = 1.0 + rng.uniform()
        centre = np.zeros(n) if centre is None else np.asarray(centre, dtype=float)
        return cls(exps, coefs, centre)

    @property
    def degree(self) -> int:
        nz = self.exps[np.abs(self.coefs) > 0]
        return int(nz.sum(1).max()) if len(nz) else 0

    def derivative(self, order) -> Poly:
        order = np.asarray(order, dtype=int)
        keep = np.all(self.exps >= order[None, :], axis=1)
        exps = self.exps[keep]
        fac = np.ones(len(exps))
        for i, o in enumerate(order):
            for t in range(o):
                fac *= exps[:, i] - t
        return Poly(exps - order[None, :], self.coefs[keep] * fac, self.centre)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        x = np.atleast_2d(np.asarray(x, dtype=float)) - self.centre
        if len(self.exps) == 0:
            return np.zeros(len(x))
        return np.prod(x[:, None, :] ** self.exps[None, :, :], axis=2) @ self.coefs

    def gradient(self, x: np.ndarray) -> np.ndarray:
        n = len(self.centre)
        return np.stack([self.derivative(np.eye(n, dtype=int)[i])(x) for i in range(n)], axis=1)


def all_orders(n: int, max_order: int):
    """All derivative orders alpha in N^n with |alpha| <= max_order."""
    out = []
    for k in range(max_order + 1):
        if n == 0:
            break
        out.extend(tuple(int(v) for v in e) for e in multi_indices(n - 1, k))
    return out


# --------------------------------------------------------------------------------------
# Sampling
# --------------------------------------------------------------------------------------


def points_in_simplices(vertices, simplices, per_simplex: int, rng, alpha: float = 1.0):
    """Random points strictly inside every simplex (Dirichlet barycentric coordinates).

    Returns x (J*per_simplex, n) and the simplex index of every point.
    """
    vertices = np.asarray(vertices, dtype=float)
    simplices = np.asarray(simplices)
    J, n1 = simplices.shape
    b = rng.dirichlet(np.full(n1, alpha), size=(J, per_simplex))  # (J, P, n+1)
    b = np.clip(b, 1e-6, None)
    b /= b.sum(axis=2, keepdims=True)
    x = np.einsum("jpk,jkn->jpn", b, vertices[simplices])
    where = np.repeat(np.arange(J), per_simplex)
    return x.reshape(-1, vertices.shape[1]), where
