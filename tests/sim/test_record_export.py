"""The real-format record writer: per-channel text files in aviation units."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from simplexspline.errors import InputError
from simplexspline.sim.record_export import RECORD_CHANNELS, write_channel_record

G0, KT, FT, LB = 9.80665, 1852.0 / 3600.0, 0.3048, 0.45359237


def _channel(path, name) -> np.ndarray:
    return np.loadtxt(path / f"{name}.txt", skiprows=1, ndmin=2)


@pytest.fixture(scope="module")
def record(tmp_path_factory, global5000_ideal):
    out = tmp_path_factory.mktemp("rec") / "record"
    write_channel_record(global5000_ideal, out)
    return out


def test_files_units_and_missing_channels(record, global5000_ideal):
    names = {p.name for p in record.iterdir()}
    assert names == {f"{c}.txt" for c in RECORD_CHANNELS} | {"maneuvers.csv", "mapping.toml",
                                                              "truth.csv"}
    assert (record / "heading.txt").read_text() == ""       # the heading channel failed
    assert not any("beta" in n or "vn" in n for n in names)  # no sideslip vane, no GPS speed
    spans = pd.read_csv(record / "maneuvers.csv")
    assert len(spans) == global5000_ideal["maneuver"].nunique()
    aoa, an = _channel(record, "vane_aoa"), _channel(record, "an_g")
    assert np.allclose(np.diff(aoa[:, 0]), 0.1)  # 10 Hz on one clock
    for _, s in spans.iterrows():
        m = global5000_ideal[global5000_ideal["maneuver"] == s["maneuver"]].iloc[::10]
        k = (aoa[:, 0] >= s["start"] - 1e-6) & (aoa[:, 0] <= s["end"] + 1e-6)
        assert k.sum() == len(m) and str(m["maneuver_type"].iloc[0]) == s["type"]
        assert np.allclose(aoa[k, 1], np.degrees(m["alpha"]), rtol=1e-7, atol=1e-9)
        assert np.allclose(an[k, 1], -m["az"] / G0, rtol=1e-7)
    hp = _channel(record, "hp")[:, 1] * FT
    ground = np.round(hp, 6) == np.round(hp[0], 6)
    assert ground[:100].all() and hp[0] == pytest.approx(global5000_ideal["h"].min() - 300.0,
                                                          abs=1e-3)  # below every maneuver
    fuel = _channel(record, "fuel_used")[:, 1]
    starts = [np.searchsorted(aoa[:, 0], s - 1e-6) for s in spans["start"]]
    assert fuel[0] == 0.0 and np.all(np.diff(fuel[starts]) >= 0)  # fuel is burnt
    flow, n1 = _channel(record, "fuel_flow"), _channel(record, "n1")   # lbs/hr and %
    for _, s in spans.iterrows():
        m = global5000_ideal[global5000_ideal["maneuver"] == s["maneuver"]].iloc[::10]
        k = (flow[:, 0] >= s["start"] - 1e-6) & (flow[:, 0] <= s["end"] + 1e-6)
        assert np.allclose(flow[k, 1] * LB / 3600.0, m["fuel_flow"], rtol=1e-7)
        assert np.allclose(n1[k, 1] / 100.0, m["n1"], rtol=1e-7)


def test_indicated_airspeed_inverts_to_the_true_airspeed(record):
    """Ideal sensors: IAS and SAT with the true pressure give back TAS (St Venant, ISA)."""
    truth = pd.read_csv(record / "truth.csv")
    ias = _channel(record, "ias")[:, 1] * KT
    temp = _channel(record, "sat")[:, 1] + 273.15
    pressure = truth["rho"] * 287.05287 * temp
    qc = 101325.0 * ((1 + (ias / 340.294) ** 2 / 5) ** 3.5 - 1)
    mach = np.sqrt(5 * ((qc / pressure + 1) ** (2 / 7) - 1))
    tas = mach * np.sqrt(1.4 * 287.05287 * temp)
    airborne = truth["tas"] > 50
    assert np.allclose(tas[airborne], truth["tas"][airborne], rtol=2e-6)


def test_the_altimeter_shows_the_isa_pressure_altitude_of_the_static_pressure(record):
    """Ideal sensors: the record's pressure altitude gives back the static pressure through
    the ISA, as an altimeter set to 1013.25 hPa does (JSBSim's own pressure-altitude is the
    standard day's geometric altitude: 0.1 % of pressure off at 4.5 km), so the import's
    density is the simulator's."""
    from simplexspline.aero.data.atmosphere import isa_pressure

    truth = pd.read_csv(record / "truth.csv")
    temp = _channel(record, "sat")[:, 1] + 273.15
    hp = _channel(record, "hp")[:, 1]
    t = _channel(record, "hp")[:, 0]
    spans = pd.read_csv(record / "maneuvers.csv")
    # the maneuvers (the transitions between them blend each channel on its own)
    inside = np.zeros(t.size, dtype=bool)
    for _, s in spans.iterrows():
        inside |= (t >= s["start"] - 1e-6) & (t <= s["end"] + 1e-6)
    rho = isa_pressure(hp[inside] * FT) / (287.05287 * temp[inside])
    assert np.allclose(rho, truth["rho"][inside], rtol=1e-6)


def test_record_refuses_to_overwrite_and_odd_rates(tmp_path, global5000_ideal):
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x.txt").write_text("mine")
    with pytest.raises(InputError, match="exists and is not an empty directory"):
        write_channel_record(global5000_ideal, tmp_path / "full")
    assert (tmp_path / "full" / "x.txt").read_text() == "mine"
    with pytest.raises(InputError, match="must divide the campaign's 100 Hz"):
        write_channel_record(global5000_ideal, tmp_path / "odd", rate_hz=30.0)
    assert not (tmp_path / "odd").exists()


def test_mapping_file_describes_the_record(record, global5000_ideal):
    import tomllib

    m = tomllib.loads((record / "mapping.toml").read_text())
    assert m["record"]["format"] == "channels" and m["record"]["rate_hz"] == 10
    assert {c["source"] for c in m["channels"].values()} == set(RECORD_CHANNELS)
    assert m["channels"]["az"]["sign"] == -1
    s = float(m["aircraft"]["S"].split()[0])
    assert s == pytest.approx(global5000_ideal.attrs["S"], rel=1e-5)
    ramp = float(m["aircraft"]["ramp_mass"].split()[0]) * LB
    assert ramp == pytest.approx(global5000_ideal["mass"].max(), rel=1e-5)
    assert math.isclose(float(m["aircraft"]["radii_of_gyration"]["y"].split()[0]),
                        float(np.sqrt((global5000_ideal["Iyy"] / global5000_ideal["mass"])
                                      .iloc[0])), rel_tol=0.05)
