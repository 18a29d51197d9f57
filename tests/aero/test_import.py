"""Import of a real-format record against the simulated flight it was made from.

The record in tests/data/citation_like (made by tests/data/make_citation_like_record.py from
three simulated global5000 maneuvers) is in aviation units, one text file per channel, 10 Hz,
indicated airspeed instead of TAS, no sideslip vane, an empty heading file, GPS latitude and
longitude only, the normal load factor in g, fuel used in lbs, 20 s on the ground.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from simplexspline.aero import identify, parse_structure
from simplexspline.aero.data.flight_data import read_flight_data
from simplexspline.aero.data.record_import import import_record
from simplexspline.aero.data.sanity import check_record
from simplexspline.aero.identify import IdentificationSettings
from simplexspline.cli import main
from simplexspline.errors import InputError

DATA = Path(__file__).resolve().parents[1] / "data" / "citation_like"
MAPPING = DATA / "mapping.toml"
LB, KT = 0.45359237, 1852.0 / 3600.0


@pytest.fixture(scope="module")
def truth():
    return pd.read_csv(DATA / "truth.csv")


@pytest.fixture(scope="module")
def imported():
    return import_record(MAPPING)


def _joined(result, truth):
    d = result.data.merge(truth, on="t_record", suffixes=("", "_true"), validate="1:1")
    assert len(d) == len(result.data)
    return d


def test_units_signs_and_derived_quantities_match_the_truth(imported, truth):
    d = _joined(imported, truth)
    # deg, deg/s, g (with the load factor's sign flipped) -> rad, rad/s, m/s^2
    for col in ("alpha", "p", "q", "r", "phi", "theta", "de", "da", "dr"):
        assert np.max(np.abs(d[col] - d[f"{col}_true"])) < 1e-6, col
    for col in ("ax", "ay", "az"):
        assert np.max(np.abs(d[col] - d[f"{col}_true"])) < 1e-5, col
    assert d["az"].mean() < -5.0                                 # -g in level flight
    # ft -> m; knots IAS + pressure altitude + degC -> Mach, TAS; ISA density
    assert np.max(np.abs(d["h"] - d["h_true"])) < 1e-3
    assert np.max(np.abs(d["tas"] - d["tas_true"])) < 1e-3
    assert np.max(np.abs(d["mach"] - d["mach_true"])) < 1e-5
    assert np.max(np.abs(d["rho"] / d["rho_true"] - 1)) < 1e-3  # JSBSim's own atmosphere
    # lbs fuel used from a 14000 lb ramp mass; radii of gyration 2.6, 3.1, 3.9 m
    assert np.max(np.abs(d["mass"] - d["mass_true"])) < 1e-3
    for col, k in (("Ixx", 2.6), ("Iyy", 3.1), ("Izz", 3.9)):
        assert np.allclose(d[col], d["mass_true"] * k ** 2, rtol=1e-8), col
    assert (d["Ixz"] == 0).all()
    assert d["mass"].iloc[0] < 14000 * LB                       # fuel burnt before 1040 s


def test_missing_sensors_are_reported_not_invented(imported):
    df = imported.data
    for col in ("beta", "psi", "vn_gps"):
        assert col not in df.columns
    assert "psi" in imported.empty                              # the empty heading file
    assert {"beta", "psi", "vn_gps"} <= set(imported.missing)
    assert set(imported.derived) >= {"tas", "mach", "rho", "mass", "Ixx, Iyy, Izz, Ixz",
                                  "x_gps, y_gps"}
    text = imported.summary()
    assert "missing sensors: beta, psi" in text and "channels without data: psi" in text


def test_a_sensor_at_one_value_through_the_record_is_a_channel_without_data(tmp_path):
    """A heading recorded as zeros is a dead channel, not a flight due north."""
    from simplexspline.errors import FlightDataError

    d = tmp_path / "rec"
    shutil.copytree(DATA, d)
    rows = (d / "yaw_rate.txt").read_text().splitlines()
    (d / "heading.txt").write_text("\n".join([rows[0]] + [f"{ln.split()[0]} 0.0"
                                                            for ln in rows[1:]]) + "\n")
    mapping = tmp_path / "mapping.toml"
    mapping.write_text(MAPPING.read_text().replace('path = "."', f'path = "{d}"')
                       .replace('list = "maneuvers.csv"', f'list = "{d / "maneuvers.csv"}"'))
    result = import_record(mapping)
    assert "psi" not in result.data.columns and "psi" in result.empty
    assert result.constant == {"psi": 0.0}
    assert "dead or unconnected sensor (treated as without data): psi = 0" in result.summary()
    # a required channel at one value stops the import and says so
    (d / "delta_e.txt").write_text("\n".join(["1.5"] * 1314) + "\n")
    with pytest.raises(FlightDataError, match=r"required channel\(s\) \['de'\] are mapped but "
                                              r"hold no data .*at one value through the whole "
                                              r"record: de = 0.0261799"):
        import_record(mapping)


def test_maneuvers_from_the_list_keep_their_types_and_drop_the_ground(imported, truth):
    df = imported.data
    listed = pd.read_csv(DATA / "maneuvers.csv")
    assert df["maneuver"].unique().tolist() == [0, 1, 2]
    for m, row in listed.iterrows():
        g = df[df["maneuver"] == m]
        assert g["maneuver_type"].iloc[0] == row["type"]
        assert g["t"].iloc[0] == 0.0 and np.allclose(np.diff(g["t"]), 0.1)
        assert g["t_record"].iloc[0] == pytest.approx(row["start"])
        assert g["t_record"].iloc[-1] == pytest.approx(row["end"])
    on_ground = truth.loc[truth["wow"] > 0.5, "t_record"]
    assert not df["t_record"].isin(on_ground).any()
    assert imported.ground_rule == "weight-on-wheels channel"


def test_the_gps_latitude_goes_into_the_metadata(imported):
    """For the reconstruction's Earth model (gravity, Earth rate)."""
    lat = np.loadtxt(DATA / "gps_lat.txt", skiprows=1)[:, 1].mean()     # deg
    assert imported.metadata["latitude_deg"] == pytest.approx(lat, abs=0.01)
    assert "latitude_deg" in imported.derived


def test_gps_positions_from_latitude_and_longitude(imported, truth):
    d = _joined(imported, truth)
    for m, g in d.groupby("maneuver"):
        n_true = np.cumsum(np.r_[0, 0.5 * (g["vn_gps"].to_numpy()[1:]
                                          + g["vn_gps"].to_numpy()[:-1])]) * 0.1
        assert np.max(np.abs(g["x_gps"] - n_true)) < 0.5      # integrated velocity [m]
        assert g["x_gps"].iloc[0] == 0.0 and g["y_gps"].iloc[0] == 0.0


def test_excitation_detection_finds_the_listed_maneuvers(tmp_path):
    text = MAPPING.read_text().replace('method = "list"', 'method = "excitation"')
    mapping = tmp_path / "mapping.toml"
    mapping.write_text(text.replace('path = "."', f'path = "{DATA}"')
                       .replace('list = "maneuvers.csv"', ""))
    result = import_record(mapping)
    listed = pd.read_csv(DATA / "maneuvers.csv")
    segs = result.segments()
    assert len(segs) == len(listed)
    for s, (_, row) in zip(segs, listed.iterrows()):
        overlap = min(s["start_s"] + s["duration_s"], row["end"]) - max(s["start_s"],
                                                                      row["start"])
        assert overlap > 0.7 * (row["end"] - row["start"])
        assert s["type"] == "excitation-" + {"3211-elevator": "elevator",
                                             "3211-aileron": "aileron",
                                             "doublet-elevator": "elevator"}[row["type"]]


def test_sanity_checks_pass_on_the_clean_record(imported):
    assert not imported.sanity.failed()
    names = [c.name for c in imported.sanity.checks if c.status == "ok"]
    assert {"rate sign p", "rate sign q", "specific force", "alpha vs theta - gamma"} <= set(
        names)


@pytest.mark.parametrize("channel,source,check", [
    ("q", "pitch_rate", "d(theta)/dt"), ("p", "roll_rate", "d(phi)/dt")])
def test_a_sign_flipped_rate_is_named(tmp_path, channel, source, check):
    text = MAPPING.read_text().replace(
        f'{channel} = {{ source = "{source}", unit = "deg/s" }}',
        f'{channel} = {{ source = "{source}", unit = "deg/s", sign = -1 }}')
    mapping = tmp_path / "mapping.toml"
    mapping.write_text(text.replace('path = "."', f'path = "{DATA}"')
                       .replace('list = "maneuvers.csv"', f'list = "{DATA / "maneuvers.csv"}"'))
    failed = import_record(mapping).sanity.failed()
    assert [c.channel for c in failed] == [channel]
    assert re.fullmatch(rf"channel '{channel}' looks sign-inverted: correlation -(0\.9\d|1\.00) "
                        rf"with {re.escape(check)}", failed[0].message)


def test_a_load_factor_taken_as_specific_force_is_named(tmp_path):
    text = MAPPING.read_text().replace('unit = "g0", sign = -1', 'unit = "g0"')
    mapping = tmp_path / "mapping.toml"
    mapping.write_text(text.replace('path = "."', f'path = "{DATA}"')
                       .replace('list = "maneuvers.csv"', f'list = "{DATA / "maneuvers.csv"}"'))
    failed = import_record(mapping).sanity.failed()
    assert [c.channel for c in failed] == ["az"]
    assert "channel 'az' looks sign-inverted" in failed[0].message


def test_an_inverted_alpha_vane_is_named(tmp_path):
    text = MAPPING.read_text().replace('unit = "deg" }\nias', 'unit = "deg", sign = -1 }\nias')
    assert 'sign = -1 }\nias' in text
    mapping = tmp_path / "mapping.toml"
    mapping.write_text(text.replace('path = "."', f'path = "{DATA}"')
                       .replace('list = "maneuvers.csv"', f'list = "{DATA / "maneuvers.csv"}"'))
    failed = import_record(mapping).sanity.failed()
    assert [c.channel for c in failed] == ["alpha"]


def test_installed_cli_imports_and_prints_the_report(tmp_path):
    exe = Path(sys.executable).with_name("simplexspline")
    out = tmp_path / "flight.parquet"
    res = subprocess.run([str(exe), "import", str(MAPPING), "-o", str(out)],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert "sanity checks:" in res.stdout and "[ok  ] rate sign q" in res.stdout
    assert "missing sensors: beta, psi" in res.stdout
    assert "3211-aileron" in res.stdout and "464 samples in 3 maneuver(s)" in res.stdout
    df, meta = read_flight_data(out)
    assert len(df) == 464 and meta["aircraft"] == "citation-like test record"
    assert meta["S"] == pytest.approx(322.9 * 0.3048 ** 2)
    assert meta["import"]["missing"][:2] == ["beta", "psi"]
    assert str(df["maneuver_type"].iloc[0]) == "3211-elevator"


def test_cli_refuses_to_write_when_a_sign_check_fails(tmp_path, capsys):
    text = MAPPING.read_text().replace('unit = "deg/s" }\nr', 'unit = "deg/s", sign = -1 }\nr')
    assert 'sign = -1 }\nr' in text
    mapping = tmp_path / "mapping.toml"
    mapping.write_text(text.replace('path = "."', f'path = "{DATA}"')
                       .replace('list = "maneuvers.csv"', f'list = "{DATA / "maneuvers.csv"}"'))
    out = tmp_path / "flight.parquet"
    assert main(["import", str(mapping), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr()
    assert "channel 'q' looks sign-inverted" in err.out
    assert "nothing written" in err.err and not out.exists()
    assert main(["import", str(mapping), "-o", str(out), "-q", "--force"]) == 0
    assert out.exists()


@pytest.mark.parametrize("fmt", ["csv", "parquet", "mat", "mat73"])
def test_table_formats_give_the_same_import(tmp_path, fmt, imported):
    """The same channels as one table (CSV, Parquet, MATLAB v5 and v7.3/HDF5)."""
    cols = {}
    for f in DATA.glob("*.txt"):
        if f.stem in ("heading", "delta_e"):
            continue
        a = np.loadtxt(f, skiprows=1)
        cols["time"] = a[:, 0]
        cols[f.stem] = a[:, 1]
    cols["delta_e"] = np.loadtxt(DATA / "delta_e.txt")
    cols["heading"] = np.full(cols["time"].size, np.nan)
    table = pd.DataFrame(cols)
    if fmt == "csv":
        path = tmp_path / "record.csv"
        table.to_csv(path, index=False)
    elif fmt == "parquet":
        path = tmp_path / "record.parquet"
        table.to_parquet(path)
    elif fmt == "mat":
        import scipy.io

        path = tmp_path / "record.mat"
        scipy.io.savemat(path, {k: v for k, v in cols.items()})
    else:
        h5py = pytest.importorskip("h5py")
        path = tmp_path / "record.mat"
        with h5py.File(path, "w", userblock_size=512) as fh:
            for k, v in cols.items():
                fh.create_dataset(k, data=v[None, :])  # MATLAB stores row vectors
        with open(path, "r+b") as fh:  # the header MATLAB writes into the user block
            fh.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Wed Nov 25 "
                     b"09:00:00 2026 HDF5 schema 1.00 .")
    text = MAPPING.read_text().replace('format = "channels"', f'format = "{fmt[:3]}"'
                                       if fmt.startswith("mat") else f'format = "{fmt}"')
    text = text.replace('path = "."', f'path = "{path}"').replace(
        'pattern = "{source}.txt"', 'time = "time"')
    text = text.replace('list = "maneuvers.csv"', f'list = "{DATA / "maneuvers.csv"}"')
    mapping = tmp_path / "mapping.toml"
    mapping.write_text(text)
    result = import_record(mapping)
    pd.testing.assert_frame_equal(result.data, imported.data, check_exact=False, rtol=1e-9)
    assert "psi" in result.empty


def _record_with(tmp_path, truth, extra: dict, mapping_lines: str, old=None, new=None):
    """A copy of the record with extra channel files (SI values from the truth) mapped."""
    rec = tmp_path / "rec"
    shutil.copytree(DATA, rec)
    t = truth["t_record"].to_numpy()
    for name, values in extra.items():
        np.savetxt(rec / f"{name}.txt", np.column_stack([t, values]), fmt=["%.2f", "%.10g"])
    text = (rec / "mapping.toml").read_text()
    if old is not None:
        assert old in text
        text = text.replace(old, new)
    text = text.replace("\n[segments]", mapping_lines + "\n\n[segments]")
    (rec / "mapping.toml").write_text(text)
    return rec / "mapping.toml"


def test_specific_force_is_checked_against_gps_accelerations(tmp_path, truth):
    """With GPS velocities and heading mapped, per maneuver (the test record's transitions
    between maneuvers are blends, not flight, so the whole-record check is not used)."""
    gps = {"gps_vn": truth["vn_gps"], "gps_ve": truth["ve_gps"], "gps_vd": truth["vd_gps"],
           "true_heading": np.degrees(truth["psi"])}
    lines = ('vn_gps = { source = "gps_vn", unit = "m/s" }\n'
             've_gps = { source = "gps_ve", unit = "m/s" }\n'
             'vd_gps = { source = "gps_vd", unit = "m/s" }')
    heading = ('psi = { source = "heading", unit = "deg" }',
               'psi = { source = "true_heading", unit = "deg" }')
    named = {}
    for flip, expect in ((None, []), ("ax_g", ["ax"]), ("ay_g", ["ay"])):
        path = _record_with(tmp_path / str(flip), truth, gps, lines, *heading)
        if flip is not None:
            text = path.read_text()
            old = f'source = "{flip}", unit = "g0" }}'
            assert old in text
            path.write_text(text.replace(old, f'source = "{flip}", unit = "g0", sign = -1 }}'))
        data = import_record(path).data
        assert {"vn_gps", "psi"} <= set(data.columns)
        for m, g in data.groupby("maneuver"):
            report = check_record(g, 0.1)
            (check,) = [c for c in report.checks if c.name == "specific force"]
            assert "the GPS accelerations" in check.message
            assert "north-east-down" in check.message
            if flip is None:
                assert check.status == "ok" and check.value < 0.5, check.message
                assert not report.failed()
            elif flip == "ax_g":      # ax carries about g sin(theta) + thrust: always seen
                assert [c.channel for c in report.failed()] == expect, check.message
            else:                     # ay is seen only where the aircraft banks or slips
                assert [c.channel for c in report.failed()] in ([], expect), check.message
                named[m] = bool(report.failed())
    assert named[1] and sum(named.values()) >= 1   # the aileron 3211


def test_without_weight_on_wheels_the_ground_is_found_by_airspeed_and_altitude(tmp_path,
                                                                              truth):
    path = _record_with(tmp_path, truth, {}, "", 'wow = { source = "wow", unit = '
                        '"dimensionless" }\n', "")
    result = import_record(path)
    assert result.ground_rule.startswith("airspeed >= 25 m/s and altitude >= 15 m")
    on_ground = truth.loc[truth["wow"] > 0.5, "t_record"]
    assert not result.data["t_record"].isin(on_ground).any()
    assert len(result.segments()) == 3


def test_maneuver_list_in_toml(tmp_path):
    listed = pd.read_csv(DATA / "maneuvers.csv")
    toml = "".join(f'[[maneuver]]\nstart = {r.start}\nend = {r.end}\ntype = "{r.type}"\n\n'
                   for r in listed.itertuples())
    (tmp_path / "list.toml").write_text(toml)
    text = MAPPING.read_text().replace('path = "."', f'path = "{DATA}"').replace(
        'list = "maneuvers.csv"', f'list = "{tmp_path / "list.toml"}"')
    (tmp_path / "mapping.toml").write_text(text)
    result = import_record(tmp_path / "mapping.toml")
    assert [s["type"] for s in result.segments()] == listed["type"].tolist()


def test_sign_checks_hold_with_sensor_noise(tmp_path):
    """Noise of flight-test sensors (rates 0.1 deg/s, attitudes 0.05 deg, accelerometers
    0.01 g, 10 Hz) neither hides a flipped rate nor fails a correct one."""
    rng = np.random.default_rng(7)
    rec = tmp_path / "rec"
    shutil.copytree(DATA, rec)
    for name, sigma in (("roll_rate", 0.1), ("pitch_rate", 0.1), ("yaw_rate", 0.1),
                        ("roll_angle", 0.05), ("pitch_angle", 0.05), ("ax_g", 0.01),
                        ("ay_g", 0.01), ("an_g", 0.01), ("vane_aoa", 0.1)):
        a = np.loadtxt(rec / f"{name}.txt", skiprows=1)
        a[:, 1] += rng.normal(0.0, sigma, len(a))
        np.savetxt(rec / f"{name}.txt", a, fmt=["%.2f", "%.8g"])
    assert not import_record(rec / "mapping.toml").sanity.failed()
    text = (rec / "mapping.toml").read_text()
    (rec / "mapping.toml").write_text(text.replace(
        'q = { source = "pitch_rate", unit = "deg/s" }',
        'q = { source = "pitch_rate", unit = "deg/s", sign = -1 }'))
    assert [c.channel for c in import_record(rec / "mapping.toml").sanity.failed()] == ["q"]


def _csv_mapping(tmp_path, time_lines):
    """The test mapping pointed at ``tmp_path/record.csv`` with the given [record] time
    keys instead of the channel-file pattern."""
    text = MAPPING.read_text().replace('format = "channels"', 'format = "csv"').replace(
        'path = "."', f'path = "{tmp_path / "record.csv"}"').replace(
        'pattern = "{source}.txt"', time_lines).replace(
        'list = "maneuvers.csv"', f'list = "{DATA / "maneuvers.csv"}"')
    (tmp_path / "mapping.toml").write_text(text)
    return tmp_path / "mapping.toml"


def test_time_stamps_in_milliseconds(tmp_path, imported):
    cols = {}
    for f in DATA.glob("*.txt"):
        if f.stem not in ("heading", "delta_e"):
            a = np.loadtxt(f, skiprows=1)
            cols["time_ms"], cols[f.stem] = a[:, 0] * 1000.0, a[:, 1]
    cols["delta_e"] = np.loadtxt(DATA / "delta_e.txt")
    cols["heading"] = np.full(cols["time_ms"].size, np.nan)
    pd.DataFrame(cols).to_csv(tmp_path / "record.csv", index=False)
    result = import_record(_csv_mapping(tmp_path, 'time = "time_ms"\ntime_unit = "ms"'))
    pd.testing.assert_frame_equal(result.data, imported.data, check_exact=False, rtol=1e-9)


def test_yaw_rate_sign_from_turns_without_heading_or_gps():
    """Coordinated turns left and right (bank up to 30 deg): r is checked against
    g sin(phi) cos(theta) / V, and a flipped r is named."""
    t = np.arange(0, 120, 0.1)
    phi = np.radians(30) * np.sin(2 * np.pi * t / 60)
    theta = np.full(t.size, np.radians(3))
    tas = np.full(t.size, 120.0)
    psid = 9.80665 * np.tan(phi) / tas
    data = {"phi": phi, "theta": theta, "tas": tas, "p": np.gradient(phi, 0.1),
            "q": psid * np.sin(phi) * np.cos(theta), "r": psid * np.cos(phi) * np.cos(theta),
            "h": np.full(t.size, 3000.0), "alpha": theta}
    (ok,) = [c for c in check_record(data, 0.1).checks if c.name == "rate sign r"]
    assert ok.status == "ok" and "in turns" in ok.message
    data["r"] = -data["r"]
    report = check_record(data, 0.1)
    assert [c.channel for c in report.failed()] == ["r"]
    assert "channel 'r' looks sign-inverted: correlation -1.00 with g sin(phi)" in \
        report.failed()[0].message


def _channel_files_as(tmp_path, write, shift=0.0):
    """The test record's channel files rewritten by ``write(name, t, v) -> text``, and its
    mapping pointing at them (and at its maneuver list, times shifted by ``shift`` [s])."""
    for f in DATA.glob("*.txt"):
        a = np.loadtxt(f, skiprows=1, ndmin=2) if f.stat().st_size and f.stem != "delta_e" \
            else None
        if a is None or a.shape[1] != 2:
            shutil.copy(f, tmp_path / f.name)
            continue
        (tmp_path / f.name).write_text(write(f.stem, a[:, 0], a[:, 1]))
    maneuvers = pd.read_csv(DATA / "maneuvers.csv")
    maneuvers[["start", "end"]] += shift
    maneuvers.to_csv(tmp_path / "maneuvers.csv", index=False)
    text = MAPPING.read_text().replace('path = "."', f'path = "{tmp_path}"').replace(
        'list = "maneuvers.csv"', f'list = "{tmp_path / "maneuvers.csv"}"')
    (tmp_path / "mapping.toml").write_text(text)
    return tmp_path / "mapping.toml"


def test_header_lines_missing_words_and_blank_fields(tmp_path, imported):
    """Real channel files: a name line, a unit line and a description before the numbers;
    gaps written as NA, '-', or blank fields between commas. The samples given are read as
    before; the blanks are missing samples, reported as dropped NaN."""
    def write(name, t, v):
        rows = [f"{ti:.2f},{float(vi)!r}" for ti, vi in zip(t, v)]
        rows[5], rows[6], rows[7] = f"{t[5]:.2f},NA", f"{t[6]:.2f},-", f"{t[7]:.2f},,"
        return f"{name}\nunit: see mapping\nrecorded by the FTI\n" + "\n".join(rows) + "\n"

    result = import_record(_channel_files_as(tmp_path, write))
    assert len(result.data) == len(imported.data)
    for c in ("alpha", "q", "theta"):
        assert np.allclose(result.data[c], imported.data[c], atol=1e-6), c


@pytest.mark.parametrize("start", [1000.0, 86400.0 - 30.0])
def test_clock_time_stamps_become_seconds_and_cross_midnight(tmp_path, imported, start):
    """Time stamps as hh:mm:ss.ss, also through midnight: the same import as seconds."""
    def write(name, t, v):
        tt = (t - t[0] + start) % 86400.0
        clock = [f"{int(x // 3600):02d}:{int(x % 3600 // 60):02d}:{x % 60:05.2f}" for x in tt]
        return "time value\n" + "\n".join(f"{c} {float(vi)!r}" for c, vi in zip(clock, v)) + "\n"

    result = import_record(_channel_files_as(tmp_path, write, shift=start - 1000.0))
    assert len(result.data) == len(imported.data)
    assert np.allclose(np.diff(result.data["t_record"]), np.diff(imported.data["t_record"]))
    for c in ("alpha", "tas", "h"):
        assert np.allclose(result.data[c], imported.data[c], atol=1e-6), c


def test_a_channel_file_without_numbers_is_named(tmp_path):
    from simplexspline.errors import FlightDataError

    def write(name, t, v):
        return "time value\n" + "\n".join(f"t{ti} v{vi}" for ti, vi in zip(t, v)) + "\n"

    with pytest.raises(FlightDataError, match=r"no line of numbers in \d+ line\(s\)"):
        import_record(_channel_files_as(tmp_path, write))


def test_csv_with_semicolons_a_unit_row_gaps_and_clock_times(tmp_path, imported):
    """A spreadsheet export: semicolons, a unit row under the header, '-' for a missing
    sample, the time as hh:mm:ss.ss: the same import as the channel files."""
    cols = {}
    for f in DATA.glob("*.txt"):
        if f.stem not in ("heading", "delta_e"):
            a = np.loadtxt(f, skiprows=1)
            cols["time"], cols[f.stem] = a[:, 0], a[:, 1].astype(object)
    cols["delta_e"] = np.loadtxt(DATA / "delta_e.txt").astype(object)
    cols["heading"] = np.full(cols["time"].size, "", dtype=object)
    t = cols.pop("time")
    cols["time"] = [f"{int(x // 3600):02d}:{int(x % 3600 // 60):02d}:{x % 60:05.2f}" for x in t]
    first = next(k for k in cols if k not in ("time", "heading"))
    cols[first] = cols[first].copy()
    cols[first][7] = "-"
    table = pd.DataFrame(cols)
    units = pd.DataFrame([{k: "[unit]" for k in table.columns}])
    pd.concat([units, table]).to_csv(tmp_path / "record.csv", sep=";", index=False)
    result = import_record(_csv_mapping(tmp_path, 'time = "time"'))
    pd.testing.assert_frame_equal(result.data, imported.data, check_exact=False, rtol=1e-6,
                                  atol=1e-9)


def test_a_csv_column_with_words_is_named(tmp_path):
    from simplexspline.aero.data.records import read_channels
    from simplexspline.errors import FlightDataError

    (tmp_path / "r.csv").write_text("time,alpha\n0,1.0\n0.1,stuck\n0.2,1.2\n")
    with pytest.raises(FlightDataError, match=r"column 'alpha' is not numeric \(row 1: "
                                              r"'stuck'\)"):
        read_channels("csv", tmp_path / "r.csv", {"alpha": (None, "alpha", None)},
                      time="time")


def test_fuel_used_summed_over_engines(tmp_path, imported):
    """A twin-engine record logs fuel used per engine, at their own time stamps: the
    mapping lists both sources and the import sums them on the common time base."""
    for f in DATA.iterdir():
        if f.is_file():
            shutil.copy(f, tmp_path / f.name)
    a = np.loadtxt(DATA / "fuel_used.txt", skiprows=1)
    share = 0.45
    np.savetxt(tmp_path / "fu_left.txt", np.c_[a[:, 0], share * a[:, 1]], header="time fu",
               comments="")
    right = np.c_[a[:, 0] + 0.05, (1 - share) * np.interp(a[:, 0] + 0.05, a[:, 0], a[:, 1])]
    np.savetxt(tmp_path / "fu_right.txt", right, header="time fu", comments="")
    (tmp_path / "fuel_used.txt").unlink()
    text = (tmp_path / "mapping.toml").read_text()
    old = next(ln for ln in text.splitlines() if ln.startswith("fuel_used"))
    (tmp_path / "mapping.toml").write_text(text.replace(
        old, 'fuel_used = { source = ["fu_left", "fu_right"], unit = "lb" }'))
    result = import_record(tmp_path / "mapping.toml")
    assert np.allclose(result.data["mass"], imported.data["mass"], rtol=0, atol=0.05)
    assert not np.allclose(result.data["mass"], result.data["mass"].iloc[0])


def test_the_engines_fuel_flow_per_engine_is_summed(imported):
    """The record logs fuel flow per engine in lbs/hr (48 % and 52 % of 0.35 lb/s); the
    mapping lists both channels and the import sums them into kg/s."""
    np.testing.assert_allclose(imported.data["fuel_flow"], 0.35 * LB, rtol=1e-7)


def test_engine_channels_fuel_flow_summed_and_fan_speed_averaged(tmp_path, imported):
    """A twin-jet record logs fuel flow (lbs/hr) and N1 (%) per engine: the fuel flows
    are summed into ``fuel_flow`` [kg/s], the fan speeds averaged into ``n1`` [-]."""
    for f in DATA.iterdir():
        if f.is_file():
            shutil.copy(f, tmp_path / f.name)
    t = np.loadtxt(DATA / "vane_aoa.txt", skiprows=1)[:, 0]
    left, right = 1400.0 + 50.0 * np.sin(t / 30.0), 1500.0 + 0 * t     # lbs/hr
    n1l, n1r = 80.0 + 5.0 * np.sin(t / 30.0), 84.0 + 0 * t             # %
    for name, v in (("lh_engine_FMF", left), ("rh_engine_FMF", right),
                    ("lh_engine_fan_N1", n1l), ("rh_engine_fan_N1", n1r)):
        np.savetxt(tmp_path / f"{name}.txt", np.c_[t, v], header=f"time {name}", comments="")
    text = (tmp_path / "mapping.toml").read_text()
    text = "\n".join(ln for ln in text.splitlines() if not ln.startswith("fuel_flow"))
    (tmp_path / "mapping.toml").write_text(
        text + '\n[channels.fuel_flow]\nsource = ["lh_engine_FMF", "rh_engine_FMF"]\n'
        'unit = "lb/hour"\n'
        '\n[channels.n1]\nsource = ["lh_engine_fan_N1", "rh_engine_fan_N1"]\n'
        'unit = "percent"\n')
    d = import_record(tmp_path / "mapping.toml").data
    tt = d["t_record"].to_numpy()
    expect_ff = (np.interp(tt, t, left) + 1500.0) * LB / 3600.0
    np.testing.assert_allclose(d["fuel_flow"], expect_ff, rtol=1e-9)
    np.testing.assert_allclose(d["n1"], (np.interp(tt, t, n1l) + 84.0) / 200.0, rtol=1e-9)


@pytest.mark.parametrize("entry, message", [
    ('alpha = { source = ["a1", "a2"], unit = "deg" }', "'alpha' cannot be a sum"),
    ('fuel_used = { source = [], unit = "lb" }', "list of distinct channel names"),
    ('fuel_used = { source = ["f", "f"], unit = "lb" }', "list of distinct channel names"),
])
def test_a_sum_of_sources_is_refused_where_it_makes_no_sense(tmp_path, entry, message):
    from simplexspline.aero.data.mapping import MappingError, read_mapping

    text = MAPPING.read_text()
    key = entry.split(" ")[0]
    old = next(ln for ln in text.splitlines() if ln.startswith(key + " "))
    (tmp_path / "mapping.toml").write_text(text.replace(old, entry))
    with pytest.raises(MappingError, match=message):
        read_mapping(tmp_path / "mapping.toml")


def test_a_structure_may_use_the_sideslip_the_reconstruction_estimates(imported):
    """The record has no sideslip vane: identify reconstructs beta from the lateral
    kinematics, so a structure the user gives with beta in it is accepted before the
    reconstruction (it was refused: "unknown variable(s) ['beta']") and fitted on it; a
    variable nothing makes is still refused by name."""
    assert "beta" not in imported.data.columns
    s = parse_structure("Cn(alpha | 1, beta, rhat, dr) S^0_1")
    result = identify(imported.data, settings=IdentificationSettings(
        coefficients=("Cn",), structures={"Cn": s}, select=False))
    assert "beta" in result.results["Cn"].model.variables
    assert np.isfinite(result.identification["beta"]).all()
    with pytest.raises(InputError, match=r"unknown variable\(s\) \['gamma'\]"):
        identify(imported.data, settings=IdentificationSettings(
            coefficients=("Cn",), select=False,
            structures={"Cn": parse_structure("Cn(alpha | 1, gamma) S^0_1")}))
