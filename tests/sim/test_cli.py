"""The `simplexspline simulate` command."""

from __future__ import annotations

import pytest

from simplexspline.aero.data.flight_data import read_flight_data
from simplexspline.cli import main


def test_simulate_writes_a_valid_parquet_file(tmp_path, capsys):
    out = tmp_path / "c.parquet"
    code = main(["simulate", "--aircraft", "f16", "--maneuvers", "2", "--seed", "1",
                 "--altitudes", "3000", "--airspeeds", "170", "--mix", "doublet=1",
                 "--workers", "1", "--ideal-sensors", "-o", str(out)])
    assert code == 0
    df, meta = read_flight_data(out)
    assert meta["aircraft"] == "f16" and meta["simulator"]["seed"] == 1
    assert sorted(df["maneuver"].unique()) == [0, 1]
    assert (df["alpha"] == df["true_alpha"]).all()
    text = capsys.readouterr().out
    assert "2 of 2 maneuvers kept" in text and str(out) in text


def test_simulate_quiet_csv(tmp_path, capsys):
    out = tmp_path / "c.csv"
    assert main(["simulate", "--maneuvers", "1", "--altitudes", "3000", "--airspeeds",
                 "170", "--mix", "doublet=1", "--workers", "1", "-q", "-o", str(out)]) == 0
    assert capsys.readouterr().out == ""
    df, meta = read_flight_data(out)
    assert len(df) > 500 and meta["sample_rate_hz"] == 100.0


def test_simulate_alternative_protocol_between_the_grid(tmp_path):
    out = tmp_path / "c.parquet"
    assert main(["simulate", "--aircraft", "c172p", "--maneuvers", "1", "--seed", "4",
                 "--protocol", "alternative", "--conditions", "between", "--mix", "3211=1",
                 "--workers", "1", "-q", "-o", str(out)]) == 0
    df, meta = read_flight_data(out)
    campaign = meta["simulator"]["campaign"]
    assert campaign["design"] == "alternative" and campaign["pilot_style"]["delay_s"] == 0.35
    assert campaign["airspeeds_mps"] == [41.0, 47.0, 53.0, 59.0]
    assert df["maneuver_type"].astype(str).str.startswith("3211").all()


def test_simulate_the_eigenmotion_protocol(tmp_path, capsys):
    """A flight-test course's maneuvers: an elevator pulse with a phugoid's free response
    (at least one period at the Cessna's median airspeed) and an aileron pulse."""
    out = tmp_path / "c.parquet"
    assert main(["simulate", "--aircraft", "c172p", "--maneuvers", "2", "--seed", "2",
                 "--protocol", "eigenmotion", "--mix", "pulse=1", "--altitudes", "1000",
                 "--airspeeds", "50", "--workers", "1", "-q", "-o", str(out)]) == 0
    df, meta = read_flight_data(out)
    assert meta["simulator"]["campaign"]["design"] == "eigenmotion"
    kinds = df.groupby("maneuver")["maneuver_type"].first().astype(str)
    assert sorted(kinds) == ["pulse-aileron", "pulse-elevator"]
    phugoid = df[df["maneuver"] == kinds.index[kinds == "pulse-elevator"][0]]
    assert phugoid["t"].iloc[-1] - phugoid["t"].iloc[0] > 20.0
    capsys.readouterr()
    assert main(["simulate", "--protocol", "eigenmotion", "--mix", "3211=1", "--maneuvers",
                 "1", "-q", "-o", str(tmp_path / "x.parquet")]) == 2
    assert "pulses and doublets only" in capsys.readouterr().err
    assert not (tmp_path / "x.parquet").exists()


def test_simulate_channels_format_writes_a_record_directory(tmp_path, capsys):
    out = tmp_path / "record"
    assert main(["simulate", "--aircraft", "c172p", "--maneuvers", "1", "--mix", "doublet=1",
                 "--altitudes", "1000", "--airspeeds", "45", "--workers", "1",
                 "--format", "channels", "--real-like", "-o", str(out)]) == 0
    assert (out / "mapping.toml").is_file() and (out / "ias.txt").is_file()
    header = (out / "truth.csv").read_text().splitlines()[0].split(",")
    assert {"wind_n", "wind_e", "wind_d"} <= set(header)  # --real-like flies in wind
    assert (out / "heading.txt").read_text() == "" and not (out / "beta.txt").exists()
    assert "1 of 1 maneuvers kept" in capsys.readouterr().out


@pytest.mark.parametrize("argv, message", [
    (["--aircraft", "spitfire"], "unknown aircraft 'spitfire'"),
    (["--maneuvers", "0"], "argument --maneuvers: expected an integer >= 1, got '0'"),
    (["--noise-scale", "-1"], "argument --noise-scale: expected a number >= 0, got '-1'"),
    (["--wind", "1,2,3"], "--wind takes LOW,HIGH [m/s]"),
    (["--wind", "10,5"], "Wind.speed_mps must be (low, high)"),
    (["--ideal-sensors", "--real-like"], "contradict each other"),
])
def test_simulate_errors_are_one_line_messages(tmp_path, capsys, argv, message):
    code = main(["simulate", *argv, "-o", str(tmp_path / "c.parquet"), "--workers", "1"])
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_simulate_rejects_unknown_output_type(tmp_path, capsys):
    assert main(["simulate", "-o", str(tmp_path / "c.xlsx")]) == 2
    assert "must end in .parquet or .csv" in capsys.readouterr().err


def test_simulate_bad_mix_is_a_usage_error(tmp_path, capsys):
    assert main(["simulate", "--mix", "3211", "-o", str(tmp_path / "c.parquet")]) == 2
    err = capsys.readouterr().err
    assert "FAMILY=WEIGHT" in err and len(err.strip().splitlines()) == 1
