"""A whole flight-test record, as a real one arrives, through import and identify (issue 16).

The rehearsal of the check on a real Citation II record, small: one continuous flight of a
business jet (global5000) through two test points with steady flight, turns and a speed
change between its maneuvers, real-installation sensors, a steady wind and light
turbulence, written at 10 Hz in aviation units with no sideslip vane, an empty heading
channel, GPS latitude and longitude only, no thrust and taxiing at both ends; a mapping file
without a maneuver list. ``simplexspline import`` then ``simplexspline identify`` with the
defaults must run to the end with every modelled coefficient's validation R^2 positive, a
positive lift-curve slope and a negative pitch stiffness. The full-size rehearsal is
``benchmarks/bench_whole_flight.py`` (and the slow test below).
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("jsbsim")

from simplexspline.aero import import_record  # noqa: E402
from simplexspline.aero.derivatives import derivatives, load_models  # noqa: E402
from simplexspline.aero.reconstruction.observability import trimmed  # noqa: E402
from simplexspline.aero.reconstruction.reconstruct import (  # noqa: E402
    ReconstructionSettings, reconstruct)
from simplexspline.cli import main  # noqa: E402
from simplexspline.errors import InputError  # noqa: E402
from simplexspline.sim import (FlightProtocol, SensorModel, Wind,  # noqa: E402
                               write_channel_record)
from simplexspline.sim.whole_flight import WholeFlight  # noqa: E402


def _record(tmp_path, **flight):
    df = WholeFlight("global5000", sensors=SensorModel.real_like(),
                     wind=Wind((5.0, 12.0), "light"),
                     protocol=FlightProtocol(mix={"3211": 2, "doublet": 1, "sum-of-sines": 1},
                                             sos_duration_s=(20.0, 30.0)), **flight).run()
    rec = write_channel_record(df, tmp_path / "record")
    mapping = rec / "mapping.toml"
    # the user has no maneuver log: no [segments] list, the default cuts by excitation
    text = mapping.read_text()
    mapping.write_text(text[:text.index("[segments]")])
    return rec, mapping, df


def _lift_slope(models) -> float:
    """dCL/dalpha at the reference condition, CL = CX sin(alpha) - CZ cos(alpha)."""
    d = derivatives(models, wrt=["alpha"])
    a = float(d["alpha"].iloc[0])
    cx, cz = float(models["CX"].predict(d)[0]), float(models["CZ"].predict(d)[0])
    return (float(d["CX_alpha"].iloc[0]) * np.sin(a) + cx * np.cos(a)
            - float(d["CZ_alpha"].iloc[0]) * np.cos(a) + cz * np.sin(a))


def _check(tmp_path, mapping, capsys):
    flight = tmp_path / "flight.parquet"
    out = tmp_path / "identification"
    assert main(["import", str(mapping), "-o", str(flight), "-q"]) == 0
    assert main(["identify", str(flight), "-o", str(out), "--no-report", "-q"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    # the record's mapping gives no IMU position: what a lever arm would do to CY is said
    imu = [w for w in summary["warnings"] if w.startswith("the accelerometers' position")]
    assert len(imu) == 1 and "[metadata.sensor_geometry.imu]" in imu[0], summary["warnings"]
    r2 = {c: e["r2"] for c, e in summary["coefficients"].items()}
    assert set(r2) == {"CX", "CY", "CZ", "Cl", "Cm", "Cn"}
    assert all(v > 0 for v in r2.values()), r2
    models = load_models(out)
    cl_alpha = _lift_slope(models)
    cm_alpha = float(derivatives(models, wrt=["alpha"])["Cm_alpha"].iloc[0])
    assert 2.0 < cl_alpha < 8.0, cl_alpha          # per rad; the simulator's is 4.35
    assert cm_alpha < 0.0, cm_alpha
    return summary, cl_alpha, cm_alpha


def test_a_whole_flight_imports_and_identifies_with_the_defaults(tmp_path, capsys):
    rec, mapping, df = _record(tmp_path, legs=[(3000.0, 150.0), (3000.0, 185.0)],
                               maneuvers=12, seed=3, steady_s=(10.0, 20.0))
    _check(tmp_path, mapping, capsys)
    flight = pd.read_parquet(tmp_path / "flight.parquet")
    found = [(g["t_record"].iloc[0], g["t_record"].iloc[-1], g["maneuver_type"].iloc[0])
             for _, g in flight.groupby("maneuver")]
    flown = pd.read_csv(rec / "maneuvers.csv")
    for _, m in flown.iterrows():     # every flown maneuver found (most of it)
        assert max(min(b, m["end"]) - max(a, m["start"]) for a, b, _ in found) \
            > 0.5 * (m["end"] - m["start"]), m["type"]
    outside = [(a, b) for a, b, kind in found if kind != "turn"
               and not any(min(b, m["end"]) > max(a, m["start"]) for _, m in flown.iterrows())]
    assert len(outside) <= 2, outside  # a turn entry, a speed change: not maneuvers
    # the turns the import cuts between the maneuvers lie in turns the aircraft flew
    listed = pd.read_csv(write_channel_record(df, tmp_path / "with-turns", turns=True)
                         / "maneuvers.csv")
    turns = listed[listed["type"] == "turn"]
    cut = [(a, b) for a, b, kind in found if kind == "turn"]
    assert cut
    for a, b in cut:
        assert any(min(b, u["end"]) - max(a, u["start"]) > 0.5 * (b - a)
                   for _, u in turns.iterrows()), (a, b)


@pytest.mark.slow
def test_a_long_whole_flight_through_four_test_points(tmp_path, capsys):
    """The bench's flight (24 maneuvers, 40 minutes, four test points: about 2 minutes)."""
    _, mapping, _ = _record(tmp_path, maneuvers=24, seed=1, steady_s=(20.0, 45.0))
    _check(tmp_path, mapping, capsys)


@pytest.fixture(scope="module")
def still_air_course():
    """A flight-test course in still air and a steady 5-6 m/s wind (global5000, one test
    point, one pulse and one doublet per axis, a turn between maneuvers; read-only)."""
    return WholeFlight("global5000", sensors=SensorModel.real_like(),
                       wind=Wind((5.0, 6.0), "none"), protocol=FlightProtocol.eigenmotion(),
                       legs=[(4500.0, 200.0)], maneuvers=6, seed=2, steady_s=(10.0, 15.0),
                       turn_probability=1.0).run()


def test_the_turns_of_a_flight_give_its_straight_maneuvers_the_wind(tmp_path,
                                                                    still_air_course):
    """A flight-test course in still air and a steady 5-6 m/s wind, without heading or
    vane, whose maneuver list logs the turns between the maneuvers (or, without a list,
    whose turns are found between the detected maneuvers). The turns observe the
    wind; with it (``wind_calibration='campaign'``, the default) the straight lateral
    maneuvers' sideslip no longer takes the crab angle's change as their heading changes:
    its RMS error over them falls by more than half (an aileron pulse's from 1.6e-2 to
    1.3e-3 rad when this test was written), and each says where its wind came from."""
    rec = write_channel_record(still_air_course, tmp_path / "record", turns=True)
    listed = pd.read_csv(rec / "maneuvers.csv")
    assert (listed["type"] == "turn").sum() >= 2
    data = import_record(rec / "mapping.toml").data
    truth = pd.read_csv(rec / "truth.csv")
    err = {}
    for mode in ("maneuver", "campaign"):
        run = reconstruct(data, workers=1,
                          settings=ReconstructionSettings(wind_calibration=mode))
        straight = [m for m, r in run.maneuvers.items()
                    if "changes by less than" in r["observability"]["wind"]]
        lateral = [m for m in straight if str(listed["type"][m]).endswith(
            ("aileron", "rudder"))]
        assert len(lateral) >= 2
        d = run.data[run.data["maneuver"].isin(lateral)]
        true_beta = np.interp(d["t_record"], truth["t_record"], truth["beta"])
        err[mode] = float(np.sqrt(np.mean((d["beta"].to_numpy() - true_beta) ** 2)))
        said = [run.maneuvers[m]["observability"]["wind"] for m in straight]
        assert all(("the campaign's turns'" in w) == (mode == "campaign") for w in said)
    assert err["campaign"] < 0.5 * err["maneuver"], err
    # without a maneuver list the turns are found between the detected maneuvers
    text = (rec / "mapping.toml").read_text()
    (rec / "detect.toml").write_text(text[:text.index("[segments]")])
    found = import_record(rec / "detect.toml")
    assert (found.data.groupby("maneuver")["maneuver_type"].first() == "turn").sum() >= 2
    assert any("turn(s) cut as maneuvers" in n for n in found.segment_notes)
    with pytest.raises(InputError, match="wind_calibration must be 'campaign' or 'maneuver'"):
        ReconstructionSettings(wind_calibration="turns")


def test_a_lateral_maneuver_flown_from_trim_keeps_its_sideslip(tmp_path, still_air_course):
    """The same course: without a vane or a heading, a straight maneuver's mean sideslip
    is not observable (a heading error and a sideslip error give the same GPS track). A
    zero mean over the maneuver (``sideslip_prior='mean'``) is wrong for a doublet or a
    pulse, and it left the offset to the filter's slight model errors: the aileron and
    rudder maneuvers' sideslip came out 0.2-2.8e-3 rad off when this test was written. In
    still air the filter now takes the sideslip as zero where the maneuver flies trimmed
    (before the input, after the free response): 0.03-0.7e-3. The turns, never trimmed,
    keep the zero mean; the statements say which rule each maneuver had."""
    rec = write_channel_record(still_air_course, tmp_path / "record", turns=True)
    kinds = pd.read_csv(rec / "maneuvers.csv")["type"]
    data = import_record(rec / "mapping.toml").data
    truth = pd.read_csv(rec / "truth.csv")
    offset, said = {}, {}
    for mode in ("mean", "trim"):
        run = reconstruct(data, workers=1,
                          settings=ReconstructionSettings(sideslip_prior=mode))
        offset[mode], said[mode] = {}, {}
        for m, g in run.data.groupby("maneuver"):
            true_beta = np.interp(g["t_record"], truth["t_record"], truth["beta"])
            offset[mode][m] = abs(float(np.mean(g["beta"].to_numpy() - true_beta)))
            said[mode][m] = run.maneuvers[m]["observability"]["beta"]
    lateral = [m for m in offset["trim"] if str(kinds[m]).endswith(("aileron", "rudder"))]
    assert len(lateral) == 4
    assert max(offset["trim"][m] for m in lateral) < 0.3 * max(offset["mean"][m]
                                                               for m in lateral), offset
    assert np.mean([offset["trim"][m] for m in lateral]) < 0.5 * np.mean(
        [offset["mean"][m] for m in lateral]), offset
    for m, kind in kinds.items():
        if kind == "turn":
            # never trimmed: the zero mean (weighed at least MEAN_SIDESLIP when short)
            assert offset["trim"][m] == pytest.approx(offset["mean"][m], abs=3e-5)
            assert said["trim"][m].endswith("zero mean over the maneuver assumed")
        else:
            assert said["trim"][m].endswith("zero where the maneuver flies trimmed (wings "
                                            "level, no rotation, the ball centred)"), kind
        assert said["mean"][m].endswith("zero mean over the maneuver assumed")
        assert said["trim"][m].startswith("estimated from the lateral kinematics")
    # the lateral maneuvers cut to their untrimmed middle (a segment detected tightly
    # around its input): too short for the per-sample zero mean to weigh anything, they
    # get one of MEAN_SIDESLIP over the maneuver (0.4-4.3e-3 -> 0.3-1.6e-3 rad, RMS 2.5e-3
    # -> 1.0e-3, when this test was written)
    keep = np.ones(len(data), dtype=bool)
    for m in lateral:
        rows = np.flatnonzero(data["maneuver"].to_numpy() == m)
        level = trimmed({c: data[c].to_numpy()[rows] for c in ("p", "r", "phi", "ay")})
        moving = np.flatnonzero(~level)
        keep[rows] = False
        keep[rows[moving[0]:moving[-1] + 1]] = True
    cut = data[keep].reset_index(drop=True)
    cut.attrs = data.attrs
    rms = {}
    for mode in ("mean", "trim"):
        run = reconstruct(cut, workers=1, settings=ReconstructionSettings(sideslip_prior=mode))
        off = []
        for m in lateral:
            g = run.data[run.data["maneuver"] == m]
            off.append(float(np.mean(g["beta"].to_numpy() - np.interp(
                g["t_record"], truth["t_record"], truth["beta"]))))
        rms[mode] = float(np.sqrt(np.mean(np.square(off))))
    assert rms["trim"] < 0.6 * rms["mean"], rms
    with pytest.raises(InputError, match="sideslip_prior must be 'trim' or 'mean'"):
        ReconstructionSettings(sideslip_prior="zero")


def test_a_vane_on_a_nose_boom_is_found_with_its_scale_error_by_the_campaign(tmp_path):
    """A still-air flight-test course (a stationary measurement and eigenmotions at each of
    two airspeeds), the angle-of-attack vane 4 m ahead on a boom with a 4 % scale error,
    neither in the record's metadata. A stationary measurement observes only offset +
    k alpha, a turn the boom's -q x / V as an offset: the campaign combines the maneuvers'
    joint information (combine_joint) and finds the boom and the scale error, and the
    angle of attack is better than with the position held where nothing gives it (here
    2.7e-4 -> 2.0e-4 rad when written; on the bench's six-airspeed Cessna course the
    boom came out at 3.95 +- 0.42 m and alpha 8.0e-4 -> 2.0e-4 rad with the scale)."""
    df = WholeFlight("c172p", sensors=SensorModel.real_like(), wind=Wind((5.0, 6.0), "none"),
                     protocol=FlightProtocol.eigenmotion(), legs=[(1000.0, 55.0),
                                                                  (1000.0, 45.0)],
                     maneuvers=5, seed=4, stationary_s=(60.0, 80.0)).run()
    rec = write_channel_record(df, tmp_path / "record", turns=True)
    data = import_record(rec / "mapping.toml").data
    truth = pd.read_csv(rec / "truth.csv")
    found = reconstruct(data, workers=1)
    held = reconstruct(data, workers=1,
                       settings=ReconstructionSettings(estimate_vane_position=False))
    x, x_sd = found.calibration["xalpha"]
    k, k_sd = found.calibration["kalpha"]
    boom = SensorModel.real_like().alpha_vane
    assert abs(x - boom["position_m"][0]) < max(3 * x_sd, 0.5), (x, x_sd)
    assert abs(k - (boom["scale"] - 1.0)) < max(3 * k_sd, 0.01), (k, k_sd)
    assert "xalpha" not in held.calibration
    assert all(r["held"]["xalpha"].startswith("not requested") for r in held.maneuvers.values())

    def rms(run):
        d = run.data
        return float(np.sqrt(np.mean(
            (d["alpha"] - np.interp(d["t_record"], truth["t_record"], truth["alpha"])) ** 2)))

    assert rms(found) < 0.85 * rms(held), (rms(found), rms(held))
    given = dict(data.attrs, sensor_geometry={"alpha_vane": {"position_m": boom["position_m"]}})
    run = reconstruct(data, given, workers=1)
    assert all(r["held"]["xalpha"] == "given in the sensor geometry: held there"
               for r in run.maneuvers.values())
