"""The wind triangle: initial heading and wind without a heading channel."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplexspline.aero.reconstruction.wind_triangle import MIN_HEADING_CHANGE, wind_triangle


def _turn(psi0, wind, rate, n=2001, dt=0.01, V=150.0, alpha=0.05, bank=0.4, noise=0.0,
          seed=0):
    """A steady turn at heading rate ``rate`` (bank ``bank``, pitch ``alpha``) in a constant
    wind: exact GPS positions of ground = air + wind velocity."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    psi = psi0 + rate * t
    theta = np.full(n, alpha)
    phi = np.full(n, bank)
    cf, sf, ct, st = math.cos(bank), math.sin(bank), math.cos(alpha), math.sin(alpha)
    # body rates of a steady turn: psidot = (q sin(phi) + r cos(phi)) / cos(theta)
    q = rate * math.cos(alpha) * math.sin(bank) * np.ones(n)
    r = rate * math.cos(alpha) * math.cos(bank) * np.ones(n)
    # air velocity (V cos(alpha), 0, V sin(alpha)) in body axes, rotated to NED (beta = 0)
    ub, wb = V * math.cos(alpha), V * math.sin(alpha)
    cp, sp = np.cos(psi), np.sin(psi)
    air = (ct * cp * ub + (cf * st * cp + sf * sp) * wb
           + 1j * (ct * sp * ub + (cf * st * sp - sf * cp) * wb))
    ground = air + complex(*wind)
    track = np.concatenate([[0], np.cumsum(0.5 * (ground[1:] + ground[:-1])) * dt])
    track = track + noise * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    return dict(dt=dt, tas=np.full(n, V), alpha=np.full(n, alpha), beta=None, phi=phi,
                theta=theta, q=q, r=r, north=track.real, east=track.imag)


def test_recovers_heading_and_wind_in_a_turn():
    tri = wind_triangle(**_turn(psi0=2.5, wind=(6.0, -9.0), rate=0.05, noise=2.0))
    assert tri.heading_change == pytest.approx(0.05 * 20.0, rel=1e-3)
    assert tri.heading_change > MIN_HEADING_CHANGE
    assert abs(tri.psi0 - 2.5) < 2e-3                       # rad
    assert math.hypot(tri.wind_n - 6.0, tri.wind_e + 9.0) < 0.2   # m/s
    assert 1.0 < tri.residual < 3.0                          # the 2 m position noise


def test_exact_without_noise_and_heading_wraps():
    tri = wind_triangle(**_turn(psi0=-3.0, wind=(-4.0, 2.0), rate=-0.08))
    assert tri.psi0 == pytest.approx(-3.0, abs=1e-6)
    assert (tri.wind_n, tri.wind_e) == pytest.approx((-4.0, 2.0), abs=1e-4)
    assert tri.residual < 1e-6


def test_straight_flight_reports_no_heading_change_and_gaps_are_skipped():
    case = _turn(psi0=1.0, wind=(5.0, 5.0), rate=0.0)
    assert wind_triangle(**case).heading_change == pytest.approx(0.0, abs=1e-12)
    case = _turn(psi0=1.0, wind=(5.0, 5.0), rate=0.05)
    case["north"][::3] = np.nan                              # GPS at a third of the rate
    tri = wind_triangle(**case)
    assert tri.psi0 == pytest.approx(1.0, abs=1e-6)
    case["north"][5:] = np.nan
    assert wind_triangle(**case) is None                     # too few GPS samples
