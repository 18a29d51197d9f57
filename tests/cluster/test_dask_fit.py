"""Distributed fit on a 2-worker dask.distributed LocalCluster equals the in-memory fit."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from simplexspline import InputError, SplineSpace, Triangulation
from simplexspline.spline.distributed import fit_dask, normal_equations_dask

dd = pytest.importorskip("dask.dataframe")
da = pytest.importorskip("dask.array")
distributed = pytest.importorskip("dask.distributed")


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=40)
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


@pytest.fixture(scope="module")
def problem():
    rng = np.random.default_rng(11)
    x = rng.random((40_000, 3))
    y = np.sin(3 * x[:, 0]) * np.cos(2 * x[:, 1]) + x[:, 2] ** 2 + 0.01 * rng.normal(size=len(x))
    w = rng.uniform(0.5, 2.0, len(x))
    space = SplineSpace(Triangulation.grid(np.zeros(3), np.ones(3), (2, 2, 2)), 3, 1)
    return space, x, y, w


def test_dataframe_fit_on_local_cluster_matches_in_memory(client, problem):
    space, x, y, w = problem
    df = pd.DataFrame({"a": x[:, 0], "b": x[:, 1], "c": x[:, 2], "f": y, "w": w})
    ddf = dd.from_pandas(df, npartitions=7)
    got = fit_dask(space, ddf, columns=["a", "b", "c"], target="f", weight="w")
    ref = space.fit(x, y, w)
    scale = np.abs(ref.coefficients).max()
    assert np.abs(got.coefficients - ref.coefficients).max() <= 1e-10 * scale
    assert got.info.counts.sum() == len(x)


def test_array_fit_matches_in_memory(client, problem):
    space, x, y, _ = problem
    xa = da.from_array(x, chunks=(6000, 3))
    ya = da.from_array(y, chunks=6000)
    got = fit_dask(space, xa, y=ya, split_every=2)
    ref = space.fit(x, y)
    assert np.abs(got.coefficients - ref.coefficients).max() <= 1e-10 * np.abs(
        ref.coefficients).max()


def test_streaming_blocks_equal_one_shot(problem):
    space, x, y, _ = problem
    xa = da.from_array(x, chunks=(10_000, 3))
    ne = normal_equations_dask(space, xa, y=da.from_array(y, chunks=10_000),
                               scheduler="threads")
    one = space.normal_equations(x, y)
    np.testing.assert_allclose(ne.XtWX, one.XtWX, rtol=1e-12, atol=1e-9)
    np.testing.assert_array_equal(ne.counts, one.counts)


def test_bad_dask_input_is_named(problem):
    space, x, y, _ = problem
    ddf = dd.from_pandas(pd.DataFrame({"a": x[:, 0], "b": x[:, 1], "f": y}), npartitions=2)
    with pytest.raises(InputError, match="not in the DataFrame"):
        fit_dask(space, ddf, columns=["a", "b", "zz"], target="f", scheduler="threads")
    with pytest.raises(InputError, match="columns=.*target="):
        fit_dask(space, ddf)
    with pytest.raises(InputError, match="chunked along rows only"):
        fit_dask(space, da.from_array(x, chunks=(1000, 1)), y=da.from_array(y, chunks=1000))
    with pytest.raises(InputError, match="dask.dataframe.DataFrame or a dask.array"):
        fit_dask(space, x)
