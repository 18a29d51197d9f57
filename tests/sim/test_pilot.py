"""Actuator and pilot/SAS control laws (no JSBSim needed)."""

from __future__ import annotations

import numpy as np
import pytest

from simplexspline.errors import InputError
from simplexspline.sim.pilot import Actuator, AircraftState, Airframe, Pilot, PilotStyle, Turn

TRIM = {"theta": 0.05, "phi": 0.0, "psi": 1.0, "h": 3000.0, "tas": 150.0, "de": -0.02,
        "da": 0.0, "dr": 0.0, "throttle": 0.5}
AIRFRAME = Airframe(bandwidth=(2.0, 2.5), damping=(3.0, 3.0, 1.5),
                    control_power=(-0.5, 0.05, -0.05), geometry=(27.9, 9.1, 3.45))
ARGS = dict(airframe=AIRFRAME, style=PilotStyle(delay_s=0.0))
STATE = AircraftState(theta=0.05, phi=0.0, psi=1.0, p=0.0, q=0.0, r=0.0, h=3000.0, tas=150.0,
                      vd=0.0, qbar=10000.0, ixx=1.3e4, iyy=7.5e4, izz=8.5e4, alpha=0.05, nz=1.0)


def test_actuator_first_order_response():
    act = Actuator(0.0, limit=1.0, rate=100.0, tau=0.05, dt=0.01)
    x = np.array([act.step(0.1) for _ in range(30)])
    t = np.arange(1, 31) * 0.01
    assert np.allclose(x, 0.1 * (1 - np.exp(-t / 0.05)), rtol=1e-12)


def test_actuator_rate_and_position_limits():
    act = Actuator(0.0, limit=0.3, rate=1.0, tau=0.01, dt=0.01)
    x = np.array([act.step(5.0) for _ in range(50)])
    assert np.allclose(np.diff(x[:25]), 0.01)  # 1 rad/s
    assert x.max() == pytest.approx(0.3) and np.all(x <= 0.3)


@pytest.mark.parametrize("mode", ["pilot", "autopilot"])
def test_trimmed_state_gives_trim_commands(mode):
    pilot = Pilot(mode, TRIM, **ARGS)
    de, da, dr, thr = pilot.command(STATE)
    assert (de, da, dr) == pytest.approx((TRIM["de"], TRIM["da"], TRIM["dr"]), abs=1e-15)
    assert thr == (pytest.approx(0.5) if mode == "pilot" else None)


def test_signs_of_the_corrections():
    pilot = Pilot("autopilot", TRIM, **ARGS)
    # nose below the reference: pitch up, i.e. trailing edge up (de decreases, Cm_de < 0)
    de, *_ = pilot.command(STATE._replace(theta=0.0))
    assert de < TRIM["de"]
    # right wing down: roll left, i.e. negative aileron (Cl_da > 0)
    _, da, _, _ = pilot.command(STATE._replace(phi=0.1))
    assert da < 0
    # yawing right: rudder opposes (Cn_dr < 0: positive rudder yaws left)
    _, _, dr, _ = pilot.command(STATE._replace(r=0.1))
    assert dr > 0


def test_gain_scheduling_with_dynamic_pressure():
    pilot = Pilot("autopilot", TRIM, **ARGS)
    d1 = pilot.command(STATE._replace(q=0.1))[0] - TRIM["de"]
    pilot = Pilot("autopilot", TRIM, **ARGS)
    d2 = pilot.command(STATE._replace(q=0.1, qbar=20000.0))[0] - TRIM["de"]
    assert d2 == pytest.approx(d1 / 2)


def test_envelope_protection_pushes_back():
    prot = {"nz": (-1.0, 4.0), "alpha": (-0.1, 0.3), "phi": 1.0}
    base = Pilot("autopilot", TRIM, **ARGS).command(STATE)[0]
    high_g = Pilot("autopilot", TRIM, protection=prot, **ARGS).command(STATE._replace(nz=5.0))
    assert high_g[0] > base  # nose-down demand
    high_a = Pilot("autopilot", TRIM, protection=prot, **ARGS).command(STATE._replace(alpha=0.4))
    assert high_a[0] > base
    steep = Pilot("autopilot", TRIM, protection=prot, **ARGS).command(STATE._replace(phi=1.2))
    unprotected = Pilot("autopilot", TRIM, **ARGS).command(STATE._replace(phi=1.2))
    assert steep[1] < unprotected[1]


def test_pilot_delay():
    pilot = Pilot("pilot", TRIM, **{**ARGS, "style": PilotStyle(delay_s=0.2)})
    out = [pilot.command(STATE._replace(theta=0.0))[0] for _ in range(25)]
    # the rate damper acts at once (q = 0 here), the attitude correction 0.2 s late
    assert out[0] == pytest.approx(TRIM["de"])
    assert out[-1] < TRIM["de"]
    first = next(i for i, d in enumerate(out) if d < TRIM["de"] - 1e-12)
    assert first == 20


def test_pilot_rolls_into_a_turn_after_the_lead():
    pilot = Pilot("pilot", TRIM, turn=Turn(bank=0.5, start_s=1.0), **ARGS)
    das = [pilot.command(STATE)[1] for _ in range(150)]
    assert max(abs(d) for d in das[:95]) < 1e-12
    assert das[-1] > 0  # right-wing-down demand


def test_relaxed_pilot_corrects_more_gently():
    """A 0.7x bandwidth asks for 0.49x the correction of the same attitude error."""
    soft_style = PilotStyle(delay_s=0.0, bandwidth_scale=0.7)
    for k, error, trim in ((0, STATE._replace(theta=0.0), TRIM["de"]),
                           (1, STATE._replace(phi=0.1), TRIM["da"])):
        firm = Pilot("pilot", TRIM, **ARGS).command(error)[k] - trim
        soft = Pilot("pilot", TRIM, AIRFRAME, style=soft_style).command(error)[k] - trim
        assert abs(firm) > 1e-4
        assert soft == pytest.approx(0.49 * firm, rel=1e-9)


@pytest.mark.parametrize("field", ["delay_s", "bandwidth_scale", "heading_gain"])
def test_pilot_style_rejects_bad_values(field):
    with pytest.raises(InputError, match=f"PilotStyle.{field} must be a number"):
        PilotStyle(**{field: float("nan")})
