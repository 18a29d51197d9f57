"""The compiled filter (numba) against the Python reference path: the same numbers.

Every test runs both paths, the reference by switching numba off
(``filter_kernels.HAVE_NUMBA = False``, what ``SIMPLEXSPLINE_NO_NUMBA=1`` does), and asks
for agreement to round-off: 1e-9 of each quantity's scale (its value, its sigma or its
column's largest value). The kernels mirror the reference's products (the Joseph form and
``F P F'`` by BLAS), so the forward passes agree to about 1e-13.

The smoothed states of the synthetic flights are only defined to about 1e-7 of their sigma:
their predicted covariances have condition numbers of 1e10 (gusts, wind and airspeed bias
nearly confounded), and multiplying the reference's own ``P_pred`` by 1 + 1e-14 moves its
smoothed gusts by 7e-8 sigma. There the bound is 1e-6 sigma; the campaigns' smoothed states
and everything reconstructed from them keep 1e-9.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplexspline.aero import reconstruct
from simplexspline.aero.reconstruction import filter_kernels
from simplexspline.aero.reconstruction.gusts import gust_process
from simplexspline.aero.reconstruction.iekf import (
    FilterNoise, IteratedUpdate, StateEstimate, rts_smooth, run_filter,
)
from simplexspline.aero.reconstruction.kinematics import (
    GUST, MEASUREMENT_NAMES, NX, NZ, PSI_MEAS, EarthModel, measure, propagate,
)
from simplexspline.aero.reconstruction.reconstruct import ReconstructionSettings

pytestmark = pytest.mark.skipif(not filter_kernels.HAVE_NUMBA, reason="numba not installed")

RTOL = 1e-9
GPS = ["x_gps", "y_gps", "z_gps", "vn_gps", "ve_gps", "vd_gps"]
DT = 0.02


def test_kernel_constants_match_the_model():
    assert (filter_kernels._NX, filter_kernels._NZ, filter_kernels._PSI_MEAS) == (
        NX, NZ, PSI_MEAS)


def _both(monkeypatch, fn):
    """``fn()`` compiled, then by the Python reference path."""
    compiled = fn()
    monkeypatch.setattr(filter_kernels, "HAVE_NUMBA", False)
    reference = fn()
    monkeypatch.setattr(filter_kernels, "HAVE_NUMBA", True)
    return compiled, reference


def _close(a, b, scale, what, rtol=RTOL):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    np.testing.assert_array_equal(np.isfinite(a), np.isfinite(b), err_msg=what)
    ok = np.isfinite(b)
    err = np.abs(a[ok] - b[ok])
    bound = rtol * (np.abs(b[ok]) + np.broadcast_to(scale, b.shape)[ok])
    assert (err <= bound).all(), f"{what}: worst {np.max(err / bound) * rtol:.3g} of the scale"


def _flight(seed: int, n: int = 400, gust_std: float = 1.0):
    """A rolling, turning climb from the filter's own model (IMU inputs, measurements with
    noise), with the vanes off the c.g. and gusts."""
    rng = np.random.default_rng(seed)
    earth = EarthModel(math.radians(52.0))
    decay, q_gust = gust_process(gust_std, 300.0, 150.0, DT)
    x = np.zeros(NX)
    x[3:6] = (150.0, 2.0, 8.0)
    x[6:9] = (0.3, 0.05, 2.0)
    x[9:18] = (0.02, -0.01, 0.03, 1e-3, -5e-4, 2e-4, 0.01, -0.005, 0.5)
    x[18:23] = (4.0, -3.0, 0.2, 0.02, -0.03)
    x[26:28] = (0.8, -0.5)                  # vane position errors along x [m]
    x[GUST] = gust_std * rng.standard_normal(3)
    F = np.eye(NX)
    t = np.arange(n) * DT
    u = np.column_stack([0.5 * np.sin(t), 0.3 * np.cos(2 * t), -9.5 + np.sin(3 * t),
                         0.2 * np.sin(1.5 * t), 0.05 + 0.02 * np.cos(t), 0.04 * np.sin(t)])
    arm = 0.05 * rng.standard_normal((n, 9))
    states = np.empty((n, NX))
    for k in range(n):
        states[k] = x
        x = propagate(x, u[k], DT, 9.81, earth, F, gust_decay=decay)
        x[GUST] += math.sqrt(q_gust) * rng.standard_normal(3)
    std = np.array([2.0, 2.0, 4.0, 0.05, 0.05, 0.1, 0.1, 1.7e-3, 1.7e-3, 8.7e-4, 8.7e-4,
                    1.7e-3])
    z = np.array([measure(s, None, a) for s, a in zip(states, arm)])
    z += std * rng.standard_normal(z.shape)
    z[:, 11] = (z[:, 11] + math.pi) % (2 * math.pi) - math.pi     # heading as measured
    q = np.full(NX, 1e-16)
    q[3:6] = 1e-6
    q[GUST] = q_gust
    noise = FilterNoise(np.array([0.01, 0.01, 0.01, 2e-4, 2e-4, 2e-4]), q, std)
    x0 = states[0] + 0.1 * rng.standard_normal(NX) * np.r_[np.ones(9), np.zeros(19)]
    sd = np.r_[np.full(3, 5.0), np.full(3, 1.0), np.full(3, 0.01), np.full(3, 0.1),
               np.full(3, 2e-3), 0.02, 0.02, 2.0, np.full(3, 10.0), 0.05, 0.05,
               np.full(3, gust_std), 2.0, 2.0]
    return StateEstimate(x0, np.diag(sd ** 2)), u, z, earth, noise, arm, decay


def _compare_passes(a: dict, b: dict, xs_a, xs_b):
    sd = np.sqrt(np.diagonal(b["P_pred"], axis1=1, axis2=2))
    for k in ("x_filt", "x_pred"):
        _close(a[k], b[k], sd, k)
    for k in ("P_filt", "P_pred"):
        s = np.sqrt(np.diagonal(b[k], axis1=1, axis2=2))
        _close(a[k], b[k], s[:, :, None] * s[:, None, :], k)
    _close(a["F"], b["F"], 1.0, "F")
    _close(a["innov"], b["innov"], np.sqrt(b["innov_var"]), "innov")
    _close(a["innov_var"], b["innov_var"], 0.0, "innov_var")
    np.testing.assert_array_equal(a["iterations"], b["iterations"])
    _close(a["loglik"], b["loglik"], 0.0, "loglik")
    _close(xs_a, xs_b, sd, "smoothed states", rtol=1e-6)


@pytest.mark.parametrize("case", ["all", "gaps", "no accelerometers", "no arm", "iterating",
                                  "second order"])
def test_forward_pass_and_smoother_equal_the_reference(monkeypatch, case):
    initial, u, z, earth, noise, arm, decay = _flight(seed=1)
    iteration = IteratedUpdate()
    kw = {"arm": arm, "gust_decay": decay}
    if case == "gaps":             # missing samples and channels, the heading among them
        rng = np.random.default_rng(2)
        z[rng.random(z.shape) < 0.2] = np.nan
        z[50:60] = np.nan
        z[:, 8] = np.nan
    elif case == "no accelerometers":
        kw["specific_force"] = False
    elif case == "no arm":
        kw["arm"] = None
    elif case == "second order":   # the step for coarsely sampled inputs
        kw["second_order"] = True
    elif case == "iterating":      # a heading 0.3 rad off and a tight rule: several gains
        initial.x[8] += 0.3
        iteration = IteratedUpdate(tol=1e-3, max_iter=6)

    def run():
        out = run_filter(initial, u, z, DT, np.full(len(u), 9.81), earth, noise, iteration,
                         **kw)
        return out, rts_smooth(out)[0]

    (a, xs_a), (b, xs_b) = _both(monkeypatch, run)
    if case == "iterating":
        assert b["iterations"].max() > 2
    _compare_passes(a, b, xs_a, xs_b)


def test_smoothed_means_do_not_depend_on_the_covariance_option():
    initial, u, z, earth, noise, arm, decay = _flight(seed=3, n=100)
    out = run_filter(initial, u, z, DT, np.full(len(u), 9.81), earth, noise, arm=arm,
                     gust_decay=decay)
    np.testing.assert_array_equal(rts_smooth(out)[0], rts_smooth(out, covariance=True)[0])


def test_numerical_failures_raise_the_reference_error(monkeypatch):
    initial, u, z, earth, noise, arm, decay = _flight(seed=4, n=20)
    calls = []
    real = filter_kernels.filter_pass

    def spy(*args):
        calls.append(1)
        return real(*args)

    monkeypatch.setattr(filter_kernels, "filter_pass", spy)
    # no noise, no uncertainty: the innovation covariance is singular at the first sample
    exact = FilterNoise(noise.input_std, noise.process_var, np.zeros(len(MEASUREMENT_NAMES)))
    with pytest.raises(np.linalg.LinAlgError, match="not positive definite at sample 0"):
        run_filter(StateEstimate(initial.x, np.zeros((NX, NX))), u, z, DT,
                   np.full(len(u), 9.81), earth, exact)
    # the aircraft standing still in still air: the airspeed's gradient divides by zero
    still = initial.x.copy()
    still[3:6] = 0.0
    still[18:21] = still[GUST] = 0.0
    with pytest.raises(ZeroDivisionError):
        run_filter(StateEstimate(still, initial.P), u, z, DT, np.full(len(u), 9.81), earth,
                   noise)
    assert len(calls) == 2            # both tried compiled first


# -- whole reconstructions ---------------------------------------------------------------

@pytest.fixture(scope="module")
def turbulent():
    """One 11 s elevator 3211 in an 8 m/s wind with JSBSim's light turbulence."""
    from simplexspline.sim import Campaign, ConditionGrid, FlightProtocol, SensorModel
    from simplexspline.sim.wind import Wind

    return Campaign("f16", maneuvers=1, seed=2, sensors=SensorModel(),
                    wind=Wind((8.0, 8.0), "light"),
                    grid=ConditionGrid(altitudes_m=[3000.0], airspeeds_mps=[180.0]),
                    protocol=FlightProtocol(mix={"3211": 1})).run(workers=1, progress=False)


def _compare_reconstructions(a, b, rtol=RTOL):
    assert a.rejected == b.rejected and a.maneuvers.keys() == b.maneuvers.keys()
    assert a.lags_applied.keys() == b.lags_applied.keys()
    for m, ra in a.maneuvers.items():
        rb = b.maneuvers[m]
        assert ra["iterations"][1] == rb["iterations"][1]
        _close(ra["iterations"][0], rb["iterations"][0], 0.0, "mean iterations")
        for ch, (value, sigma) in rb["biases"].items():
            _close(ra["biases"][ch], (value, sigma), sigma, f"maneuver {m} bias {ch}", rtol)
        assert ra["innovations"].keys() == rb["innovations"].keys()
        for ch, st in rb["innovations"].items():
            for k, v in st.items():
                _close(ra["innovations"][ch][k], v, 1.0, f"maneuver {m} innovation {ch} {k}")
        ga, gb = ra["gusts"], rb["gusts"]
        assert ga["std"] == gb["std"] and ga["length_m"] == gb["length_m"]
        assert ga["loglik"].keys() == gb["loglik"].keys()
        for k, v in gb["loglik"].items():
            _close(ga["loglik"][k], v, 0.0, f"maneuver {m} log-likelihood {k}")
        assert ra["held"] == rb["held"] and ra["weak"] == rb["weak"]
    assert list(a.data.columns) == list(b.data.columns)
    for c in a.data.columns:
        if a.data[c].dtype.kind == "f":
            col = b.data[c].to_numpy()
            scale = np.nanmax(np.abs(col)) if np.isfinite(col).any() else 0.0
            _close(a.data[c].to_numpy(), col, scale, f"column {c}")


@pytest.mark.parametrize("drop", [[], GPS, ["beta", "psi"]],
                         ids=["gps", "no gps", "no beta vane, no heading"])
def test_reconstruction_in_turbulence_equals_the_reference(monkeypatch, turbulent, drop):
    data = turbulent.drop(columns=drop)
    a, b = _both(monkeypatch, lambda: reconstruct(data, workers=1))
    if not drop:
        assert next(iter(b.maneuvers.values()))["gusts"]["std"] > 0    # gusts estimated
    _compare_reconstructions(a, b)


def test_campaign_reconstruction_equals_the_reference(monkeypatch, noisy_campaign):
    """Two still-air maneuvers: the campaign calibration pass, lags, the smoother. The
    biases pass through the first pass, the joint combination of the vane constants (a
    3 x 3 inversion of information sums) and the second pass: their round-off reaches
    2e-9 of their sigma (measured 1.85e-9), so they are held to 1e-8."""
    data = noisy_campaign[noisy_campaign["maneuver"].isin([0, 2])]
    settings = ReconstructionSettings(gust_std=0)
    a, b = _both(monkeypatch, lambda: reconstruct(data, settings=settings, workers=1))
    _compare_reconstructions(a, b, rtol=1e-8)
