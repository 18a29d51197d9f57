"""`simplexspline reconstruct`: reads a campaign, writes the reconstruction, prints a summary."""

from __future__ import annotations

import hashlib
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from simplexspline.aero.data.flight_data import read_flight_data, write_flight_data
from simplexspline.cli import main


@pytest.fixture(scope="module")
def campaign_file(noisy_campaign, tmp_path_factory):
    """Three short maneuvers of the noisy campaign, one of them cut too short."""
    df = noisy_campaign[noisy_campaign["maneuver"].isin([1, 3, 4])].copy()
    df.attrs = dict(noisy_campaign.attrs)
    df = df[~((df["maneuver"] == 4) & (df["t"] > 1.0))]
    path = tmp_path_factory.mktemp("cli") / "campaign.parquet"
    write_flight_data(df, path)
    return path


def _digest(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_reconstruct_writes_output_and_summary(campaign_file, tmp_path, capsys):
    before = _digest(campaign_file)
    out = tmp_path / "reconstructed.parquet"
    code = main(["reconstruct", str(campaign_file), "-o", str(out), "--workers", "1"])
    text = capsys.readouterr().out
    assert code == 0
    assert _digest(campaign_file) == before                  # input never modified
    assert "estimated biases" in text and "innovations" in text
    assert "rejected maneuver 4: too short" in text
    assert "thrust subtracted" in text and "x real time" in text
    df, meta = read_flight_data(out)
    assert sorted(df["maneuver"].unique()) == [1, 3]
    for c in ("CX", "CY", "CZ", "Cl", "Cm", "Cn", "phat", "qhat", "rhat"):
        assert np.isfinite(df[c]).all()
    assert set(meta["reconstruction"]["maneuvers"]) == {"1", "3"}
    assert "too short" in meta["reconstruction"]["rejected"]["4"]
    assert "control de: smoothed in" in text
    source, _ = read_flight_data(campaign_file)
    raw = source.set_index(["maneuver", "t"]).loc[list(zip(df["maneuver"], df["t"])), "de"]
    assert not np.allclose(df["de"].to_numpy(), raw.to_numpy())          # smoothed


def test_reconstruct_can_keep_the_controls_as_measured(campaign_file, tmp_path, capsys):
    out = tmp_path / "raw_controls.parquet"
    assert main(["reconstruct", str(campaign_file), "-o", str(out), "--workers", "1",
                 "--no-control-smoothing"]) == 0
    assert "control de" not in capsys.readouterr().out
    df, meta = read_flight_data(out)
    source, _ = read_flight_data(campaign_file)
    raw = source.set_index(["maneuver", "t"]).loc[list(zip(df["maneuver"], df["t"])), "de"]
    np.testing.assert_array_equal(df["de"].to_numpy(), raw.to_numpy())
    assert meta["reconstruction"]["settings"]["smooth_controls"] is False


def test_reconstruct_csv_output(campaign_file, tmp_path, capsys):
    out = tmp_path / "reconstructed.csv"
    assert main(["reconstruct", str(campaign_file), "-o", str(out), "--workers", "1", "-q",
                 "--accelerations", "differentiate", "--gusts", "0"]) == 0
    assert capsys.readouterr().out == ""
    df, meta = read_flight_data(out)
    assert meta["reconstruction"]["accelerations"] == "differentiated"
    assert meta["reconstruction"]["settings"]["gust_std"] == 0
    assert main(["reconstruct", str(campaign_file), "-o", str(out), "--gusts", "strong"]) == 2
    assert "--gusts: expected a number" in capsys.readouterr().err


@pytest.mark.parametrize("output, message", [
    ("same", "must not overwrite the input"),
    ("out.txt", "must end in .parquet or .csv"),
    ("missing/out.parquet", "does not exist"),
])
def test_reconstruct_bad_output(campaign_file, tmp_path, capsys, output, message):
    target = campaign_file if output == "same" else tmp_path / output
    assert main(["reconstruct", str(campaign_file), "-o", str(target)]) == 2
    assert message in capsys.readouterr().err


def test_reconstruct_missing_file(tmp_path, capsys):
    assert main(["reconstruct", str(tmp_path / "nope.parquet"), "-o",
                 str(tmp_path / "o.parquet")]) == 2
    assert "error" in capsys.readouterr().err


def test_installed_command_help():
    exe = Path(sys.executable).with_name("simplexspline")
    res = subprocess.run([str(exe), "reconstruct", "--help"], capture_output=True, text=True,
                         check=False)
    assert res.returncode == 0
    assert "--accelerations" in res.stdout
