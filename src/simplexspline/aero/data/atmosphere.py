"""The International Standard Atmosphere (ISA) and the air-data relations of a flight record.

Pressure altitude gives static pressure through the ISA (troposphere and the isothermal
lower stratosphere, to 20 km); density follows from static pressure and the measured static
temperature by the ideal gas law; calibrated airspeed and static pressure give the Mach number
through the subsonic compressible pitot relation (St Venant); Mach and static temperature give
the true airspeed. SI units throughout: m, Pa, K, kg/m^3, m/s.

>>> round(float(isa_density(0.0)), 4), round(float(isa_pressure(11000.0)), 1)
(1.225, 22632.0)
>>> round(float(mach_from_cas(100.0, isa_pressure(0.0))), 4)
0.2939
"""

from __future__ import annotations

import numpy as np

from simplexspline.errors import InputError

__all__ = ["cas_from_mach", "GAMMA", "LAPSE_RATE", "P0", "R_AIR", "T0", "TROPOPAUSE_M", "CEILING_M",
           "isa_temperature", "isa_pressure", "isa_density", "pressure_altitude", "density",
           "hydrostatic_height",
           "speed_of_sound", "mach_from_cas", "static_temperature_from_total"]

#: Sea-level standard pressure [Pa], temperature [K]; gas constant of air [J/(kg K)];
#: ratio of specific heats; tropospheric lapse rate [K/m]; standard gravity [m/s^2].
P0, T0, R_AIR, GAMMA, LAPSE_RATE, G0 = 101325.0, 288.15, 287.05287, 1.4, 0.0065, 9.80665
#: Tropopause and the top of the modelled atmosphere (isothermal layer) [m].
TROPOPAUSE_M, CEILING_M = 11000.0, 20000.0
#: Lowest pressure altitude accepted [m] (a field 600 m below sea level: the Dead Sea).
FLOOR_M = -610.0
_T11 = T0 - LAPSE_RATE * TROPOPAUSE_M
_P11 = P0 * (_T11 / T0) ** (G0 / (R_AIR * LAPSE_RATE))


def _altitude(h) -> np.ndarray:
    h = np.asarray(h, dtype=float)
    with np.errstate(invalid="ignore"):
        bad = (h < FLOOR_M) | (h > CEILING_M)
    if bad.any():
        first = float(h[bad].flat[0])
        raise InputError(f"pressure altitude {first:.6g} m is outside the ISA model "
                         f"({FLOOR_M:g} .. {CEILING_M:g} m): check the altitude's unit "
                         "(feet given as metres?)")
    return h


def isa_temperature(h) -> np.ndarray:
    """ISA static temperature [K] at pressure altitude ``h`` [m] (array_like)."""
    h = _altitude(h)
    return np.where(h <= TROPOPAUSE_M, T0 - LAPSE_RATE * h, _T11)


def isa_pressure(h) -> np.ndarray:
    """Static pressure [Pa] at pressure altitude ``h`` [m] (array_like), ISA."""
    h = _altitude(h)
    low = P0 * (1.0 - LAPSE_RATE * np.minimum(h, TROPOPAUSE_M) / T0) ** (
        G0 / (R_AIR * LAPSE_RATE))
    high = _P11 * np.exp(-G0 * (h - TROPOPAUSE_M) / (R_AIR * _T11))
    return np.where(h <= TROPOPAUSE_M, low, high)


def pressure_altitude(pressure) -> np.ndarray:
    """Pressure altitude [m] of static pressure ``pressure`` [Pa] (array_like): the
    inverse of :func:`isa_pressure`, what an altimeter set to 1013.25 hPa shows.

    >>> round(float(pressure_altitude(isa_pressure(7000.0))), 6)
    7000.0
    """
    p = np.asarray(pressure, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        if (p <= 0).any():
            raise InputError("static pressure must be positive in Pa")
        low = T0 / LAPSE_RATE * (1.0 - (p / P0) ** (R_AIR * LAPSE_RATE / G0))
        high = TROPOPAUSE_M - R_AIR * _T11 / G0 * np.log(p / _P11)
    return _altitude(np.where(p >= _P11, low, high))


def hydrostatic_height(h, rho, g=G0) -> np.ndarray:
    """Geometric height change [m] along a record from its pressure altitude ``h`` [m] and
    air density ``rho`` [kg/m^3], relative to the first sample where both are finite
    (NaN elsewhere): the hydrostatic equation ``dz = -dp / (rho g)`` summed over the steps
    between finite samples.

    A pressure altitude climbs at the geometric rate only on a standard day and in the
    ISA's geopotential metres: its rate is ``T_ISA(h) / T`` times the geometric one (4 %
    off with the static temperature 12 K from standard), and ``g0 / g`` (0.2 % at 7 km).
    A barometric altitude that stands in for the GPS altitude goes through this first.

    Parameters
    ----------
    h : array_like, shape (N,)
        Pressure altitude [m].
    rho : array_like, shape (N,)
        Air density [kg/m^3] (from the static pressure and temperature).
    g : float or array_like, shape (N,)
        Gravity [m/s^2].

    Returns
    -------
    numpy.ndarray, shape (N,)

    >>> z = hydrostatic_height([0.0, 1000.0], isa_density([0.0, 1000.0]))
    >>> bool(abs(z[1] - 1000.0) < 0.5)
    True
    """
    h = np.asarray(h, dtype=float)
    rho = np.asarray(rho, dtype=float)
    g = np.broadcast_to(np.asarray(g, dtype=float), h.shape)
    out = np.full(h.shape, np.nan)
    ok = np.flatnonzero(np.isfinite(h) & np.isfinite(rho) & (rho > 0))
    if ok.size == 0:
        return out
    p, r, gg = isa_pressure(h[ok]), rho[ok], g[ok]
    # each step's pressure drop over the density and gravity at its middle
    dz = -np.diff(p) / (0.25 * (r[1:] + r[:-1]) * (gg[1:] + gg[:-1]))
    out[ok] = np.concatenate([[0.0], np.cumsum(dz)])
    return out


def density(pressure, temperature) -> np.ndarray:
    """Air density [kg/m^3] from static pressure [Pa] and static temperature [K] (ideal gas)."""
    temperature = np.asarray(temperature, dtype=float)
    with np.errstate(invalid="ignore"):
        if (temperature <= 0).any():
            raise InputError("static temperature must be positive in kelvin: check the "
                             "temperature channel's unit (degC given as K?)")
    return np.asarray(pressure, dtype=float) / (R_AIR * temperature)


def isa_density(h) -> np.ndarray:
    """ISA density [kg/m^3] at pressure altitude ``h`` [m] (standard-day temperature)."""
    return density(isa_pressure(h), isa_temperature(h))


def speed_of_sound(temperature) -> np.ndarray:
    """Speed of sound [m/s] at static temperature [K]."""
    return np.sqrt(GAMMA * R_AIR * np.asarray(temperature, dtype=float))


def mach_from_cas(cas, pressure) -> np.ndarray:
    """Mach number from calibrated airspeed [m/s] and static pressure [Pa] (subsonic).

    The impact pressure of the calibrated airspeed at sea level,
    ``qc = P0 ((1 + 0.2 (cas/a0)^2)^3.5 - 1)``, is the one measured at altitude, so
    ``M = sqrt(5 ((qc/p + 1)^(2/7) - 1))``. Indicated airspeed may be passed when no
    position-error correction is known (the error then passes into Mach and TAS).
    """
    a0 = float(speed_of_sound(T0))
    cas = np.asarray(cas, dtype=float)
    qc = P0 * ((1.0 + 0.2 * (cas / a0) ** 2) ** 3.5 - 1.0)
    return np.sqrt(5.0 * ((qc / np.asarray(pressure, dtype=float) + 1.0) ** (2.0 / 7.0) - 1.0))


def cas_from_mach(mach, pressure) -> np.ndarray:
    """Calibrated airspeed [m/s] from Mach number and static pressure [Pa] (subsonic): the
    inverse of :func:`mach_from_cas`."""
    a0 = float(speed_of_sound(T0))
    mach = np.asarray(mach, dtype=float)
    qc = np.asarray(pressure, dtype=float) * ((1.0 + 0.2 * mach**2) ** 3.5 - 1.0)
    return a0 * np.sqrt(5.0 * ((qc / P0 + 1.0) ** (2.0 / 7.0) - 1.0))


def static_temperature_from_total(total_temperature, mach, recovery: float = 1.0) -> np.ndarray:
    """Static temperature [K] from total (probe) temperature [K] and Mach number.

    ``T = TAT / (1 + recovery (gamma - 1)/2 M^2)``; ``recovery`` is the probe's recovery
    factor (1 for an ideal total-temperature probe).
    """
    mach = np.asarray(mach, dtype=float)
    return np.asarray(total_temperature, dtype=float) / (
        1.0 + recovery * 0.5 * (GAMMA - 1.0) * mach ** 2)
