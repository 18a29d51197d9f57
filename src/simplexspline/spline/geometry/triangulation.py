"""Triangulations of n-dimensional space: construction, validation, facets, location.

A triangulation (paper Eq. 5-6) is a set of J non-overlapping n-simplices that meet only in
common faces. :class:`Triangulation` holds its vertices and simplices, checks that it is
valid, finds the interior facets and neighbours the continuity conditions need, and
locates points.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from math import factorial

import numpy as np
from scipy.spatial import cKDTree

from simplexspline.errors import DegenerateSimplexError, InputError, TriangulationError
from simplexspline.spline.geometry.barycentric import (
    DEGENERACY_TOL,
    barycentric,
    simplex_quality,
    simplex_transforms,
    simplex_volumes,
)
from simplexspline.spline.geometry.location import (
    INSIDE_TOL,
    BucketLocator,
    GridLocator,
    WalkLocator,
    kuhn_permutations,
)
from simplexspline.spline import kernels
from simplexspline.spline.inputs import as_points

__all__ = ["Triangulation", "Facets"]

#: Default radius-ratio threshold below which :meth:`Triangulation.slivers` reports a
#: simplex. Kuhn simplices have quality >= 0.54 up to n = 6; Delaunay slivers go far lower.
SLIVER_THRESHOLD = 0.1


@dataclass(frozen=True)
class Facets:
    """Interior facets of a triangulation.

    Attributes
    ----------
    simplices : ndarray of int, shape (F, 2)
        The two simplices sharing each facet.
    out_positions : ndarray of int, shape (F, 2)
        Local position (0..n) in each simplex of its vertex that is not on the facet.
    vertices : ndarray of int, shape (F, n)
        Global vertex ids of the facet, sorted.
    """

    simplices: np.ndarray
    out_positions: np.ndarray
    vertices: np.ndarray

    def __len__(self) -> int:
        return len(self.simplices)


class Triangulation:
    """A conforming triangulation of simplices in n-dimensional space.

    Parameters
    ----------
    vertices : array_like, shape (V, n)
        Vertex coordinates.
    simplices : array_like of int, shape (J, n + 1)
        Vertex indices of each simplex; any vertex order.

    Raises
    ------
    InputError
        Wrong shapes, NaN/inf coordinates, indices out of range or repeated in a simplex.
    DegenerateSimplexError
        Simplices of (numerically) zero volume; ``.simplices`` lists them.
    TriangulationError
        Simplices that overlap, or a facet shared by more than two simplices, or a
        non-conforming (hanging-vertex) contact.

    Examples
    --------
    >>> tri = Triangulation.grid([0, 0], [1, 1], (2, 2))
    >>> tri.nsimplex, tri.ndim
    (8, 2)
    >>> tri.locate([[0.1, 0.2], [2.0, 0.0]]).tolist()
    [1, -1]
    """

    def __init__(self, vertices, simplices, *, _kind: str = "explicit", _grid=None, _check=True):
        vertices = as_points(vertices, name="vertices")
        simplices = np.asarray(simplices)
        n = vertices.shape[1]
        if simplices.ndim != 2 or simplices.shape[1] != n + 1:
            raise InputError(
                f"simplices must have shape (J, n+1) = (J, {n + 1}) for {n}-D vertices, "
                f"got {simplices.shape}"
            )
        if len(simplices) == 0:
            raise InputError("a triangulation needs at least one simplex")
        if not np.issubdtype(simplices.dtype, np.integer):
            if not np.all(np.isfinite(simplices)) or np.any(simplices != np.round(simplices)):
                raise InputError("simplices must hold integer vertex indices")
        simplices = simplices.astype(np.int64)
        if simplices.min() < 0 or simplices.max() >= len(vertices):
            raise InputError(
                f"simplex vertex indices must lie in 0..{len(vertices) - 1}, "
                f"got {simplices.min()}..{simplices.max()}"
            )
        srt = np.sort(simplices, axis=1)
        rep = np.nonzero(np.any(srt[:, 1:] == srt[:, :-1], axis=1))[0]
        if len(rep):
            raise DegenerateSimplexError(
                f"{len(rep)} simplices repeat a vertex (degenerate): {_ids(rep)}", rep
            )
        self.vertices = vertices
        self.simplices = simplices
        self.kind = _kind
        self._grid = _grid
        self.vertices.setflags(write=False)
        self.simplices.setflags(write=False)
        origin, tinv, sine = simplex_transforms(self.corners)
        bad = np.nonzero(sine <= DEGENERACY_TOL)[0]
        if len(bad):
            raise DegenerateSimplexError(
                f"{len(bad)} simplices have zero volume (degenerate): {_ids(bad)}; remove "
                "them or perturb their vertices",
                bad,
            )
        self._origin = origin
        self._tinv = tinv
        if _check:
            self._check_conforming()

    # ------------------------------------------------------------------ constructors
    @classmethod
    def delaunay(cls, points, *, qhull_options: str | None = None) -> Triangulation:
        """Delaunay triangulation of points (scipy/qhull; 1-D: sorted intervals).

        Parameters
        ----------
        points : array_like, shape (V, n)
            The vertices.
        qhull_options : str, optional
            Passed to :class:`scipy.spatial.Delaunay`.

        Notes
        -----
        Delaunay triangulations of scattered points often contain slivers (paper Fig. 4);
        check :meth:`quality` / :meth:`slivers`, or use :meth:`grid` / :meth:`fit`.
        Numerically flat simplices that qhull may return are dropped.
        """
        pts = as_points(points, name="points")
        n = pts.shape[1]
        if n == 1:
            uniq = np.unique(pts[:, 0])
            if len(uniq) < 2:
                raise InputError("a 1-D Delaunay triangulation needs two distinct points")
            order = np.argsort(pts[:, 0], kind="stable")
            first = order[np.searchsorted(pts[order, 0], uniq)]
            simp = np.column_stack([first[:-1], first[1:]])
            return cls(pts, simp, _kind="delaunay", _check=False)
        if len(pts) < n + 1:
            raise InputError(f"{n}-D Delaunay needs at least {n + 1} points, got {len(pts)}")
        from scipy.spatial import Delaunay, QhullError

        try:
            dt = Delaunay(pts, qhull_options=qhull_options)
        except QhullError as exc:
            raise TriangulationError(
                f"qhull could not triangulate the points (are they all in a hyperplane?): "
                f"{str(exc).splitlines()[0]}"
            ) from None
        simp = dt.simplices.astype(np.int64)
        _, _, sine = simplex_transforms(pts[simp])
        keep = sine > DEGENERACY_TOL
        tri = cls(pts, simp[keep], _kind="delaunay", _check=False)
        # qhull's simplices tile the convex hull; with flat ones dropped, a walk stopped
        # at a boundary facet no longer proves a point outside
        tri.__dict__["_convex"] = bool(np.all(keep))
        return tri

    @classmethod
    def grid(cls, lower, upper, shape) -> Triangulation:
        """Kuhn (Freudenthal) triangulation of a box split into cells.

        Each cell with lower corner ``z`` is split into ``n!`` simplices, one per
        permutation ``pi`` of the axes, with vertices ``z, z + e_pi1, z + e_pi1 + e_pi2,
        ..., z + 1`` (in cell units). The triangulation is conforming across cells and
        points are located in O(n log n) without search.

        Parameters
        ----------
        lower, upper : array_like, shape (n,)
            Box corners, ``lower < upper``.
        shape : int or sequence of int, shape (n,)
            Cells per axis (>= 1).
        """
        lower, upper, shape = _box(lower, upper, shape)
        return cls._from_grid(lower, upper, shape, None, kind="grid")

    @classmethod
    def fit(cls, x, shape, *, min_points: int = 1, padding: float = 0.0) -> Triangulation:
        """A well-shaped triangulation fitted to data (the paper's Fig. 5 idea).

        A Kuhn grid triangulation of the data's bounding box, from which every simplex
        holding fewer than ``min_points`` data points is dropped, so that no simplex is
        empty. Scale the variables first (e.g. to unit ranges) so cells are not needles.

        Parameters
        ----------
        x : array_like, shape (N, n)
            The data points.
        shape : int or sequence of int
            Cells per axis of the bounding-box grid.
        min_points : int, default 1
            Minimum number of data points for a simplex to be kept.
        padding : float, default 0
            Enlarge the bounding box by this fraction of its range on each side.
        """
        pts = as_points(x, name="x")
        lower, upper = pts.min(axis=0), pts.max(axis=0)
        flat = np.nonzero(upper <= lower)[0]
        if len(flat):
            raise InputError(
                f"the data have zero range along axis {flat.tolist()}: drop that variable "
                "or fit a lower-dimensional model"
            )
        pad = padding * (upper - lower)
        lower, upper, shape = _box(lower - pad, upper + pad, shape)
        full = cls._from_grid(lower, upper, shape, None, kind="fit")
        sid = full.locate(pts)
        counts = np.bincount(sid[sid >= 0], minlength=full.nsimplex)
        keep = counts >= max(int(min_points), 1)
        if not np.any(keep):
            raise InputError(f"no simplex holds min_points={min_points} data points")
        return cls._from_grid(lower, upper, shape, keep, kind="fit")

    @classmethod
    def _from_grid(cls, lower, upper, shape, keep, *, kind: str) -> Triangulation:
        n = len(shape)
        perms = kuhn_permutations(n)
        nfact = len(perms)
        # Offsets (in node units) of the n+1 vertices of each permutation's simplex.
        offs = np.zeros((nfact, n + 1, n), dtype=np.int64)
        for k in range(n):
            offs[:, k + 1] = offs[:, k]
            offs[np.arange(nfact), k + 1, perms[:, k]] += 1
        cells = np.indices(tuple(shape)).reshape(n, -1).T  # (ncells, n), C order
        nodes = cells[:, None, None, :] + offs[None]  # (ncells, n!, n+1, n)
        node_shape = tuple(np.asarray(shape) + 1)
        simp = np.ravel_multi_index(tuple(np.moveaxis(nodes, -1, 0)), node_shape)
        simp = simp.reshape(-1, n + 1)
        table = np.arange(len(simp), dtype=np.int64)
        if keep is not None:
            simp = simp[keep]
            table = np.full(len(keep), -1, dtype=np.int64)
            table[keep] = np.arange(int(keep.sum()))
        used, inverse = np.unique(simp, return_inverse=True)
        grid_idx = np.stack(np.unravel_index(used, node_shape), axis=1)
        step = (upper - lower) / shape
        verts = lower + grid_idx * step
        verts[grid_idx == shape] = np.broadcast_to(upper, verts.shape)[grid_idx == shape]
        info = {"lower": lower, "upper": upper, "shape": shape, "table": table}
        return cls(verts, inverse.reshape(simp.shape), _kind=kind, _grid=info, _check=False)

    # ------------------------------------------------------------------ basic properties
    @property
    def ndim(self) -> int:
        """Spatial dimension n."""
        return self.vertices.shape[1]

    @property
    def nsimplex(self) -> int:
        """Number of simplices J."""
        return len(self.simplices)

    @cached_property
    def corners(self) -> np.ndarray:
        """Vertex coordinates of every simplex, shape (J, n + 1, n)."""
        c = self.vertices[self.simplices]
        c.setflags(write=False)
        return c

    def same_as(self, other) -> bool:
        """True when ``other`` is this triangulation or one with identical arrays."""
        return self is other or (
            isinstance(other, Triangulation)
            and self.vertices.shape == other.vertices.shape
            and self.simplices.shape == other.simplices.shape
            and np.array_equal(self.vertices, other.vertices)
            and np.array_equal(self.simplices, other.simplices))

    def __repr__(self) -> str:
        return f"Triangulation(kind={self.kind!r}, ndim={self.ndim}, nsimplex={self.nsimplex})"

    # ------------------------------------------------------------------ facets
    @cached_property
    def _facet_table(self):
        n = self.ndim
        nsimp = self.nsimplex
        pos = np.arange(n + 1)
        # Facet opposite local vertex i of simplex j: all other vertices, sorted.
        drop = np.array([np.delete(pos, i) for i in range(n + 1)])  # (n+1, n)
        keys = np.sort(self.simplices[:, drop], axis=2).reshape(-1, n)  # (J*(n+1), n)
        owner = np.repeat(np.arange(nsimp), n + 1)
        local = np.tile(pos, nsimp)
        order = np.lexsort(keys.T[::-1])
        ks = keys[order]
        same = np.all(ks[1:] == ks[:-1], axis=1)
        if np.any(same[1:] & same[:-1]):
            i = int(np.nonzero(same[1:] & same[:-1])[0][0]) + 1
            sims = np.unique(owner[order[i - 1 : i + 2]])
            raise TriangulationError(
                f"facet with vertices {ks[i].tolist()} is shared by more than two simplices "
                f"({sims.tolist()}): the simplices overlap"
            )
        first = np.nonzero(same)[0]
        a, b = order[first], order[first + 1]
        facets = Facets(
            simplices=np.stack([owner[a], owner[b]], axis=1),
            out_positions=np.stack([local[a], local[b]], axis=1),
            vertices=ks[first],
        )
        neighbors = np.full((nsimp, n + 1), -1, dtype=np.int64)
        neighbors[owner[a], local[a]] = owner[b]
        neighbors[owner[b], local[b]] = owner[a]
        return facets, neighbors

    @property
    def facets(self) -> Facets:
        """The interior facets (shared by two simplices); see :class:`Facets`."""
        return self._facet_table[0]

    @property
    def neighbors(self) -> np.ndarray:
        """Neighbour across the facet opposite each local vertex, shape (J, n + 1); -1 on
        the boundary."""
        return self._facet_table[1]

    def out_vertex_coordinates(self) -> np.ndarray:
        """Barycentric coordinates of each interior facet's out-of-facet vertex of simplex
        ``facets.simplices[:, 0]`` with respect to simplex ``facets.simplices[:, 1]``,
        shape (F, n + 1)."""
        f = self.facets
        sigma = self.vertices[self.simplices[f.simplices[:, 0], f.out_positions[:, 0]]]
        other = f.simplices[:, 1]
        return barycentric(sigma, self._origin[other], self._tinv[other])

    def _check_conforming(self) -> None:
        f = self.facets
        if len(f):
            # Across a shared facet the two out-of-facet vertices lie on opposite sides.
            bsig = self.out_vertex_coordinates()[np.arange(len(f)), f.out_positions[:, 1]]
            bad = np.nonzero(bsig >= -INSIDE_TOL)[0]
            if len(bad):
                pairs = f.simplices[bad[:5]].tolist()
                raise TriangulationError(
                    f"{len(bad)} pairs of simplices sharing a facet lie on the same side of "
                    f"it (they overlap), e.g. {pairs}"
                )
        # No point strictly inside a simplex may lie in another simplex; and just outside a
        # boundary facet there must be no simplex (else the contact is non-conforming).
        n = self.ndim
        corners = self.corners
        inner = [corners.mean(axis=1)]
        for i in range(n + 1):
            w = np.full(n + 1, 0.5 / n)
            w[i] = 0.5
            inner.append(np.einsum("i,jin->jn", w, corners))
        probe = np.concatenate(inner)
        owner = np.tile(np.arange(self.nsimplex), n + 2)
        point, simplex = self._buckets.containing(probe, tol=-1e-9)
        clash = simplex != owner[point]
        if np.any(clash):
            k = int(np.nonzero(clash)[0][0])
            raise TriangulationError(
                f"simplices {int(owner[point[k]])} and {int(simplex[k])} overlap"
            )
        bj, bi = np.nonzero(self.neighbors < 0)
        if len(bj):
            fc = (corners[bj].sum(axis=1) - corners[bj, bi]) / n
            # a step of 1e-7 of the distance from the opposite vertex, away from it (no
            # norm: it underflows at coordinates like 1e-300)
            outside = fc + 1e-7 * (fc - corners[bj, bi])
            point, simplex = self._buckets.containing(outside, tol=-1e-12)
            if len(point):
                k = int(point[0])
                raise TriangulationError(
                    f"simplices {int(bj[k])} and {int(simplex[0])} touch without sharing a "
                    "whole facet (a hanging vertex): the triangulation is not conforming"
                )

    # ------------------------------------------------------------------ location
    @cached_property
    def _locator(self):
        if self._grid is not None:
            g = self._grid
            return GridLocator(g["lower"], g["upper"], g["shape"], g["table"])
        if kernels.HAVE_NUMBA:
            return WalkLocator(np.asarray(self.corners), self._origin, self._tinv,
                               self.neighbors, self._convex, self._bucket_locate)
        return self._buckets

    def _bucket_locate(self, pts: np.ndarray) -> np.ndarray:
        """The exact bucket search (the walk's fallback; a method, so it pickles)."""
        return self._buckets.locate(pts)

    @cached_property
    def _buckets(self):
        return BucketLocator(np.asarray(self.corners), self._origin, self._tinv)

    @cached_property
    def _convex(self) -> bool:
        """Whether the simplices cover their vertices' convex hull (then a point beyond a
        boundary facet is outside): checked for Delaunay triangulations by comparing the
        volumes; False for others (their locators never rely on it)."""
        if self.kind != "delaunay":
            return False
        if self.ndim == 1:
            return True
        from scipy.spatial import ConvexHull, QhullError

        try:
            hull = ConvexHull(self.vertices).volume
        except QhullError:
            return False
        return bool(abs(self.volumes().sum() - hull) <= 1e-9 * hull)

    def locate(self, x) -> np.ndarray:
        """Index of the simplex containing each point.

        Parameters
        ----------
        x : array_like, shape (N, n)

        Returns
        -------
        ndarray of int, shape (N,)
            ``-1`` for points outside the triangulation. A point on a shared facet goes
            to one of the simplices that share it.
        """
        pts = as_points(x, name="x", ndim=self.ndim)
        return self._locator.locate(pts)

    def _locate_checked(self, pts: np.ndarray) -> np.ndarray:
        """:meth:`locate` for points already checked by ``as_points`` (kernel)."""
        return self._locator.locate(pts)

    def _locate_evaluate(self, pts: np.ndarray, coef: np.ndarray, degree: int
                         ) -> tuple[np.ndarray, np.ndarray, bool]:
        """Simplex (-1 outside) and value (NaN outside) of the B-form spline with
        coefficients ``coef`` (J, d_hat) at checked points, and whether any point is
        outside; compiled (numba only). On walk triangulations one fused pass: the walk
        hands its barycentric coordinates to the basis."""
        loc = self._locator
        if not isinstance(loc, WalkLocator):
            sid = loc.locate(pts)
            values = kernels.evaluate(pts, sid, self._origin, self._tinv, coef, degree)
            return sid, values, bool((sid < 0).any())
        sid, values, unlocated = kernels.walk_evaluate(pts, loc.plan, coef, degree)
        if not unlocated:
            return sid, values, False
        raw = sid.copy()
        loc.settle(pts, sid)
        redo = np.nonzero((sid != raw) & (sid >= 0))[0]
        values[redo] = kernels.evaluate(pts[redo], sid[redo], self._origin, self._tinv, coef,
                                        degree)
        return sid, values, bool((sid < 0).any())

    def barycentric(self, x, simplices) -> np.ndarray:
        """Barycentric coordinates of points with respect to given simplices.

        Parameters
        ----------
        x : array_like, shape (N, n)
        simplices : array_like of int, shape (N,)

        Returns
        -------
        ndarray, shape (N, n + 1)
            Rows sum to 1; negative entries mean the point is outside that simplex.
        """
        pts = as_points(x, name="x", ndim=self.ndim)
        sid = self._check_ids(simplices, len(pts))
        return barycentric(pts, self._origin[sid], self._tinv[sid])

    def _locator_barycentric(self, pts: np.ndarray, sid: np.ndarray) -> np.ndarray:
        """Barycentric coordinates for validated points and simplex ids (kernel)."""
        return barycentric(pts, self._origin[sid], self._tinv[sid])

    def nearest(self, x, k: int = 8) -> np.ndarray:
        """For each point, the simplex to extrapolate from.

        Among the ``k`` simplices with the nearest centroids, the one whose barycentric
        coordinates of the point are least negative (the point is 'least outside' it).

        Returns
        -------
        ndarray of int, shape (N,)
        """
        pts = as_points(x, name="x", ndim=self.ndim)
        k = int(min(k, self.nsimplex))
        _, cand = self._centroid_tree.query(pts, k=k)
        # at coordinates near the float limit the distances overflow and the tree reports
        # no neighbour (index J): any simplex will do there
        cand = np.asarray(cand).reshape(len(pts), k)
        cand = np.where(cand < self.nsimplex, cand, 0)
        best = np.full(len(pts), -np.inf)
        out = cand[:, 0].copy()
        for i in range(k):
            s = cand[:, i]
            with np.errstate(all="ignore"):
                bmin = barycentric(pts, self._origin[s], self._tinv[s]).min(axis=1)
            better = bmin > best
            best[better] = bmin[better]
            out[better] = s[better]
        return out

    @cached_property
    def _centroid_tree(self):
        return cKDTree(self.centroids())

    def _check_ids(self, simplices, npts: int) -> np.ndarray:
        sid = np.asarray(simplices)
        if sid.shape != (npts,) or not np.issubdtype(sid.dtype, np.integer):
            raise InputError(f"simplices must be {npts} integer indices, got {sid.shape}")
        if npts and (sid.min() < 0 or sid.max() >= self.nsimplex):
            raise InputError(f"simplex indices must lie in 0..{self.nsimplex - 1}")
        return sid.astype(np.int64)

    # ------------------------------------------------------------------ geometry
    def centroids(self) -> np.ndarray:
        """Centroid of every simplex, shape (J, n)."""
        return self.corners.mean(axis=1)

    def volumes(self) -> np.ndarray:
        """Volume of every simplex, shape (J,)."""
        return simplex_volumes(np.asarray(self.corners))

    def quality(self) -> np.ndarray:
        """Normalised radius ratio ``n r_in / r_circ`` per simplex, shape (J,), in (0, 1].

        1 for the regular simplex; small values are slivers or needles, which make the
        B-form badly conditioned (paper Section II.B).
        """
        return simplex_quality(np.asarray(self.corners))

    def slivers(self, threshold: float | None = None) -> np.ndarray:
        """Indices of simplices whose :meth:`quality` is below ``threshold``
        (default :data:`SLIVER_THRESHOLD`)."""
        thr = SLIVER_THRESHOLD if threshold is None else float(threshold)
        return np.nonzero(self.quality() < thr)[0]

    # ------------------------------------------------------------------ serialisation
    def to_arrays(self) -> dict:
        """Arrays and settings that rebuild this triangulation exactly (for model files)."""
        out = {"kind": self.kind, "vertices": self.vertices, "simplices": self.simplices}
        if self._grid is not None:
            out.update({f"grid_{k}": np.asarray(v) for k, v in self._grid.items()})
        return out

    @classmethod
    def from_arrays(cls, data: dict, *, check: bool = True) -> Triangulation:
        """Inverse of :meth:`to_arrays`.

        ``check=False`` skips the (costly) conformity checks of explicit triangulations,
        for arrays that come from a triangulation already validated.
        """
        grid = None
        if "grid_table" in data:
            grid = {
                "lower": np.asarray(data["grid_lower"], dtype=float),
                "upper": np.asarray(data["grid_upper"], dtype=float),
                "shape": np.asarray(data["grid_shape"], dtype=np.int64),
                "table": np.asarray(data["grid_table"], dtype=np.int64),
            }
        kind = str(data.get("kind", "explicit" if grid is None else "grid"))
        if grid is not None:
            if kind not in ("grid", "fit"):
                raise InputError(f"a {kind!r} triangulation cannot carry a grid table")
            n = len(grid["shape"])
            size = int(np.prod(grid["shape"])) * factorial(n)
            table = grid["table"]
            nsimp = len(np.asarray(data["simplices"]))
            if (len(grid["lower"]) != n or len(grid["upper"]) != n or table.shape != (size,)
                    or table.max(initial=-1) >= nsimp or table.min(initial=0) < -1
                    or int((table >= 0).sum()) != nsimp):
                raise InputError("the grid location table does not match the triangulation")
            if check:
                _check_grid_arrays(cls, data, grid, kind)
        return cls(data["vertices"], data["simplices"], _kind=kind, _grid=grid,
                   _check=check and grid is None)


def _check_grid_arrays(cls, data: dict, grid: dict, kind: str) -> None:
    """A grid (or fitted-grid) triangulation read from arrays must be the one its grid
    describes: rebuilt from the grid and compared, so a damaged file (a repeated or moved
    simplex or vertex) is refused instead of evaluating wrong pieces."""
    table = grid["table"]
    shape = tuple(int(v) for v in grid["shape"])
    expected = cls._from_grid(grid["lower"], grid["upper"], shape,
                              None if kind == "grid" else table >= 0, kind=kind)
    verts = np.asarray(data["vertices"], dtype=float)
    simp = np.asarray(data["simplices"])
    ok = (verts.shape == expected.vertices.shape and simp.shape == expected.simplices.shape
          and np.array_equal(simp, expected.simplices)
          and np.array_equal(table, expected._grid["table"])
          and np.allclose(verts, expected.vertices, rtol=1e-12, atol=0.0))
    if not ok:
        raise TriangulationError(
            f"the {kind} triangulation's vertices or simplices are not those of its grid "
            f"(shape {list(shape)}): the arrays are damaged; re-create or re-save the model")


def _ids(ids, most: int = 10) -> str:
    ids = np.asarray(ids).tolist()
    more = f" ... ({len(ids) - most} more)" if len(ids) > most else ""
    return f"{ids[:most]}{more}"


def _box(lower, upper, shape):
    lower = np.atleast_1d(np.asarray(lower, dtype=float))
    upper = np.atleast_1d(np.asarray(upper, dtype=float))
    if lower.ndim != 1 or lower.shape != upper.shape:
        raise InputError(f"lower and upper must be 1-D of equal length, got {lower.shape} "
                         f"and {upper.shape}")
    if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
        raise InputError("lower and upper must be finite")
    if np.any(upper <= lower):
        raise InputError(f"upper must exceed lower on every axis, got {lower} and {upper}")
    try:
        shape = np.broadcast_to(np.asarray(shape), lower.shape)
    except ValueError:
        raise InputError(f"shape {np.asarray(shape).tolist()} does not match the "
                         f"{len(lower)}-D lower/upper corners") from None
    if not np.issubdtype(shape.dtype, np.integer) or np.any(shape < 1):
        raise InputError(f"shape must be positive integers, got {shape.tolist()}")
    cells = int(np.prod(shape.astype(float))) * factorial(len(lower))
    if cells > 50_000_000:
        raise InputError(f"a grid of shape {shape.tolist()} has {cells} simplices: too many")
    return lower, upper, shape.astype(np.int64)
