"""Campaign behaviour: trimmed starts, the envelope, Eq. 43-48, reproducibility, schema."""

from __future__ import annotations

import hashlib
import math

import numpy as np
import pandas as pd
import pytest

from simplexspline.aero.data.flight_data import (
    FLIGHT_DATA_COLUMNS,
    REQUIRED_COLUMNS,
    SCHEMA_VERSION,
    validate_flight_data,
)
from simplexspline.errors import InputError, SimulationError
from simplexspline.sim import (
    MANEUVER_TYPES,
    Campaign,
    ConditionGrid,
    Envelope,
    FlightProtocol,
    PilotStyle,
    SensorModel,
    Wind,
    envelope_coverage,
    get_aircraft,
)
from simplexspline.sim.maneuvers import LEAD_S

from .conftest import small_campaign

G0 = 9.80665


def _eq43_48(df: pd.DataFrame) -> dict[str, np.ndarray]:
    """The paper's Eq. 43-48 on the recorded columns, thrust removed."""
    m = df.attrs
    qs = 0.5 * df["rho"] * df["tas"] ** 2 * m["S"]
    mass = df["mass"]
    p, q, r = df["p"], df["q"], df["r"]
    pd_, qd, rd = df["pdot"], df["qdot"], df["rdot"]
    ix, iy, iz, ixz = df["Ixx"], df["Iyy"], df["Izz"], df["Ixz"]
    return {
        "CX": (mass * df["ax"] - df["thrust_x"]) / qs,
        "CY": (mass * df["ay"] - df["thrust_y"]) / qs,
        "CZ": (mass * df["az"] - df["thrust_z"]) / qs,
        "Cl": (ix * pd_ - (iy - iz) * q * r - ixz * (rd + p * q) - df["thrust_l"])
        / (qs * m["b"]),
        "Cm": (iy * qd - (iz - ix) * r * p - ixz * (r**2 - p**2) - df["thrust_m"])
        / (qs * m["cbar"]),
        "Cn": (iz * rd - (ix - iy) * p * q - ixz * (pd_ - q * r) - df["thrust_n"])
        / (qs * m["b"]),
    }


def test_equations_43_48_reproduce_true_coefficients(ideal):
    coeffs = _eq43_48(ideal)
    for name, c in coeffs.items():
        true = ideal[f"true_{name}"].to_numpy()
        assert np.max(np.abs(c.to_numpy() - true)) <= 1e-6, name
        # the coefficients vary: the check is not trivially satisfied by constants
        assert np.ptp(true) > 1e-3, name


def test_equations_need_the_paper_ixz_sign_and_thrust_removal(f16_ideal):
    df = f16_ideal.copy()
    df.attrs = f16_ideal.attrs
    df["Ixz"] = -df["Ixz"]
    assert np.max(np.abs(_eq43_48(df)["Cn"] - df["true_Cn"])) > 1e-4
    df = f16_ideal.copy()
    df.attrs = f16_ideal.attrs
    df["thrust_x"] = 0.0
    assert np.max(np.abs(_eq43_48(df)["CX"] - df["true_CX"])) > 1e-3


def test_angular_accelerations_are_forward_differences_of_the_rates(ideal):
    for _, m in ideal.groupby("maneuver"):
        for rate in ("p", "q", "r"):
            x, xdot = m[rate].to_numpy(), m[rate + "dot"].to_numpy()
            assert np.allclose(np.diff(x) / 0.01, xdot[:-1], rtol=0, atol=1e-9)


def test_every_maneuver_starts_trimmed(ideal):
    for _, m in ideal.groupby("maneuver", sort=False):
        first = m.iloc[0]
        assert first["t"] == 0.0
        # straight and level, unaccelerated: gamma = 0, wings level, no rates
        assert abs(first["theta"] - first["alpha"]) < 1e-3
        assert abs(first["phi"]) < 1e-2 and abs(first["beta"]) < 1e-3
        assert abs(first["ax"] - G0 * math.sin(first["theta"])) < 0.02
        assert abs(first["az"] + G0 * math.cos(first["theta"])) < 0.02
        # nothing moves before the input starts
        lead = m[m["t"] < LEAD_S - 0.2]
        assert np.abs(lead[["p", "q", "r"]].to_numpy()).max() < 5e-4
        assert np.abs(lead[["pdot", "qdot", "rdot"]].to_numpy()).max() < 1e-3
        assert np.ptp(lead["de"]) < 1e-3


def test_every_kept_sample_is_inside_the_envelope(ideal):
    env = get_aircraft(ideal.attrs["aircraft"]).envelope
    nz = -ideal["true_az"] / G0
    assert ideal["true_alpha"].between(env.alpha_min, env.alpha_max).all()
    assert (ideal["true_beta"].abs() <= env.beta_max).all()
    assert (ideal["true_phi"].abs() <= env.phi_max).all()
    assert (ideal["true_theta"].abs() <= env.theta_max).all()
    assert nz.between(env.nz_min, env.nz_max).all()
    assert (ideal["true_mach"] <= env.mach_max).all()
    assert (ideal["true_h"] >= env.h_min).all()


def test_maneuvers_excite_the_intended_axis(ideal):
    limits = {"de": 0, "da": 1, "dr": 2}
    prof = get_aircraft(ideal.attrs["aircraft"])
    seen = set()
    for (_, kind), m in ideal.groupby(["maneuver", "maneuver_type"], observed=True):
        seen.add(kind)
        swing = {c: np.ptp(m[c]) / prof.surfaces[i].limit for c, i in limits.items()}
        if kind.startswith(("3211", "doublet")):
            axis = {"elevator": "de", "aileron": "da", "rudder": "dr"}[kind.split("-")[1]]
            assert max(swing, key=swing.get) == axis, (kind, swing)
        else:  # sum of sines on all three axes
            assert min(swing.values()) > 0.05, swing
    assert {"3211-elevator", "3211-aileron", "3211-rudder", "sum-of-sines"} <= seen


def _slope(df: pd.DataFrame, coefficient: str, regressors: list[str], of: str) -> float:
    """Least-squares slope of ``coefficient`` on ``of`` with an intercept and ``regressors``."""
    X = np.column_stack([np.ones(len(df))] + [df[c].to_numpy() for c in regressors + [of]])
    return float(np.linalg.lstsq(X, df[f"true_{coefficient}"].to_numpy(), rcond=None)[0][-1])


def test_coefficients_are_physically_sane(ideal):
    """Lift up, drag-like CX, and each surface's moment with the documented sign."""
    assert ideal["true_CZ"].median() < -0.05
    assert ideal["true_CX"].median() < 0.02
    v = ideal["tas"].to_numpy()
    m = ideal.attrs
    x = ideal.assign(phat=ideal["p"] * m["b"] / (2 * v), qhat=ideal["q"] * m["cbar"] / (2 * v),
                     rhat=ideal["r"] * m["b"] / (2 * v))
    kind = ideal["maneuver_type"].astype(str)
    lat = ["beta", "phat", "rhat"]
    assert _slope(x[kind == "3211-elevator"], "Cm", ["alpha", "qhat"], "de") < 0
    assert _slope(x[kind == "3211-aileron"], "Cl", lat, "da") > 0
    assert _slope(x[kind == "3211-rudder"], "Cn", lat, "dr") < 0


def test_table_follows_the_schema(ideal):
    report = validate_flight_data(ideal, nan="raise")
    assert report.unknown_columns == [] and report.nan_gaps == []
    assert set(REQUIRED_COLUMNS) <= set(ideal.columns)
    assert set(ideal.columns) <= set(FLIGHT_DATA_COLUMNS)
    meta = ideal.attrs
    assert meta["schema"] == SCHEMA_VERSION
    assert meta["S"] > 0 and meta["b"] > 0 and meta["cbar"] > 0
    assert set(ideal["maneuver_type"].unique()) <= set(MANEUVER_TYPES)
    for _, m in ideal.groupby("maneuver"):
        assert np.allclose(np.diff(m["t"]), 0.01)
        assert m["condition"].nunique() == 1
    summary = meta["summary"]
    assert summary["samples"] == len(ideal)
    assert summary["maneuvers_kept"] == ideal["maneuver"].nunique()
    kept_log = [lg for lg in meta["maneuvers"] if lg["status"] in ("complete", "cut")]
    assert sorted(lg["maneuver"] for lg in kept_log) == sorted(ideal["maneuver"].unique())
    for lg in kept_log:
        n = int((ideal["maneuver"] == lg["maneuver"]).sum())
        assert lg["duration_s"] == pytest.approx(n * 0.01)


def test_f16_and_global5000_geometry_in_metadata(f16_ideal, global5000_ideal):
    ft = 0.3048
    assert f16_ideal.attrs["S"] == pytest.approx(300 * ft**2)
    assert f16_ideal.attrs["b"] == pytest.approx(30 * ft)
    assert f16_ideal.attrs["cbar"] == pytest.approx(11.32 * ft)
    assert global5000_ideal.attrs["S"] == pytest.approx(1022 * ft**2)
    # Ixz in the paper's sign convention: f16's file gives ixz = -982 slug ft^2 with
    # negated cross products, i.e. a positive integral of x z dm
    assert (f16_ideal["Ixz"] > 0).all()


def test_same_seed_same_data_in_parallel_and_serial(f16_ideal):
    parallel = small_campaign("f16").run(workers=2, progress=False)
    pd.testing.assert_frame_equal(parallel, f16_ideal, check_exact=True)
    assert parallel.attrs["maneuvers"] == f16_ideal.attrs["maneuvers"]


def test_same_seed_same_data_global5000(global5000_ideal):
    again = small_campaign("global5000").run(workers=1, progress=False)
    pd.testing.assert_frame_equal(again, global5000_ideal, check_exact=True)


#: sha256 of the small campaigns' columns, computed with the code before the pilot took its
#: settings as objects (issue 15): the refactoring changed no number. A JSBSim or numpy
#: upgrade may change them; then recompute with _fingerprint at a commit known to be good.
#: Recomputed at stop 28, when the altimeter's pressure altitude became the ISA's of the
#: static pressure (columns h, true_h; every other column hashed the same as before:
#: f16 875e095d..., global5000 66c42679... without them, before and after).
#: Stop 40 found a second set on another machine with the same code and the same package
#: versions (jsbsim 1.3.3, numpy 2.4.6, pandas 3.1.1); stop 41, on an AMD EPYC with
#: AVX-512, measured the first set again: the simulated bits depend on the processor
#: (JSBSim's and numpy's floating point on its instruction set), not on the code. Each
#: machine must reproduce one of the known sets, both columns from the same set.
FINGERPRINTS = (
    {"f16": "0e1e782b920d0aabb3aade436d3e42057bbdf30d7552a91c9ef11b8fdb311c62",
     "global5000": "1cc571d1d0274b6b5ecefcd8e677d9a8434b262f24e8f88bf4861ddd780af833"},
    {"f16": "e040752bd999677766ba26e5e49b6c9166afc99152231b706e4dfeebf986ed60",
     "global5000": "6d20972706383accd318dca47da8167422c55c647f20fe06382495e55d4d3c63"},
)


#: Columns added after the fingerprints were taken (read from JSBSim, changing no other).
_NEWER = ("maneuver_type", "fuel_flow", "n1")


def _fingerprint(df: pd.DataFrame) -> str:
    h = hashlib.sha256()
    for c in df.columns:
        if c not in _NEWER:
            h.update(c.encode())
            h.update(np.ascontiguousarray(df[c].to_numpy()).tobytes())
    return h.hexdigest()


def test_same_seed_bit_identical_to_before_the_pilot_refactoring(f16_ideal, global5000_ideal):
    found = {"f16": _fingerprint(f16_ideal), "global5000": _fingerprint(global5000_ideal)}
    assert found in FINGERPRINTS


def _air_velocity_ned(df: pd.DataFrame) -> np.ndarray:
    """Air-relative velocity (n, 3) in NED from tas, alpha, beta and the attitude."""
    a, b, V = df["true_alpha"], df["true_beta"], df["true_tas"]
    uvw = np.column_stack([V * np.cos(a) * np.cos(b), V * np.sin(b), V * np.sin(a) * np.cos(b)])
    ph, th, ps = (df[f"true_{x}"].to_numpy() for x in ("phi", "theta", "psi"))
    cph, sph, cth, sth, cps, sps = np.cos(ph), np.sin(ph), np.cos(th), np.sin(th), \
        np.cos(ps), np.sin(ps)
    rows = [
        (cth * cps, sph * sth * cps - cph * sps, cph * sth * cps + sph * sps),
        (cth * sps, sph * sth * sps + cph * cps, cph * sth * sps - sph * cps),
        (-sth, sph * cth, cph * cth),
    ]
    return np.column_stack([sum(r[j] * uvw[:, j] for j in range(3)) for r in rows])


def _check_wind_identity(df: pd.DataFrame) -> None:
    """Ground velocity = air velocity + true wind at every sample; Eq. 43-48 still exact."""
    ground = df[["true_vn_gps", "true_ve_gps", "true_vd_gps"]].to_numpy()
    wind = df[["true_wind_n", "true_wind_e", "true_wind_d"]].to_numpy()
    assert np.abs(ground - wind - _air_velocity_ned(df)).max() < 1e-3
    for name, c in _eq43_48(df).items():  # ideal sensors
        assert np.max(np.abs(c - df[f"true_{name}"])) <= 1e-6, name


def test_steady_wind_keeps_the_trim_and_is_recorded():
    df = small_campaign("global5000", maneuvers=2, mix={"3211": 1, "sum-of-sines": 1},
                        wind=Wind((10.0, 15.0))).run(workers=1, progress=False)
    assert df.attrs["simulator"]["wind"] == {"speed_mps": (10.0, 15.0), "turbulence": "none"}
    _check_wind_identity(df)
    for _, m in df.groupby("maneuver"):
        speed = np.hypot(m["true_wind_n"], m["true_wind_e"])
        assert 10.0 <= speed.min() and speed.max() <= 15.0 and np.ptp(speed) < 1e-9
        assert np.hypot(m["vn_gps"] - m["true_wind_n"], m["ve_gps"] - m["true_wind_e"]).iloc[0] \
            == pytest.approx(m["tas"].iloc[0], abs=0.05)
        first = m.iloc[0]  # trimmed, air-relative: as in still air
        assert abs(first["true_theta"] - first["true_alpha"]) < 1e-3
        assert abs(first["true_beta"]) < 1e-3
        assert abs(first["true_az"] + G0 * math.cos(first["true_theta"])) < 0.02
        # steady wind: the air does not rotate, aero rates = inertial rates (but for the
        # Earth's rotation, which JSBSim's aero rates leave out)
        for axis in "pqr":
            assert np.abs(m[f"true_{axis}_aero"] - m[f"true_{axis}"]).max() < 1e-4, axis
        lead = m[m["t"] < LEAD_S - 0.2]
        assert np.abs(lead[["p", "q", "r"]].to_numpy()).max() < 5e-4


def test_turbulence_moves_the_air_and_is_recorded():
    df = small_campaign("global5000", maneuvers=1, mix={"doublet": 1},
                        wind=Wind((5.0, 5.0), "light")).run(workers=1, progress=False)
    _check_wind_identity(df)
    assert np.ptp(np.hypot(df["true_wind_n"], df["true_wind_e"])) > 0.05
    assert np.ptp(df["true_wind_d"]) > 0.05
    # the rotational gusts: the aerodynamics see body rates relative to the air, which
    # differ from the inertial (gyro) rates by more than the gyro noise
    for axis in "pqr":
        gust = df[f"true_{axis}_aero"] - df[f"true_{axis}"]
        assert gust.std() > 3e-4, axis
    again = small_campaign("global5000", maneuvers=1, mix={"doublet": 1},
                           wind=Wind((5.0, 5.0), "light")).run(workers=1, progress=False)
    pd.testing.assert_frame_equal(df, again, check_exact=True)  # seeded gusts


def test_still_air_campaigns_have_no_wind_columns(f16_ideal):
    assert not any(c.startswith("true_wind") for c in f16_ideal.columns)
    assert f16_ideal.attrs["simulator"]["wind"] is None


def test_campaign_round_trips_through_parquet(tmp_path, f16_ideal):
    from simplexspline.aero.data.flight_data import read_flight_data, write_flight_data

    path = write_flight_data(f16_ideal, tmp_path / "campaign.parquet")
    back, meta = read_flight_data(path)
    pd.testing.assert_frame_equal(back, f16_ideal, check_exact=True)
    assert meta["maneuvers"] == f16_ideal.attrs["maneuvers"]
    assert meta["simulator"]["sensors"] == SensorModel.ideal().to_dict()


def test_other_seed_other_data(f16_ideal):
    other = small_campaign("f16", seed=8, maneuvers=2).run(workers=1, progress=False)
    assert not np.array_equal(other["de"].to_numpy()[:500], f16_ideal["de"].to_numpy()[:500])


def test_sensor_noise_changes_measurements_not_the_flight():
    sensors = SensorModel()
    noisy = small_campaign("f16", sensors=sensors, maneuvers=2).run(workers=1, progress=False)
    ideal = small_campaign("f16", maneuvers=2).run(workers=1, progress=False)
    true_cols = [c for c in ideal.columns if c.startswith("true_")]
    pd.testing.assert_frame_equal(noisy[true_cols], ideal[true_cols], check_exact=True)
    err = noisy["ax"] - noisy["true_ax"]
    assert err.mean() == pytest.approx(sensors.bias["ax"], abs=3e-3)
    assert err.std() == pytest.approx(sensors.noise_std["ax"], rel=0.1)
    assert noisy.attrs["simulator"]["sensors"] == sensors.to_dict()


def test_tight_envelope_cuts_and_marks_maneuvers():
    prof = get_aircraft("f16")
    env = Envelope(**{**prof.envelope.to_dict(), "nz_min": 0.6, "nz_max": 1.4})
    df = small_campaign("f16", maneuvers=3, mix={"3211": 1}, envelope=env, min_kept_s=1.0,
                        grid=ConditionGrid([3000.0], [220.0])).run(workers=1, progress=False)
    logs = df.attrs["maneuvers"]
    assert [lg["status"] for lg in logs].count("cut") >= 1
    for lg in logs:
        rows = df[df["maneuver"] == lg["maneuver"]]
        if lg["status"] == "cut":
            assert "load factor" in lg["reason"]
            assert len(rows) * 0.01 == pytest.approx(lg["duration_s"])
            assert len(rows) < round(lg["planned_s"] / 0.01)
    nz = -df["true_az"] / G0
    assert nz.between(0.6, 1.4).all()
    assert df.attrs["summary"]["cut"] == [lg["status"] for lg in logs].count("cut")


def test_short_remainders_are_dropped_not_kept():
    prof = get_aircraft("f16")
    env = Envelope(**{**prof.envelope.to_dict(), "nz_min": 0.9, "nz_max": 1.1})
    with pytest.raises(SimulationError, match="no maneuver was kept"):
        small_campaign("f16", maneuvers=1, mix={"doublet": 1}, envelope=env, min_kept_s=60.0,
                       grid=ConditionGrid([3000.0], [220.0])).run(workers=1, progress=False)


def test_untrimmable_grid_is_an_error_that_says_why():
    campaign = Campaign("global5000", grid=ConditionGrid([12000.0], [120.0]), maneuvers=1,
                        sensors=SensorModel.ideal())
    conditions = campaign.conditions(workers=1)
    assert conditions[0]["trimmed"] is False and "trim" in conditions[0]["reason"]
    with pytest.raises(SimulationError, match="no condition .* could be trimmed"):
        campaign.run(workers=1, progress=False)


def test_conditions_above_the_mach_limit_are_skipped_without_trimming():
    c = Campaign("f16", grid=ConditionGrid([1000.0], [330.0])).conditions(workers=1)
    assert c == [{"condition": 0, "h_m": 1000.0, "tas_mps": 330.0, "trimmed": False,
                  "reason": c[0]["reason"]}]
    assert "Mach" in c[0]["reason"]


def test_plan_is_balanced_and_jittered():
    campaign = small_campaign("f16", maneuvers=12, mix={"3211": 1, "sum-of-sines": 1})
    plan = campaign.plan(workers=1)
    kinds = [p["design"]["type"] for p in plan]
    assert kinds.count("sum-of-sines") == 6
    assert sorted(k for k in kinds if k != "sum-of-sines") == sorted(
        ["3211-elevator", "3211-aileron", "3211-rudder"] * 2)
    assert sorted({p["condition"] for p in plan}) == [0, 1, 2, 3]
    assert len({(p["h_m"], p["tas_mps"]) for p in plan}) == 12  # jittered trim points
    for p in plan:
        assert abs(p["h_m"] - p["h_nominal"]) <= 2000.0 + 1e-9
        assert abs(p["tas_mps"] - p["tas_nominal"]) <= 30.0 + 1e-9


def test_turn_fraction_zero_is_straight_and_level():
    plan = small_campaign("f16", maneuvers=4, mix={"sum-of-sines": 1},
                          turn_fraction=0.0).plan(workers=1)
    assert [p["design"]["bank"] for p in plan] == [0.0] * 4
    plan = small_campaign("f16", maneuvers=4, mix={"sum-of-sines": 1},
                          turn_fraction=1.0).plan(workers=1)
    assert all(abs(p["design"]["bank"]) > 0.1 for p in plan)


def test_maneuvers_per_condition():
    plan = small_campaign("f16", maneuvers_per_condition=2).plan(workers=1)
    conditions = [p["condition"] for p in plan]
    assert sorted(conditions) == [0, 0, 1, 1, 2, 2, 3, 3]


def test_simulate_campaign_writes_the_file(tmp_path):
    from simplexspline.aero.data.flight_data import read_flight_data
    from simplexspline.sim import simulate_campaign

    out = tmp_path / "c.parquet"
    df = simulate_campaign("global5000", maneuvers=1, seed=4, output=out, workers=1,
                           progress=False, grid=ConditionGrid([3000.0], [170.0]),
                           protocol=FlightProtocol(mix={"doublet": 1}))
    back, meta = read_flight_data(out, nan="raise")
    assert len(back) == len(df) and meta["aircraft"] == "global5000"
    assert meta["simulator"]["seed"] == 4


@pytest.mark.parametrize("kwargs, match", [
    ({"maneuvers": 0}, "maneuvers must be a positive integer"),
    ({"aircraft": "spitfire"}, "unknown aircraft 'spitfire'"),
    ({"protocol": {"mix": {"loop": 1}}}, "unknown maneuver family 'loop'"),
    ({"protocol": {"mix": {"3211": 0}}}, "at least one positive weight"),
    ({"seed": -1}, "seed must be a non-negative integer"),
    ({"grid": {"altitudes_m": []}}, "altitudes_m must be a non-empty"),
    ({"grid": {"airspeeds_mps": [100.0, 100.0]}}, "duplicates"),
    ({"protocol": {"sos_duration_s": (5.0, 1.0)}}, "sos_duration_s"),
    ({"protocol": {"sos_duration_s": 100.0}}, "sos_duration_s"),
    ({"protocol": {"mix": {"3211": "a lot"}}},
     "mix weight of '3211' must be a non-negative number"),
    ({"sensors": "none"}, "sensors must be"),
    ({"envelope": {"alpha_max": 1.0}}, "envelope must be"),
    ({"grid": "none"}, "grid must be"),
    ({"protocol": "none"}, "protocol must be"),
    ({"protocol": {"min_kept_s": -1.0}}, "min_kept_s must be a number of seconds"),
    ({"protocol": {"turn_fraction": 1.5}}, "turn_fraction must be a number in"),
    ({"protocol": {"pilot_delay_s": float("nan")}}, "pilot_delay_s must be"),
    ({"protocol": {"design": "mine"}}, "unknown excitation design 'mine'"),
    ({"wind": "gale"}, "wind must be a simplexspline.sim.Wind"),
    ({"protocol": {"pilot": "relaxed"}}, "pilot must be a simplexspline.sim.PilotStyle"),
    ({"protocol": {"pilot_delay_s": 0.5, "pilot": PilotStyle(delay_s=0.3)}},
     "give the delay in one place"),
])
def test_invalid_campaigns_are_rejected(kwargs, match):
    """Settings objects check their own values when made; the campaign checks the rest."""
    kwargs = {"aircraft": "f16", **kwargs}
    with pytest.raises(InputError, match=match):
        for key, cls in (("grid", ConditionGrid), ("protocol", FlightProtocol)):
            if isinstance(kwargs.get(key), dict):
                kwargs[key] = cls(**kwargs[key])
        Campaign(**kwargs).run(workers=1, progress=False)


def test_invalid_workers_rejected():
    with pytest.raises(InputError, match="workers must be a positive integer"):
        small_campaign("f16", maneuvers=1).run(workers=0, progress=False)


def test_envelope_coverage_summarises_the_campaign(f16_ideal):
    cov = envelope_coverage(f16_ideal)
    assert {"alpha", "beta", "mach", "p", "q", "r", "de", "da", "dr", "nz"} <= set(cov.index)
    assert cov.loc["alpha", "max"] == pytest.approx(np.degrees(f16_ideal["true_alpha"].max()))
    assert (cov["min"] <= cov["p50"]).all() and (cov["p50"] <= cov["max"]).all()


@pytest.mark.slow
@pytest.mark.parametrize("aircraft", ["f16", "global5000", "c172p", "A4", "737", "T37"])
def test_default_grid_campaign_stays_inside_and_covers(aircraft):
    """Forty maneuvers on the default grid: few cuts, Eq. 43-48 hold, wide coverage."""
    df = Campaign(aircraft, maneuvers=40, seed=3, sensors=SensorModel.ideal()).run(
        workers=2, progress=False)
    s = df.attrs["summary"]
    assert s["cut"] + s["dropped"] + s["trim-failed"] <= 4
    for name, c in _eq43_48(df).items():
        assert np.max(np.abs(c - df[f"true_{name}"])) <= 1e-6
    cov = envelope_coverage(df)
    prof = get_aircraft(aircraft)
    alpha_span = math.degrees(prof.envelope.alpha_max - prof.envelope.alpha_min)
    assert cov.loc["alpha", "max"] - cov.loc["alpha", "min"] > min(8.0, 0.3 * alpha_span)
    speeds = prof.airspeeds_mps
    assert cov.loc["tas", "max"] - cov.loc["tas", "min"] > 0.6 * (max(speeds) - min(speeds))


def test_a_dying_worker_is_reported_as_a_simulation_error():
    import os

    from simplexspline.sim.campaign import Executor

    with Executor(2) as ex, pytest.raises(SimulationError, match="worker process died"):
        list(ex.map(os._exit, [3, 3], [1.0, 1.0], progress=False, desc="crash"))
