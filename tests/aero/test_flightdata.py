"""Flight-data schema: validation errors name the column; files round-trip atomically."""

from __future__ import annotations

import math
import os

import numpy as np
import pandas as pd
import pytest

from simplexspline.aero.data.flight_data import (
    FLIGHT_DATA_COLUMNS,
    REQUIRED_COLUMNS,
    SCHEMA_VERSION,
    SENSOR_COLUMNS,
    FlightDataWarning,
    NanGap,
    present_columns,
    read_flight_data,
    sensor_geometry,
    sidecar_path,
    validate_flight_data,
    without_metadata,
    write_flight_data,
)
from simplexspline.errors import FlightDataError, InputError


def make_data(rng: np.random.Generator, maneuvers: int = 3, n: int = 50) -> pd.DataFrame:
    """A small table with every required and sensor column, plausible values, metadata."""
    rows = maneuvers * n
    df = pd.DataFrame({
        "maneuver": np.repeat(np.arange(maneuvers, dtype=np.int64), n),
        "t": np.tile(np.arange(n) * 0.01, maneuvers),
    })
    for name in REQUIRED_COLUMNS + SENSOR_COLUMNS:
        if name in df:
            continue
        df[name] = rng.uniform(0.01, 0.2, rows)
    df["tas"] = rng.uniform(100, 200, rows)
    df["mass"] = 9000.0
    df["maneuver_type"] = pd.Categorical(["sum-of-sines"] * rows)
    df["true_CX"] = rng.normal(size=rows)
    df.attrs = {"schema": SCHEMA_VERSION, "aircraft": "test", "S": 27.87, "b": 9.14,
                "cbar": 3.45, "nested": {"seed": 0, "list": [1, 2.5]}}
    return df


def test_the_table_documents_every_column():
    for name, spec in FLIGHT_DATA_COLUMNS.items():
        assert spec.name == name and spec.kind in ("float", "int", "str")
        assert spec.description
    assert FLIGHT_DATA_COLUMNS["alpha"].unit == "rad"
    assert FLIGHT_DATA_COLUMNS["Ixz"].unit == "kg m^2"
    assert FLIGHT_DATA_COLUMNS["true_Cm"].unit == "-"
    assert FLIGHT_DATA_COLUMNS["true_alpha"].unit == "rad"
    assert "maneuver" in REQUIRED_COLUMNS and "pdot" not in REQUIRED_COLUMNS


def test_documentation_lists_every_column():
    doc = os.path.join(os.path.dirname(__file__), "..", "..", "docs", "flight-data-schema.md")
    with open(doc) as f:
        text = f.read()
    missing = [c for c in FLIGHT_DATA_COLUMNS if f"`{c}`" not in text]
    assert missing == []


@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_round_trip(tmp_path, rng, suffix):
    df = make_data(rng)
    path = write_flight_data(df, tmp_path / f"d{suffix}")
    back, meta = read_flight_data(path)
    pd.testing.assert_frame_equal(back, df, check_exact=True, check_categorical=False)
    assert meta["nested"] == {"seed": 0, "list": [1, 2.5]}
    assert meta["units"]["alpha"] == "rad" and meta["units"]["tas"] == "m/s"
    assert back.attrs == meta
    if suffix == ".csv":
        assert sidecar_path(path).name == "d.csv.json"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["d.csv", "d.csv.json"] if suffix == ".csv" else ["d.parquet"])


def test_metadata_argument_overrides_attrs(tmp_path, rng):
    df = make_data(rng)
    meta = {**df.attrs, "aircraft": "other"}
    _, back = read_flight_data(write_flight_data(df, tmp_path / "d.parquet", meta))
    assert back["aircraft"] == "other"


class _CopyCounter:
    """Metadata that count how often pandas deep-copies them."""

    copies = 0

    def __deepcopy__(self, memo):
        type(self).copies += 1
        return self


def test_checks_and_writes_never_copy_the_metadata_per_column(tmp_path, rng):
    # pandas deep-copies ``attrs`` into every column it hands out; a campaign's metadata
    # made validating a 60-maneuver reconstruction spend seconds in copies
    df = make_data(rng)
    meta = dict(df.attrs)
    df.attrs = {**meta, "probe": _CopyCounter()}
    _CopyCounter.copies = 0
    validate_flight_data(df, meta)
    write_flight_data(df, tmp_path / "d.parquet", meta)
    assert _CopyCounter.copies == 0
    plain = without_metadata(df)
    assert plain.attrs == {} and "probe" in df.attrs
    assert np.shares_memory(plain["alpha"].to_numpy(), df["alpha"].to_numpy())


@pytest.mark.parametrize("column", ["alpha", "Ixz", "maneuver", "t"])
def test_missing_required_column_is_named(rng, column):
    df = make_data(rng).drop(columns=[column])
    with pytest.raises(FlightDataError, match=f"required column.*'{column}'"):
        validate_flight_data(df)


def test_wrong_unit_tag_is_named(rng):
    df = make_data(rng)
    meta = {**df.attrs, "units": {"alpha": "deg"}}
    with pytest.raises(FlightDataError, match="column 'alpha' has unit 'deg'.*requires 'rad'"):
        validate_flight_data(df, meta)


def test_values_in_degrees_are_caught(rng):
    df = make_data(rng)
    df.loc[10, "beta"] = 12.0
    with pytest.raises(FlightDataError, match="column 'beta' has value 12 at row 10.*radians"):
        validate_flight_data(df)


def test_a_noisy_north_heading_just_above_two_pi_is_accepted(rng):
    """A heading recorded in [0, 2 pi) plus sensor noise flying north: not 'impossible'."""
    df = make_data(rng)
    df["psi"] = 2 * np.pi + 0.01 * np.sin(np.arange(len(df)))
    validate_flight_data(df)
    df.loc[3, "psi"] = 350.0                      # a heading in degrees is still caught
    with pytest.raises(FlightDataError, match="column 'psi' has value 350 at row 3.*radians"):
        validate_flight_data(df)


@pytest.mark.parametrize("column, value", [("tas", 0.0), ("rho", -1.0), ("Izz", 0.0)])
def test_non_positive_physical_quantities(rng, column, value):
    df = make_data(rng)
    df.loc[3, column] = value
    with pytest.raises(FlightDataError, match=f"column '{column}'"):
        validate_flight_data(df)


def test_time_must_increase_within_each_maneuver(rng):
    df = make_data(rng)
    validate_flight_data(df)  # restarting at 0 in the next maneuver is fine
    df.loc[60, "t"] = df.loc[58, "t"]
    with pytest.raises(FlightDataError, match="column 't' is not strictly increasing within "
                                              "maneuver 1 .row 60"):
        validate_flight_data(df)


def test_interleaved_maneuvers_are_checked_per_maneuver(rng):
    df = make_data(rng).sample(frac=1.0, random_state=1)
    df = df.sort_values(["t", "maneuver"], kind="stable").reset_index(drop=True)
    df.attrs = make_data(rng).attrs
    validate_flight_data(df)


def test_nan_gaps_are_reported_never_filled(rng):
    df = make_data(rng)
    df.loc[45:54, "q"] = np.nan  # spans the end of maneuver 0 and start of maneuver 1
    df.loc[120, "ax"] = np.nan
    with pytest.warns(FlightDataWarning, match="3 NaN gap"):
        report = validate_flight_data(df)
    assert report.nan_gaps == [NanGap("q", 0, 0.45, 5), NanGap("q", 1, 0.0, 5),
                               NanGap("ax", 2, 0.2, 1)]
    assert report.rows == 150 and report.maneuvers == 3
    with pytest.raises(FlightDataError, match="column 'q' has 5 NaN sample.*maneuver 0"):
        validate_flight_data(df, nan="raise")
    assert validate_flight_data(df, nan="ignore").nan_gaps == report.nan_gaps
    assert df["q"].isna().sum() == 10


def test_nan_gaps_survive_a_round_trip(tmp_path, rng):
    df = make_data(rng)
    df.loc[7, "r"] = np.nan
    path = write_flight_data(df, tmp_path / "d.parquet")
    with pytest.warns(FlightDataWarning, match="column.*'r'"):
        back, _ = read_flight_data(path)
    assert math.isnan(back.loc[7, "r"])


def test_infinite_values(rng):
    df = make_data(rng)
    df.loc[5, "az"] = np.inf
    with pytest.raises(FlightDataError, match="column 'az' contains infinite values .first "
                                              "at row 5"):
        validate_flight_data(df)


def test_types(rng):
    df = make_data(rng)
    df["maneuver"] = df["maneuver"].astype(float)
    with pytest.raises(FlightDataError, match="column 'maneuver' must hold integers"):
        validate_flight_data(df)
    df = make_data(rng)
    df["alpha"] = "x"
    with pytest.raises(FlightDataError, match="column 'alpha' must be numeric"):
        validate_flight_data(df)
    df = make_data(rng)
    df["maneuver_type"] = 3
    with pytest.raises(FlightDataError, match="column 'maneuver_type' must hold strings"):
        validate_flight_data(df)


@pytest.mark.parametrize("change, match", [
    ({"schema": "simplexspline.flightdata/2"}, "reads 'simplexspline.flightdata/1'"),
    ({"S": 0.0}, "metadata 'S' must be a positive number"),
    ({"cbar": "wide"}, "metadata 'cbar' must be a positive number"),
    ({"units": ["rad"]}, "metadata 'units' must map"),
])
def test_bad_metadata(rng, change, match):
    df = make_data(rng)
    with pytest.raises(FlightDataError, match=match):
        validate_flight_data(df, {**df.attrs, **change})


def test_missing_metadata_key(rng):
    df = make_data(rng)
    meta = dict(df.attrs)
    del meta["b"]
    with pytest.raises(FlightDataError, match="metadata key 'b' is missing"):
        validate_flight_data(df, meta)


def test_unknown_columns_are_kept_and_listed(tmp_path, rng):
    df = make_data(rng)
    df["oil_temperature"] = 1.0
    assert validate_flight_data(df).unknown_columns == ["oil_temperature"]
    back, _ = read_flight_data(write_flight_data(df, tmp_path / "d.parquet"))
    assert "oil_temperature" in back


def test_invalid_data_are_not_written(tmp_path, rng):
    good = make_data(rng)
    path = write_flight_data(good, tmp_path / "d.parquet")
    before = path.read_bytes()
    bad = good.drop(columns=["alpha"])
    with pytest.raises(FlightDataError, match="'alpha'"):
        write_flight_data(bad, path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["d.parquet"]


def test_failed_write_leaves_old_file_and_no_temporaries(tmp_path, rng, monkeypatch):
    import pyarrow.parquet as pq

    good = make_data(rng)
    path = write_flight_data(good, tmp_path / "d.parquet")
    before = path.read_bytes()

    def broken(table, where, **kwargs):
        with open(where, "wb") as f:
            f.write(b"partial")
        raise OSError("disk full")

    monkeypatch.setattr(pq, "write_table", broken)
    with pytest.raises(OSError, match="disk full"):
        write_flight_data(good, path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["d.parquet"]


def test_read_errors(tmp_path, rng):
    with pytest.raises(FlightDataError, match="does not exist"):
        read_flight_data(tmp_path / "none.parquet")
    (tmp_path / "junk.parquet").write_bytes(b"not parquet")
    with pytest.raises(FlightDataError, match="cannot read Parquet file"):
        read_flight_data(tmp_path / "junk.parquet")
    make_data(rng).to_csv(tmp_path / "d.csv", index=False)
    with pytest.raises(FlightDataError, match="need their metadata sidecar .*d.csv.json"):
        read_flight_data(tmp_path / "d.csv")
    with pytest.raises(InputError, match="unknown flight-data file type '.xlsx'"):
        read_flight_data(tmp_path / "d.xlsx")
    with pytest.raises(InputError, match="directory .* does not exist"):
        write_flight_data(make_data(rng), tmp_path / "no" / "d.parquet")


def test_invalid_nan_policy(rng):
    with pytest.raises(InputError, match="nan must be"):
        validate_flight_data(make_data(rng), nan="fill")


def test_not_a_dataframe():
    with pytest.raises(FlightDataError, match="must be a pandas DataFrame"):
        validate_flight_data({"t": [0.0]}, {"schema": SCHEMA_VERSION})


@pytest.mark.parametrize("column", list(SENSOR_COLUMNS))
def test_sensors_real_aircraft_lack_are_optional(rng, column):
    df = make_data(rng).drop(columns=[column])
    assert column not in REQUIRED_COLUMNS
    assert validate_flight_data(df).nan_gaps == []


def test_a_column_that_is_entirely_nan_counts_as_absent(rng):
    df = make_data(rng)
    df["beta"] = np.nan
    df["vn_gps"] = np.nan
    report = validate_flight_data(df, nan="raise")      # no gap: an empty channel is absent
    assert report.empty_columns == ["beta", "vn_gps"] and report.nan_gaps == []
    assert "beta" not in present_columns(df) and "alpha" in present_columns(df)
    assert "maneuver_type" in present_columns(df)
    df["alpha"] = np.nan
    with pytest.raises(FlightDataError, match="required column 'alpha' is entirely NaN"):
        validate_flight_data(df)


def test_sensor_geometry_is_parsed_with_defaults(rng):
    geo = sensor_geometry({"sensor_geometry": {
        "alpha_vane": {"position_m": [5.2, 0, -0.3], "scale": 1.05, "offset_rad": 0.01},
        "lag_s": {"alpha": 0.05}}})
    assert geo.alpha_vane.position_m == (5.2, 0.0, -0.3) and geo.alpha_vane.scale == 1.05
    assert geo.beta_vane.position_m == (0.0, 0.0, 0.0) and geo.beta_vane.scale == 1.0
    assert geo.imu_position_m == (0.0, 0.0, 0.0) and geo.lag_s == {"alpha": 0.05}
    assert geo.given == ("alpha_vane", "lag_s")
    assert geo.positions_given == ("alpha_vane",)
    assert sensor_geometry({}).given == ()
    calibration_only = sensor_geometry({"sensor_geometry": {"beta_vane": {"scale": 0.97}}})
    assert calibration_only.given == ("beta_vane",) and calibration_only.positions_given == ()


@pytest.mark.parametrize("geo, match", [
    ({"pitot": {}}, "unknown key.*'pitot'"),
    ({"alpha_vane": {"position_m": [5200, 0, 0]}}, "alpha_vane.position_m.*within 100 m"),
    ({"imu": {"position_m": [1, 2]}}, "imu.position_m must be three"),
    ({"beta_vane": {"scale": 0}}, "beta_vane.scale must be a finite positive"),
    ({"lag_s": {"alpha": 50}}, "lag_s.alpha = 50 s is outside"),
    ({"lag_s": {"fuel": 0.1}}, "unknown channel 'fuel'"),
])
def test_bad_sensor_geometry_is_named(rng, geo, match):
    df = make_data(rng)
    df.attrs["sensor_geometry"] = geo
    with pytest.raises(FlightDataError, match=match):
        validate_flight_data(df)


def test_sensor_geometry_round_trips(tmp_path, rng):
    df = make_data(rng)
    df.attrs["sensor_geometry"] = {"imu": {"position_m": [0.5, 0.0, 0.1]},
                                   "lag_s": {"tas": 0.1}}
    _, meta = read_flight_data(write_flight_data(df, tmp_path / "d.parquet"))
    assert sensor_geometry(meta).imu_position_m == (0.5, 0.0, 0.1)
