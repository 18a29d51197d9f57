"""A whole flight-test sortie on one JSBSim model: phases, physics, the record written."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from simplexspline.errors import InputError
from simplexspline.sim import FlightProtocol, SensorModel, write_channel_record
from simplexspline.sim.record_export import _position
from simplexspline.sim.whole_flight import FLIGHT_TYPE, STATIONARY_TYPE, WholeFlight

from .test_campaign import _eq43_48

LEGS = [(3000.0, 170.0), (3000.0, 190.0)]


@pytest.fixture(scope="module")
def sortie():
    """Two test points, three maneuvers, a turn before each, perfect sensors (~2 s)."""
    return WholeFlight("global5000", legs=LEGS, maneuvers=3, seed=4, steady_s=(6.0, 8.0),
                       turn_probability=1.0, sensors=SensorModel.ideal(),
                       protocol=FlightProtocol(mix={"3211": 1, "doublet": 1,
                                                    "sum-of-sines": 1},
                                               sos_duration_s=(12.0, 12.0))).run()


def _phase(df, seg):
    return df[(df["t"] >= seg["start_s"] - 1e-9) & (df["t"] <= seg["end_s"] + 1e-9)]


def test_one_continuous_flight_with_every_phase_listed(sortie):
    assert sortie["maneuver"].nunique() == 1 and set(sortie["maneuver_type"]) == {FLIGHT_TYPE}
    segs = sortie.attrs["flight"]["segments"]
    assert segs[0]["start_s"] == 0.0 and segs[-1]["end_s"] == pytest.approx(sortie["t"].iloc[-1])
    for a, b in zip(segs, segs[1:]):            # contiguous: one sample apart
        assert b["start_s"] == pytest.approx(a["end_s"] + 0.01)
    kinds = [s["type"] for s in segs]
    assert kinds.count("transition") == 1 and kinds.count("turn") == 3
    flown = [k for k in kinds if k not in ("steady", "turn", "transition")]
    assert sorted(k.split("-")[0] for k in flown) == ["3211", "doublet", "sum"]
    assert np.all(np.diff(sortie["t"]) == pytest.approx(0.01))


def test_the_flight_is_physical_throughout(sortie):
    """Eq. 43-48 hold in every phase (one model flown, not pieces blended)."""
    for name, c in _eq43_48(sortie).items():
        assert np.max(np.abs(c.to_numpy() - sortie[f"true_{name}"].to_numpy())) <= 1e-6, name
    assert np.all(np.diff(sortie["mass"]) <= 0)                     # fuel is burnt
    assert sortie["mass"].iloc[0] - sortie["mass"].iloc[-1] > 1.0


def test_the_pilot_flies_to_the_next_test_point_and_turns(sortie):
    segs = sortie.attrs["flight"]["segments"]
    i = [s["type"] for s in segs].index("transition")
    after = _phase(sortie, segs[i + 1])                              # the settling
    assert abs(after["true_tas"].iloc[-1] - LEGS[1][1]) < 3.0
    assert abs(after["true_h"].iloc[-1] - LEGS[1][0]) < 50.0
    for seg in (s for s in segs if s["type"] == "turn"):
        g = _phase(sortie, seg)
        change = abs(np.unwrap(g["true_psi"].to_numpy())[-1] - g["true_psi"].iloc[0])
        assert math.radians(50) < change < math.radians(190)        # 60-180 deg planned
        assert abs(g["true_phi"].iloc[-1]) < math.radians(5)         # wings level again


def test_the_record_of_a_whole_flight_lists_its_maneuvers(sortie, tmp_path):
    rec = write_channel_record(sortie, tmp_path / "rec")
    spans = pd.read_csv(rec / "maneuvers.csv")
    flown = [s for s in sortie.attrs["flight"]["segments"]
             if s["type"] not in ("steady", "turn", "transition")]
    assert list(spans["type"]) == [s["type"] for s in flown]
    assert np.allclose(spans["end"] - spans["start"],
                       [s["end_s"] - s["start_s"] for s in flown], atol=0.2)  # 10 Hz
    ias = np.loadtxt(rec / "ias.txt", skiprows=1)[:, 1]
    assert ias[0] < 20 and ias[-1] < 20 and ias.max() > 300         # taxi, fly, taxi


def test_gps_positions_far_from_the_start_keep_the_ground_speed():
    """400 km north the east distance per degree of longitude is 7 % shorter than at the
    start: latitude and longitude must be integrated with the radii where the aircraft is."""
    n = 30000                                     # 3000 s at 10 Hz
    lat, lon = _position(np.full(n, 150.0), np.full(n, 200.0), 10.0)
    e2 = 6.69437999014e-3
    r_e = 6378137.0 / np.sqrt(1 - e2 * np.sin(lat[-1]) ** 2)
    r_n = 6378137.0 * (1 - e2) / (1 - e2 * np.sin(lat[-1]) ** 2) ** 1.5
    assert (lon[-1] - lon[-2]) * 10 * r_e * np.cos(lat[-1]) == pytest.approx(200.0, rel=1e-4)
    assert (lat[-1] - lat[-2]) * 10 * r_n == pytest.approx(150.0, rel=1e-4)
    assert math.degrees(lat[-1] - lat[0]) > 3.5


@pytest.mark.parametrize("kwargs, match", [
    ({"legs": [(3000.0, -5.0)]}, "legs must be"),
    ({"legs": [(1000.0, 330.0)]}, "above the envelope's"),
    ({"maneuvers": 0}, "maneuvers must be a positive integer"),
    ({"steady_s": (5.0, 1.0)}, "steady_s must be"),
    ({"turn_probability": 2.0}, "turn_probability must be in"),
    ({"stationary_s": (0.0, 10.0)}, "stationary_s must be"),
])
def test_bad_flights_are_refused(kwargs, match):
    with pytest.raises(InputError, match=match):
        WholeFlight("global5000", **kwargs)


def test_the_eigenmotion_design_refuses_3211s_in_its_mix():
    with pytest.raises(InputError, match="pulses and doublets only; the mix gives"):
        FlightProtocol(mix={"3211": 1, "pulse": 1}, design="eigenmotion")


def test_a_flight_test_course_logs_its_stationary_measurements_and_eigenmotions(tmp_path):
    """The course's design: each leg opens with a stationary measurement (trimmed straight
    flight, logged and listed as a maneuver), and the maneuvers are single pulses and
    doublets with their free responses; the elevator pulse changes the airspeed (a
    phugoid), the stationary measurement does not."""
    flight = WholeFlight("global5000", legs=LEGS, maneuvers=2, seed=3, steady_s=(5.0, 5.0),
                         stationary_s=(20.0, 25.0), turn_probability=0.0,
                         sensors=SensorModel.ideal(),
                         protocol=FlightProtocol.eigenmotion(mix={"pulse": 1}))
    df = flight.run()
    segs = df.attrs["flight"]["segments"]
    kinds = [s["type"] for s in segs]
    assert kinds.count(STATIONARY_TYPE) == 2 and df.attrs["flight"]["stationary_s"] == [20, 25]
    assert kinds.index(STATIONARY_TYPE) == 0                      # the first leg's
    assert kinds[kinds.index("transition") + 2] == STATIONARY_TYPE  # after settling
    flown = [s for s in segs if s["type"] not in ("steady", "turn", "transition")]
    assert {s["type"] for s in flown} == {STATIONARY_TYPE, "pulse-elevator", "pulse-aileron"}
    for seg in flown:
        g = _phase(df, seg)
        spread = np.ptp(g["true_tas"].to_numpy())
        if seg["type"] == STATIONARY_TYPE:
            assert 20.0 <= seg["end_s"] - seg["start_s"] <= 25.01
            assert spread < 1.0 and np.ptp(g["de"].to_numpy()) < math.radians(0.5)
        elif seg["type"] == "pulse-elevator":
            assert seg["end_s"] - seg["start_s"] > 40.0              # a phugoid period
            assert spread > 3.0
    spans = pd.read_csv(write_channel_record(df, tmp_path / "rec") / "maneuvers.csv")
    assert list(spans["type"]) == [s["type"] for s in flown]
