"""`simplexspline identify`: the installed command end to end on a small JSBSim campaign."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from simplexspline.aero.data.flight_data import write_flight_data
from simplexspline.aero.modelling.model import AeroModel
from simplexspline.cli import main

EXE = str(Path(sys.executable).with_name("simplexspline"))


@pytest.fixture(scope="module")
def campaign_file(noisy_campaign, tmp_path_factory):
    path = tmp_path_factory.mktemp("identify") / "campaign.parquet"
    write_flight_data(noisy_campaign, path)
    return path


def _run(*args, cwd=None):
    return subprocess.run([EXE, "identify", *args], capture_output=True, text=True,
                          timeout=600, cwd=cwd)


def test_identify_raw_campaign_end_to_end(campaign_file, tmp_path):
    """Raw sensor data -> reconstruction -> selection -> models, summary, report."""
    out = tmp_path / "out"
    res = _run(str(campaign_file), "-o", str(out), "--coefficients", "CZ,Cm",
               "--rounds", "1", "--workers", "1")
    assert res.returncode == 0, res.stderr
    assert "flight path reconstruction" in res.stdout
    assert "rel. RMS" in res.stdout and "CZ(" in res.stdout       # the Table-2 table
    # the derivatives at the reference condition, with their jackknife errors
    assert "derivatives at the reference condition" in res.stdout
    assert re.search(r"Cm_alpha\s+[-+][0-9.]+ \+- [0-9.e-]+\s+1/rad", res.stdout), res.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["derivatives"]["values"]["Cm_alpha"]["folds"] == 5
    assert summary["provenance"]["source"].startswith("campaign.parquet (sha256:")
    assert summary["provenance"]["reconstruction"]["reconstructed"] is True
    for c in ("CZ", "Cm"):
        e = summary["coefficients"][c]
        assert e["rrms"] < 0.1 and e["r2"] > 0.7      # 5 short maneuvers to learn from
        assert e["rms_true"] < 0.05
        model = AeroModel.load(out / "models" / f"{c}.json")
        assert model.structure.label() == e["label"]
    html = (out / "report.html").read_text()
    assert "data:image/png;base64" in html
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out")]


def test_identify_fixed_structure_from_the_command_line(campaign_file, tmp_path, capsys):
    out = tmp_path / "fixed"
    code = main(["identify", str(campaign_file), "-o", str(out), "--coefficients", "CZ",
                 "--model", "CZ(alpha, de, qhat) S^1_2", "--no-select", "--no-report",
                 "--workers", "1", "--format", "npz", "-q"])
    assert code == 0 and capsys.readouterr().out == ""
    model = AeroModel.load(out / "models" / "CZ.npz")
    assert model.structure.label() == "CZ(alpha, de, qhat) S^1_2"
    assert not (out / "report.html").exists()
    assert np.isfinite(model.predict(np.zeros((1, 3)))).all()


def test_unknown_variable_is_a_clear_message_and_writes_nothing(campaign_file, tmp_path):
    out = tmp_path / "bad"
    res = _run(str(campaign_file), "-o", str(out), "--model", "CZ=alpha,elevator",
               "--coefficients", "CZ", "--no-select", "--workers", "1")
    assert res.returncode == 2
    assert "unknown variable(s) ['elevator'] in the structure of CZ" in res.stderr
    assert "Traceback" not in res.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("args, match", [
    (["--model", "CZ alpha"], "cannot read the model structure"),
    (["--coefficients", "CZ,CW"], "unknown coefficient(s) ['CW']"),
    (["--validation-fraction", "1.5"],
     "argument --validation-fraction: expected a number between 0 and 1, got '1.5'"),
    (["--seed", "-1"], "a seed must be an integer between 0 and 4294967295, got '-1'"),
    (["--config", "missing.toml"], "config file 'missing.toml' does not exist"),
])
def test_bad_options(campaign_file, tmp_path, capsys, args, match):
    code = main(["identify", str(campaign_file), "-o", str(tmp_path / "x"), *args])
    assert code == 2
    assert match in capsys.readouterr().err


def test_missing_data_file(tmp_path, capsys):
    assert main(["identify", str(tmp_path / "nope.parquet"), "-o", str(tmp_path / "o")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_main_job_simulates_a_campaign_without_data(tmp_path):
    """The README's first command, shortened: simulate, reconstruct, identify, report."""
    res = _run("-o", "out", "--maneuvers", "3", "--coefficients", "Cm", "--rounds", "0",
               "--no-report", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "simulating a f16 flight-test campaign: 3 maneuvers" in res.stdout
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["aircraft"] == "f16" and "Cm" in summary["coefficients"]
    assert (tmp_path / "out" / "models" / "Cm.json").is_file()


def test_nan_gaps_and_rejected_maneuvers_are_said_on_the_console(noisy_campaign, tmp_path,
                                                                  capsys):
    """A NaN burst in alpha is reported on the console, and so is a maneuver the
    reconstruction rejects for a long gap (issue 18, item 8)."""
    df = noisy_campaign.copy()
    mans = df["maneuver"].to_numpy()
    first, second = np.unique(mans)[:2]
    burst = np.flatnonzero(mans == first)[100:160]
    rows = np.flatnonzero(mans == second)
    gap = rows[len(rows) // 8: len(rows) // 8 + int(0.74 * len(rows))]
    df.loc[df.index[burst], "alpha"] = np.nan
    df.loc[df.index[gap], "q"] = np.nan              # an IMU input: the filter cannot run
    path = tmp_path / "gappy.parquet"
    write_flight_data(df, path)
    code = main(["identify", str(path), "-o", str(tmp_path / "out"), "--coefficients", "Cm",
                 "--rounds", "0", "--no-report"])
    out = capsys.readouterr()
    assert code == 0, out.err
    assert "warning: flight data:" in out.err and "NaN gap(s) in column(s) ['alpha'" in out.err
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    rejected = summary["provenance"]["reconstruction"]["rejected"]
    assert str(int(second)) in rejected
    assert f"warning: the reconstruction rejected {len(rejected)} maneuver(s): maneuver " \
           f"{int(second)}: " in out.out
