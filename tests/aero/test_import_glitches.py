"""Time-stamp glitches of real records: repaired where safe, otherwise reported and split."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from simplexspline.aero.data.record_import import import_record
from simplexspline.aero.data.time_base import clean_time_stamps, common_grid, resample
from simplexspline.errors import FlightDataError

DATA = Path(__file__).resolve().parents[1] / "data" / "citation_like"


def _signal(t):
    return np.sin(0.7 * t) + 0.1 * t


def test_duplicates_are_dropped_and_reported():
    t = np.arange(100) * 0.1
    tt = np.insert(t, [10, 50, 50], [t[9], t[49], t[49]])
    v = np.insert(_signal(t), [10, 50, 50], [_signal(t[9]), 5.0, _signal(t[49])])
    c = clean_time_stamps("q", tt, v)
    assert np.array_equal(c.t, t) and np.allclose(c.values, _signal(t))
    kinds = {i.kind: i for i in c.issues}
    assert kinds["duplicate"].samples == 2
    assert kinds["conflicting-duplicate"].samples == 1
    assert kinds["conflicting-duplicate"].t == pytest.approx(4.9)
    assert "different values" in kinds["conflicting-duplicate"].text()


def test_a_jumping_stamp_and_a_short_step_back_are_dropped():
    t = np.arange(100) * 0.1
    tt, v = t.copy(), _signal(t)
    tt[30] = 1234.5                  # corrupted stamp that jumps ahead and comes back
    tt[60] = 5.55                    # one sample stamped before its predecessor
    c = clean_time_stamps("alpha", tt, v)
    assert c.t.size == 98 and np.all(np.diff(c.t) > 0)
    kinds = {i.kind: i for i in c.issues}
    assert kinds["jump"].t == 1234.5 and kinds["jump"].samples == 1
    assert kinds["backwards"].samples == 1
    assert not c.gaps
    grid = common_grid([c])
    assert np.allclose(resample(c, grid), _signal(grid), atol=0.02)   # bridged one step


def test_a_clock_reset_is_an_error_naming_the_channel():
    t = np.r_[np.arange(100) * 0.1, np.arange(50) * 0.1]
    with pytest.raises(FlightDataError, match=r"channel 'h': time goes back from 9\.9 s to "
                                              r"0 s and stays behind for 50 samples"):
        clean_time_stamps("h", t, np.zeros(t.size))


def test_a_dropout_is_left_as_nan_not_interpolated():
    t = np.r_[np.arange(50), np.arange(80, 130)] * 0.1
    c = clean_time_stamps("p", t, _signal(t))
    assert c.gaps == [(pytest.approx(4.9), pytest.approx(8.0))]
    (issue,) = c.issues
    assert issue.kind == "dropout" and issue.samples == 30
    assert "dropout of 3.1 s" in issue.text() and "split" in issue.text()
    grid = common_grid([c])
    v = resample(c, grid)
    hole = (grid > 4.95) & (grid < 7.95)
    assert np.isnan(v[hole]).all() and np.isfinite(v[~hole]).all()


def test_channels_at_different_rates_share_the_fastest_time_base():
    fast = clean_time_stamps("q", np.arange(0, 20, 0.1), _signal(np.arange(0, 20, 0.1)))
    slow = clean_time_stamps("lat", np.arange(0, 20.01, 1.0), _signal(np.arange(0, 21, 1.0)))
    grid = common_grid([slow, fast])
    assert np.allclose(np.diff(grid), 0.1) and grid[0] == 0 and grid[-1] == pytest.approx(20)
    v = resample(slow, grid)
    assert np.allclose(v[::10], _signal(np.arange(0, 21, 1.0)))     # the samples themselves
    assert np.isnan(resample(fast, grid)[-1])                       # beyond its last stamp


def test_wrapping_angles_are_interpolated_the_short_way():
    t = np.arange(4) * 1.0
    psi = np.array([3.0, 3.1, -3.1, -3.0])
    c = clean_time_stamps("psi", t, psi)
    v = resample(c, np.array([1.5]), wrap=True)
    assert abs(abs(v[0]) - np.pi) < 0.05


def _copy_record(tmp_path):
    rec = tmp_path / "rec"
    shutil.copytree(DATA, rec)
    return rec


def test_a_dropout_in_a_record_splits_the_maneuver_and_is_reported(tmp_path):
    rec = _copy_record(tmp_path)
    f = rec / "pitch_rate.txt"
    lines = f.read_text().splitlines()
    # remove 1.5 s of samples in the middle of the first maneuver (1040 .. 1057.1 s)
    keep = [ln for ln in lines if not (ln[0].isdigit() and 1047.0 <= float(ln.split()[0])
                                       <= 1048.5)]
    f.write_text("\n".join(keep) + "\n")
    result = import_record(rec / "mapping.toml")
    assert any(i.kind == "dropout" and i.channel == "q" for i in result.time_issues)
    types = [s["type"] for s in result.segments()]
    assert types == ["3211-elevator", "3211-elevator", "3211-aileron", "doublet-elevator"]
    assert any("split into 2" in n for n in result.segment_notes)
    assert not result.data["q"].isna().any()
    assert "dropout of 1.7 s (16 samples missing) at t = 1046.9 s" in result.summary()


def test_repeated_time_stamps_in_a_record_are_repaired_and_reported(tmp_path):
    rec = _copy_record(tmp_path)
    f = rec / "vane_aoa.txt"
    lines = f.read_text().splitlines()
    lines.insert(500, lines[499])
    f.write_text("\n".join(lines) + "\n")
    clean = import_record(DATA / "mapping.toml").data
    result = import_record(rec / "mapping.toml")
    assert [i.kind for i in result.time_issues] == ["duplicate"]
    assert "channel 'alpha': 1 repeated time stamp(s)" in result.summary()
    assert np.array_equal(result.data["alpha"], clean["alpha"])


def test_a_slow_sensor_recorded_faster_keeps_its_updates():
    """A 1 Hz fix held for ten 10 Hz samples: the updates are kept and interpolated, a
    value that stood still (on the ground) is no dropout, a live channel is untouched."""
    from simplexspline.aero.data.time_base import held_updates

    t = np.arange(600) * 0.1
    x = np.where(t < 20.0, 0.0, 60.0 * (t - 20.0))            # parked, then 60 m/s
    held = x[(np.arange(600) // 10) * 10]                      # the receiver's 1 Hz fixes
    tk, vk, issue = held_updates("x_gps", t, held)
    assert issue.kind == "held" and issue.duration == pytest.approx(1.0)
    assert "updating every 1 s" in issue.text()
    assert np.max(np.diff(tk)) <= 1.0 + 1e-9                  # the parked run: no gap
    c = clean_time_stamps("x_gps", tk, vk)
    assert not c.issues and c.dt == pytest.approx(1.0)
    back = resample(c, t)
    fixes = t <= tk[-1]
    assert np.max(np.abs(back[fixes] - x[fixes])) < 1e-9       # exact for a straight line
    assert np.max(np.abs(held - x)) > 50.0                     # the stairs: 54 m off
    live = np.sin(t)
    assert held_updates("x_gps", t, live)[2] is None
    assert held_updates("x_gps", t, np.zeros_like(t))[2] is None   # dead, not slow
    with_gap = held.copy()
    with_gap[100:110] = np.nan
    tk, vk, _ = held_updates("x_gps", t, with_gap)
    assert np.isnan(vk).sum() == 10                            # missing samples stay missing


def test_gps_fixes_held_at_the_recorder_rate_are_interpolated(tmp_path):
    d = tmp_path / "rec"
    shutil.copytree(DATA, d)
    for name in ("gps_lat.txt", "gps_lon.txt"):
        lines = (d / name).read_text().splitlines()
        rows = [ln.split() for ln in lines[1:]]
        (d / name).write_text("\n".join([lines[0]] + [f"{a} {rows[(i // 10) * 10][1]}"
                                                      for i, (a, _) in enumerate(rows)]) + "\n")
    text = (DATA / "mapping.toml").read_text().replace('path = "."', f'path = "{d}"').replace(
        'list = "maneuvers.csv"', f'list = "{d / "maneuvers.csv"}"')
    (d / "mapping.toml").write_text(text)
    held = import_record(d / "mapping.toml")
    clean = import_record(DATA / "mapping.toml")
    assert {i.channel for i in held.time_issues if i.kind == "held"} == {"lat", "lon"}
    assert not [i for i in held.time_issues if i.kind == "dropout"]
    assert len(held.data) == len(clean.data)
    err = np.hypot(held.data["x_gps"] - clean.data["x_gps"],
                   held.data["y_gps"] - clean.data["y_gps"])
    assert np.max(err) < 2.0                                   # m; held as stairs: 100+
    assert not held.sanity.failed()
