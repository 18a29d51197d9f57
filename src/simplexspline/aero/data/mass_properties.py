"""Mass and inertias of a flight record: ramp mass minus fuel used; radii of gyration or a table.

A flight-test record rarely holds the mass and inertias; it holds the fuel used. The mass is
the ramp mass minus the fuel used; the inertias follow either from radii of gyration
(``I = m k^2``, constant radii) or from a table of inertias over mass (weight-and-balance
data), interpolated linearly. A table is never extrapolated: a mass outside it is an error.

>>> import numpy as np
>>> m = mass_from_fuel(6000.0, np.array([0.0, 100.0]))
>>> m.tolist()
[6000.0, 5900.0]
>>> inertias_from_radii(m, {"x": 2.0, "y": 3.0, "z": 4.0})["Iyy"].tolist()
[54000.0, 53100.0]
"""

from __future__ import annotations

import numpy as np

from simplexspline.errors import InputError

__all__ = ["mass_from_fuel", "inertias_from_radii", "inertias_from_table", "INERTIAS"]

#: The schema's inertia columns.
INERTIAS: tuple[str, ...] = ("Ixx", "Iyy", "Izz", "Ixz")


def mass_from_fuel(ramp_mass: float, fuel_used) -> np.ndarray:
    """Mass [kg] = ramp mass [kg] - fuel used [kg] (array_like, NaN passes through).

    Raises
    ------
    InputError
        If the fuel used exceeds the ramp mass (a unit error: fuel in lb read as kg?).
    """
    fuel = np.asarray(fuel_used, dtype=float)
    mass = ramp_mass - fuel
    with np.errstate(invalid="ignore"):
        if (mass <= 0).any():
            raise InputError(f"fuel used reaches {np.nanmax(fuel):.6g} kg, more than the ramp "
                             f"mass {ramp_mass:.6g} kg: check the units of fuel_used and "
                             "ramp_mass")
    return mass


def inertias_from_radii(mass, radii: dict) -> dict:
    """Inertias [kg m^2] from radii of gyration [m]: ``Ixx = m kx^2`` etc.

    Parameters
    ----------
    mass : array_like, shape (n,)
        [kg].
    radii : dict
        'x', 'y', 'z' [m] and optionally 'xz' [m], signed: ``Ixz = sign(xz) m xz^2``
        (0 when absent).

    Returns
    -------
    dict of str to ndarray, shape (n,)
        'Ixx', 'Iyy', 'Izz', 'Ixz'.
    """
    m = np.asarray(mass, dtype=float)
    xz = float(radii.get("xz", 0.0))
    return {"Ixx": m * radii["x"] ** 2, "Iyy": m * radii["y"] ** 2, "Izz": m * radii["z"] ** 2,
            "Ixz": np.sign(xz) * m * xz ** 2}


def inertias_from_table(mass, table: dict) -> dict:
    """Inertias [kg m^2] interpolated linearly in a table over mass.

    Parameters
    ----------
    mass : array_like, shape (n,)
        [kg]; NaN passes through.
    table : dict
        'mass' (strictly increasing, [kg]) and 'Ixx', 'Iyy', 'Izz', optionally 'Ixz'
        [kg m^2], lists of equal length. A single row gives constant inertias.

    Returns
    -------
    dict of str to ndarray, shape (n,)

    Raises
    ------
    InputError
        If a mass lies outside the table (it is never extrapolated).
    """
    m = np.asarray(mass, dtype=float)
    grid = np.asarray(table["mass"], dtype=float)
    finite = m[np.isfinite(m)]
    if grid.size > 1 and finite.size and (finite.min() < grid[0] - 1e-9 * grid[0]
                                          or finite.max() > grid[-1] + 1e-9 * grid[-1]):
        raise InputError(f"mass {finite.min():.6g} .. {finite.max():.6g} kg leaves the inertia "
                         f"table ({grid[0]:.6g} .. {grid[-1]:.6g} kg); extend the table (it is "
                         "not extrapolated) or check the mass units")
    out = {}
    for key in INERTIAS:
        values = np.asarray(table.get(key, np.zeros(grid.size)), dtype=float)
        if grid.size == 1:
            out[key] = np.where(np.isfinite(m), values[0], np.nan)
        else:
            out[key] = np.where(np.isfinite(m), np.interp(m, grid, values), np.nan)
    return out
