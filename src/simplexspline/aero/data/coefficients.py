"""Aerodynamic force and moment coefficients from (reconstructed) flight data: Eq. 43-48.

de Visser, Mulder and Chu (AIAA 2010-7950), Eq. 43-48, with ``qbar = rho V^2 / 2``::

    CX = (m ax - Tx) / (qbar S)
    CY = (m ay - Ty) / (qbar S)
    CZ = (m az - Tz) / (qbar S)
    Cl = (Ixx pdot - (Iyy - Izz) q r - Ixz (rdot + p q) - Tl) / (qbar S b)
    Cm = (Iyy qdot - (Izz - Ixx) r p - Ixz (r^2 - p^2) - Tm) / (qbar S cbar)
    Cn = (Izz rdot - (Ixx - Iyy) p q - Ixz (pdot - q r) - Tn) / (qbar S b)

Thrust: when all six ``thrust_x .. thrust_n`` columns are present the thrust forces and
moments T are subtracted (aerodynamic coefficients); otherwise T = 0 and the coefficients
include thrust, as in the paper, and the result is flagged (``thrust_subtracted`` False).
``Ixz`` has the sign of the paper (the schema's convention). Angular accelerations come from
the ``pdot, qdot, rdot`` columns or, when absent (or on request), from the rates by smoothed
differentiation (:func:`~simplexspline.aero.data.differentiation.midpoint_derivative`).

Moment reference point: Eq. 46-48 give the moments about the c.g. When the c.g. moves
(columns ``x_cg, y_cg, z_cg``: fuel burn, passengers), the same aircraft then has different
moment coefficients from one maneuver to the next (a pitching moment ``-dx CZ / cbar`` for a
c.g. shift ``dx``), which no function of the flight state can fit. The moments are therefore
transferred to one fixed point (:func:`transfer_moments`), ``M_ref = M_cg + r x F`` with
``r`` the c.g. from that point::

    Cl_ref = Cl + (ry CZ - rz CY) / b
    Cm_ref = Cm + (rz CX - rx CZ) / cbar
    Cn_ref = Cn + (rx CY - ry CX) / b

The point is metadata ``moment_reference_m`` (x, y, z [m] in the frame of the c.g. columns)
when given, else the median c.g. of the data (the shortest transfer, so the least force
noise enters the moments). True moment coefficients (``true_Cl, true_Cm, true_Cn``), when
present, are transferred alike so that they stay comparable.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from simplexspline.aero.data.differentiation import derivative_by_maneuver
from simplexspline.aero.variables import COEFFICIENTS, RATE_NAMES
from simplexspline.errors import FlightDataError, InputError

__all__ = ["THRUST_COLUMNS", "CG_COLUMNS", "aerodynamic_coefficients", "angular_accelerations",
           "transfer_moments"]

#: The name the deprecated path ``simplexspline.aero.coefficients`` forwards: use
#: :data:`simplexspline.aero.variables.COEFFICIENTS`.
COEFFICIENT_NAMES = COEFFICIENTS
#: Thrust forces [N] and moments [N m] subtracted when all six are present.
THRUST_COLUMNS: tuple[str, ...] = ("thrust_x", "thrust_y", "thrust_z", "thrust_l", "thrust_m",
                                   "thrust_n")
#: The c.g. from the sensor-geometry reference point, body axes [m].
CG_COLUMNS: tuple[str, ...] = ("x_cg", "y_cg", "z_cg")
_NEEDED = ("maneuver", "t", "tas", "rho", "p", "q", "r", "mass", "Ixx", "Iyy", "Izz", "Ixz")
_ACCELEROMETERS = ("ax", "ay", "az")


def angular_accelerations(df, *, half_window: int | None = None,
                          degree: int = 4) -> np.ndarray:
    """pdot, qdot, rdot [rad/s^2] by smoothed differentiation of p, q, r per maneuver.

    Parameters
    ----------
    df : pandas.DataFrame
        Columns ``maneuver``, ``t``, ``p``, ``q``, ``r``; uniform sampling within a maneuver.
    half_window : int, optional
    degree : int
        See :func:`~simplexspline.aero.data.differentiation.derivative_by_maneuver` (None:
        the default for the data's rate).

    Returns
    -------
    (n, 3) ndarray
        In the row order of ``df``; NaN for maneuvers with a NaN rate.
    """
    return derivative_by_maneuver(df["maneuver"].to_numpy(), df["t"].to_numpy(dtype=float),
                                  df[["p", "q", "r"]].to_numpy(dtype=float),
                                  half_window=half_window, degree=degree)


def transfer_moments(forces: np.ndarray, moments: np.ndarray, arm: np.ndarray, b: float,
                     cbar: float) -> np.ndarray:
    """Moment coefficients about another point: ``M_ref = M_cg + r x F``.

    Parameters
    ----------
    forces : (n, 3) ndarray
        ``CX, CY, CZ`` [-], the forces the moments belong to (aerodynamic, or with thrust
        when the moments include it).
    moments : (n, 3) ndarray
        ``Cl, Cm, Cn`` [-] about the c.g.
    arm : (3,) or (n, 3) ndarray
        ``r``: the c.g. from the new reference point, body axes (x forward, y right,
        z down) [m].
    b, cbar : float
        Span and mean aerodynamic chord [m].

    Returns
    -------
    (n, 3) ndarray
        ``Cl, Cm, Cn`` about the reference point.
    """
    F = np.asarray(forces, dtype=float)
    r = np.broadcast_to(np.asarray(arm, dtype=float), F.shape)
    rxF = np.cross(r, F)             # [m]: the moment arm times the force coefficients
    return np.asarray(moments, dtype=float) + rxF / np.array([b, cbar, b])


def _moment_reference(meta: Mapping, cg: np.ndarray) -> tuple[np.ndarray, str]:
    """The fixed point the moments are transferred to, and where it came from."""
    given = meta.get("moment_reference_m")
    if given is not None:
        ref = np.asarray(given, dtype=float)
        if ref.shape != (3,) or not np.isfinite(ref).all():
            raise InputError(f"metadata moment_reference_m must be three finite numbers "
                             f"(x, y, z [m], the frame of x_cg, y_cg, z_cg), got {given!r}")
        return ref, "metadata moment_reference_m"
    return np.nanmedian(cg, axis=0), "the median c.g. of the data"


def aerodynamic_coefficients(df, metadata: Mapping | None = None, *,
                             accelerations: str = "auto", half_window: int | None = None,
                             degree: int = 4, thrust_model=None):
    """Force and moment coefficients (Eq. 43-48) and non-dimensional rates.

    Parameters
    ----------
    df : pandas.DataFrame
        Flight data in the schema (SI units); ideally reconstructed (bias-corrected) data.
    metadata : mapping, optional
        Schema metadata with ``S`` [m^2], ``b`` [m], ``cbar`` [m]; ``df.attrs`` if None.
    accelerations : {'auto', 'measured', 'differentiate'}
        Where pdot, qdot, rdot come from: the columns ('measured'), smoothed
        differentiation of p, q, r ('differentiate'), or the columns when present ('auto').
    half_window : int, optional
    degree : int
        Differentiation settings (:func:`angular_accelerations`; None: the default for the
        data's rate).
    thrust_model : callable or ThrustModel, optional
        Used when the ``thrust_*`` columns are absent: ``thrust_model(df)`` returns a
        mapping with some of ``thrust_x .. thrust_n`` ((n,) arrays, N and N m; the others
        are zero), e.g. :class:`~simplexspline.aero.data.thrust.ThrustModel` (a function of
        fan speed or fuel flow, density and Mach).

    Returns
    -------
    coefficients : pandas.DataFrame
        Columns ``CX, CY, CZ, Cl, Cm, Cn, phat, qhat, rhat`` (and ``pdot, qdot, rdot`` as
        used), same index as ``df``. Without accelerometers (``ax, ay, az`` absent or
        entirely NaN) ``CX, CY, CZ`` are NaN: moment coefficients only. With c.g. columns
        the moments are about a fixed reference point (module docstring), and so are the
        columns ``true_Cl, true_Cm, true_Cn`` added when ``df`` has the truth;
        ``coefficients.attrs["moment_reference"]`` says which point: ``point_m`` (x, y, z
        [m], or None for the c.g.) and ``source``.
    thrust_subtracted : bool
        True when thrust was subtracted (the columns, or the thrust model); False when the
        coefficients include thrust (as in the paper).

    Raises
    ------
    FlightDataError
        A needed column or metadata key is missing.
    """
    import pandas as pd  # optional dependency (the 'aero' extra)

    meta = df.attrs if metadata is None else metadata
    for key in ("S", "b", "cbar"):
        if key not in meta:
            raise FlightDataError(f"metadata {key!r} is missing; the coefficients need the "
                                  "reference area S, span b and chord cbar")
    S, b, c = float(meta["S"]), float(meta["b"]), float(meta["cbar"])
    missing = [n for n in _NEEDED if n not in df.columns]
    if missing:
        raise FlightDataError(f"column(s) {missing} needed for the coefficients are missing")
    if accelerations not in ("auto", "measured", "differentiate"):
        raise InputError("accelerations must be 'auto', 'measured' or 'differentiate', got "
                         f"{accelerations!r}")
    have = all(n in df.columns for n in ("pdot", "qdot", "rdot"))
    if accelerations == "measured" and not have:
        raise FlightDataError("accelerations='measured' but column(s) pdot, qdot, rdot are "
                              "missing: use accelerations='differentiate'")
    if accelerations == "differentiate" or (accelerations == "auto" and not have):
        acc = angular_accelerations(df, half_window=half_window, degree=degree)
    else:
        acc = df[["pdot", "qdot", "rdot"]].to_numpy(dtype=float)
    col = {n: df[n].to_numpy(dtype=float) for n in _NEEDED[2:]}
    nan = np.full(len(df), np.nan)
    for n in _ACCELEROMETERS:        # no accelerometers: no force coefficients
        col[n] = df[n].to_numpy(dtype=float) if n in df.columns else nan
    thrust = all(n in df.columns and not df[n].isna().all() for n in THRUST_COLUMNS)
    if thrust:
        T = [df[n].to_numpy(dtype=float) for n in THRUST_COLUMNS]
    elif thrust_model is not None:
        given = thrust_model(df)
        unknown = set(given) - set(THRUST_COLUMNS)
        if unknown:
            raise InputError(f"the thrust model returned unknown key(s) {sorted(unknown)}; "
                             f"allowed: {list(THRUST_COLUMNS)}")
        T = [np.broadcast_to(np.asarray(given.get(n, 0.0), dtype=float), (len(df),))
             for n in THRUST_COLUMNS]
        thrust = True
    else:
        T = [0.0] * 6
    V, m = col["tas"], col["mass"]
    p, q, r = col["p"], col["q"], col["r"]
    pd_, qd, rd = acc[:, 0], acc[:, 1], acc[:, 2]
    Ixx, Iyy, Izz, Ixz = col["Ixx"], col["Iyy"], col["Izz"], col["Ixz"]
    qS = 0.5 * col["rho"] * V * V * S
    coefficients = (
        (m * col["ax"] - T[0]) / qS,
        (m * col["ay"] - T[1]) / qS,
        (m * col["az"] - T[2]) / qS,
        (Ixx * pd_ - (Iyy - Izz) * q * r - Ixz * (rd + p * q) - T[3]) / (qS * b),
        (Iyy * qd - (Izz - Ixx) * r * p - Ixz * (r * r - p * p) - T[4]) / (qS * c),
        (Izz * rd - (Ixx - Iyy) * p * q - Ixz * (pd_ - q * r) - T[5]) / (qS * b),
    )
    rates = (p * b / (2 * V), q * c / (2 * V), r * b / (2 * V))
    out = {**dict(zip(COEFFICIENTS, coefficients)), **dict(zip(RATE_NAMES, rates)),
           "pdot": pd_, "qdot": qd, "rdot": rd}
    reference = {"point_m": None, "source": "the c.g. (no c.g. columns)"}
    if all(n in df.columns for n in CG_COLUMNS):
        cg = df[list(CG_COLUMNS)].to_numpy(dtype=float)
        forces = np.column_stack(coefficients[:3])
        moments = np.column_stack(coefficients[3:])
        usable = np.isfinite(moments).all(axis=1)
        if not np.isfinite(cg[usable]).all():
            raise FlightDataError("the c.g. columns x_cg, y_cg, z_cg hold NaN or inf where "
                                  "the moments are known: fill them (the c.g. moves "
                                  "slowly: interpolate) or drop the columns")
        forced = usable & np.isfinite(forces).all(axis=1)
        if not forced.any():
            reference["source"] = ("the c.g.: NOT transferred to a fixed point (no force "
                                   "coefficients: no accelerometers), so a moving c.g. "
                                   "stays in the moment coefficients")
        else:
            ref, source = _moment_reference(meta, cg[usable])
            arm = cg - ref
            moved = transfer_moments(forces, moments, arm, b, c)   # NaN without forces
            out.update(zip(COEFFICIENTS[3:], moved.T))
            lost = int(np.count_nonzero(usable & ~forced))
            if lost:   # about the c.g. there: one frame or none, never a mix
                source += (f"; {lost} samples without force coefficients (no "
                           "accelerometers there) have no moment coefficients either")
            truth = [f"true_{n}" for n in COEFFICIENTS]
            if all(n in df.columns for n in truth):
                true = df[truth].to_numpy(dtype=float)
                moved = transfer_moments(true[:, :3], true[:, 3:], arm, b, c)
                out.update(zip(truth[3:], moved.T))
            reference = {"point_m": [float(v) for v in ref], "source": source}
    result = pd.DataFrame(out, index=df.index)
    result.attrs["moment_reference"] = reference
    return result, bool(thrust)
