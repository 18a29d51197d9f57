"""Acceptance tests of the spline core (issue 2).

reference.py  dense, independent reference implementations (multi-indices, basis, Eq. 21
              smoothness matrix, regression matrix, null-space and KKT solvers, SVD rank)
cases.py      triangulations of every kind (explicit, delaunay, grid, fit) and sampling
test_spline_bform.py           multi-indices, basis values, de Casteljau, B-net
test_spline_triangulation.py   validation, facets/neighbours, locate, barycentric, quality
test_spline_continuity.py      H against the dense reference; C^r across facets
test_spline_reproduction.py    polynomial reproduction, derivatives, outside policies
test_spline_solve.py           X, normal equations, constrained LS vs references, weights,
                               streaming, on_insufficient policies, affine invariance
test_spline_invariance.py      numbering invariance, array conventions, large offsets
test_spline_convergence.py     observed convergence orders (prints the table)
test_spline_io.py              model files
test_spline_errors.py          clear exceptions for bad input
"""
