"""The JSBSim boundary: idle models, scratch directory, console silence."""

from __future__ import annotations

import os

import numpy as np

from simplexspline.sim import fdm as fdm_module
from simplexspline.sim import get_aircraft
from simplexspline.sim.maneuvers import design_maneuver
from simplexspline.sim.flight import simulate_maneuver
from simplexspline.sim.sensors import SensorModel

from .conftest import small_campaign


def _spec(aircraft: str, kind: str) -> dict:
    prof = get_aircraft(aircraft)
    return {"index": 0, "condition": 0, "profile": prof.to_dict(),
            "envelope": prof.envelope.to_dict(), "sensors": SensorModel.ideal().to_dict(),
            "design": design_maneuver(kind, prof, np.random.default_rng(5), (15.0, 15.0)),
            "h_m": 4000.0, "tas_mps": 200.0, "h_nominal": 4000.0, "tas_nominal": 200.0,
            "psi_rad": 0.3, "fuel_fraction": 0.8, "seed": 0, "min_kept_s": 3.0,
            "pilot": {"delay_s": 0.2}}


def test_switching_idle_models_off_changes_nothing(monkeypatch):
    for aircraft in ("f16", "global5000"):
        spec = _spec(aircraft, "sum-of-sines")
        fast = simulate_maneuver(spec)["columns"]
        monkeypatch.setattr(fdm_module, "IDLE_MODELS", ())
        full = simulate_maneuver(spec)["columns"]
        monkeypatch.undo()
        assert fast.keys() == full.keys()
        for name in fast:
            assert np.array_equal(fast[name], full[name]), (aircraft, name)


def test_jsbsim_leaves_no_files_and_no_console_output(tmp_path, monkeypatch, capfd):
    monkeypatch.chdir(tmp_path)
    small_campaign("global5000", maneuvers=1, mix={"doublet": 1}).run(workers=1,
                                                                      progress=False)
    assert os.listdir(tmp_path) == []  # global5000 writes global5000.csv into the cwd
    assert os.getcwd() == str(tmp_path)
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_quiet_scratch_restores_streams(capfd):
    with fdm_module.quiet_scratch() as scratch:
        print("hidden")
        os.write(1, b"hidden too\n")
        assert os.getcwd() == scratch
    print("shown")
    out, _ = capfd.readouterr()
    assert out == "shown\n"


def test_engine_channels_fuel_flow_and_fan_speed():
    """The recorder reads what a real installation's engine channels show: the total fuel
    flow of all engines and the mean fan speed N1 of turbines (NaN for a piston). The thrust
    per fuel flow lands where engines of each kind have it."""
    for aircraft, fan, per_fuel in (("f16", True, (2e4, 8e4)),
                                    ("global5000", True, (2e4, 8e4)),
                                    ("c172p", False, (5e4, 5e5))):
        prof = get_aircraft(aircraft)
        with fdm_module.quiet_scratch():
            fdm = fdm_module.trim_fdm(prof, prof.altitudes_m[0], prof.airspeeds_mps[-1])
            rec = fdm_module.Recorder(fdm, prof)
            fdm.run()
            s = rec.sample()
        idx = fdm_module.IDX
        assert len(s) == len(idx)
        fuel = s[idx["engines/fuel-flow-pps"]] * 0.45359237            # kg/s
        thrust = s[idx["forces/fbx-prop-lbs"]] * 4.4482216152605       # N
        assert fuel > 0 and per_fuel[0] < thrust / fuel < per_fuel[1], (aircraft, thrust / fuel)
        n1 = s[idx["engines/n1-pct"]]
        assert (30.0 < n1 < 110.0) if fan else np.isnan(n1), (aircraft, n1)


def test_campaign_columns_hold_the_engine_channels(f16_ideal):
    assert (f16_ideal["fuel_flow"] > 0).all()
    assert f16_ideal["n1"].between(0.3, 1.1).all()
    # the fuel flow follows the throttle: thrust per fuel flow stays within a factor of 2
    ratio = f16_ideal["thrust_x"] / f16_ideal["fuel_flow"]
    assert ratio.max() / ratio.min() < 2.0
