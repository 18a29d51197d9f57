"""The ISA's pressure altitude and the hydrostatic height change of a barometric record."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings as hsettings, strategies as st

from simplexspline.aero.data.atmosphere import (
    G0, R_AIR, hydrostatic_height, isa_pressure, isa_temperature, pressure_altitude,
)
from simplexspline.errors import InputError


@hsettings(max_examples=60, deadline=None)
@given(st.floats(-600.0, 19990.0))
def test_pressure_altitude_inverts_the_isa_pressure(h):
    assert float(pressure_altitude(isa_pressure(h))) == pytest.approx(h, abs=1e-6)


def test_pressure_altitude_rejects_what_no_altimeter_shows():
    with pytest.raises(InputError, match="static pressure must be positive"):
        pressure_altitude([90000.0, 0.0])
    with pytest.raises(InputError, match="outside the ISA model"):
        pressure_altitude(1000.0)            # Pa: above 20 km


def _hot_day(z, delta_t=15.0):
    """Static pressure and density at geometric heights ``z`` [m] of a day ``delta_t``
    warmer than the ISA, with gravity falling with height: the hydrostatic equation
    integrated finely from sea level."""
    zz = np.linspace(0.0, float(np.max(z)), 20001)
    g = G0 * (6.371e6 / (6.371e6 + zz)) ** 2
    # geopotential height, the ISA's temperature profile in it, plus delta_t
    hgp = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) / G0 * np.diff(zz))])
    temp = isa_temperature(hgp) + delta_t
    lnp = np.log(101325.0) - np.concatenate(
        [[0.0], np.cumsum(0.5 * (g[1:] / temp[1:] + g[:-1] / temp[:-1]) / R_AIR * np.diff(zz))])
    p = np.exp(np.interp(z, zz, lnp))
    t = np.interp(z, zz, temp)
    return p, p / (R_AIR * t), G0 * (6.371e6 / (6.371e6 + z)) ** 2


def test_the_hydrostatic_height_follows_the_aircraft_on_a_hot_day():
    """A 2 km climb at 7 km on a day 15 K above standard: the pressure altitude climbs
    about 6 % less than the aircraft; the hydrostatic height change is within 0.2 m."""
    z = np.linspace(7000.0, 9000.0, 401)
    p, rho, g = _hot_day(z)
    h = pressure_altitude(p)
    climb = z - z[0]
    assert abs((h[-1] - h[0]) - climb[-1]) > 80.0                 # the raw baro is 4-6 % off
    assert np.max(np.abs(hydrostatic_height(h, rho, g) - climb)) < 0.2
    # on the standard day, g = g0: the geopotential pressure altitude itself
    hs = np.linspace(1000.0, 3000.0, 201)
    rho_isa = isa_pressure(hs) / (R_AIR * isa_temperature(hs))
    assert np.max(np.abs(hydrostatic_height(hs, rho_isa) - (hs - hs[0]))) < 1e-3


def test_gaps_stay_gaps_and_the_rest_is_relative_to_the_first_finite_sample():
    z = np.linspace(3000.0, 3300.0, 7)
    p, rho, g = _hot_day(z, 0.0)
    h = pressure_altitude(p)
    h[0] = np.nan
    rho[3] = np.nan
    out = hydrostatic_height(h, rho, g)
    assert np.isnan(out[0]) and np.isnan(out[3])
    assert out[1] == 0.0
    np.testing.assert_allclose(out[[2, 4, 5, 6]], z[[2, 4, 5, 6]] - z[1], atol=0.05)
    assert np.isnan(hydrostatic_height([np.nan, np.nan], [1.0, 1.0])).all()
