"""Read, validate and write flight data in the simplexspline flight-data schema, version 1.

One table, one row per sample, SI units and radians, body axes (x forward, y right,
z down). The schema is documented column by column in ``docs/flight-data-schema.md``;
:data:`FLIGHT_DATA_COLUMNS` is the same table in code. Files are Parquet (metadata in the
Parquet key-value metadata) or CSV with a JSON sidecar ``<file>.csv.json``.

Validation raises :class:`~simplexspline.errors.FlightDataError` naming the offending
column (missing required columns, wrong unit tags, wrong types, infinities, time not
increasing within a maneuver, values that cannot be in the documented unit). NaN gaps are
reported (:class:`FlightDataReport`, and a :class:`FlightDataWarning` unless
``nan="ignore"``), never interpolated.
"""

from __future__ import annotations

import json
import math
import os
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simplexspline._files import atomic_write, jsonable, write_text
from simplexspline.errors import FlightDataError, InputError

__all__ = [
    "SCHEMA_VERSION",
    "ColumnSpec",
    "FLIGHT_DATA_COLUMNS",
    "REQUIRED_COLUMNS",
    "REQUIRED_METADATA",
    "FlightDataReport",
    "NanGap",
    "FlightDataWarning",
    "SENSOR_COLUMNS",
    "LAG_CHANNELS",
    "SensorGeometry",
    "VaneCalibration",
    "present_columns",
    "sensor_geometry",
    "without_metadata",
    "validate_flight_data",
    "read_flight_data",
    "write_flight_data",
    "sidecar_path",
]

SCHEMA_VERSION = "simplexspline.flightdata/1"


class FlightDataWarning(UserWarning):
    """Flight data that are valid but need attention (e.g. NaN gaps)."""


@dataclass(frozen=True)
class ColumnSpec:
    """One column of the schema.

    Attributes
    ----------
    name : str
    unit : str
        SI unit tag ('-' for dimensionless, '' for labels).
    kind : {'float', 'int', 'str'}
    required : bool
    description : str
        Meaning, frame and sign convention.
    """

    name: str
    unit: str
    kind: str
    required: bool
    description: str


def _spec(rows, required: bool, kind: str = "float") -> dict:
    return {n: ColumnSpec(n, unit, kind, required and n not in SENSOR_COLUMNS, d)
            for n, unit, d in rows}


_ID = [
    ("t", "s", "time since the start of the maneuver, strictly increasing within it"),
    ("alpha", "rad", "angle of attack, atan(w/u) of the air-relative velocity in body axes"),
    ("beta", "rad", "sideslip angle, asin(v/V); positive with the wind from the right"),
    ("tas", "m/s", "true airspeed"),
    ("mach", "-", "Mach number"),
    ("h", "m", "pressure altitude (ISA)"),
    ("rho", "kg/m^3", "air density"),
    ("p", "rad/s", "roll rate about body x (right wing down positive), inertial"),
    ("q", "rad/s", "pitch rate about body y (nose up positive), inertial"),
    ("r", "rad/s", "yaw rate about body z (nose right positive), inertial"),
    ("phi", "rad", "bank angle (Euler 3-2-1, right wing down positive)"),
    ("theta", "rad", "pitch attitude (Euler 3-2-1, nose up positive)"),
    ("psi", "rad", "heading (Euler 3-2-1, from true north, east positive), in [-pi, pi)"),
    ("ax", "m/s^2", ("specific force along body x (non-gravitational force/mass) at the "
                     "c.g., or at metadata sensor_geometry.imu")),
    ("ay", "m/s^2", "specific force along body y at the c.g."),
    ("az", "m/s^2", "specific force along body z at the c.g. (about -g in level flight)"),
    ("de", "rad", "elevator deflection (sign convention in metadata 'sign_conventions')"),
    ("da", "rad", "aileron deflection (sign convention in metadata 'sign_conventions')"),
    ("dr", "rad", "rudder deflection (sign convention in metadata 'sign_conventions')"),
    ("mass", "kg", "aircraft mass"),
    ("Ixx", "kg m^2", "moment of inertia about body x, about the c.g."),
    ("Iyy", "kg m^2", "moment of inertia about body y, about the c.g."),
    ("Izz", "kg m^2", "moment of inertia about body z, about the c.g."),
    ("Ixz", "kg m^2", "product of inertia, sign of the paper's Eq. 46-48 (Ixz = int x z dm)"),
]
_OPT = [
    ("pdot", "rad/s^2", "roll acceleration (body, inertial)"),
    ("qdot", "rad/s^2", "pitch acceleration (body, inertial)"),
    ("rdot", "rad/s^2", "yaw acceleration (body, inertial)"),
    ("thrust_x", "N", "thrust force along body x (removed from the aerodynamic coefficients)"),
    ("thrust_y", "N", "thrust force along body y"),
    ("thrust_z", "N", "thrust force along body z"),
    ("thrust_l", "N m", "thrust rolling moment about the c.g."),
    ("thrust_m", "N m", "thrust pitching moment about the c.g."),
    ("thrust_n", "N m", "thrust yawing moment about the c.g."),
    ("dte", "rad", "elevator trim tab deflection"),
    ("flap", "rad", "flap deflection (for the simulated f16: the leading-edge flap)"),
    ("gear", "-", "landing gear position, 0 up .. 1 down"),
    ("speedbrake", "-", "speedbrake position, 0 retracted .. 1 extended"),
    ("x_gps", "m", "GPS north position from the maneuver's first sample (local flat earth)"),
    ("y_gps", "m", "GPS east position from the maneuver's first sample"),
    ("z_gps", "m", "GPS down position from the maneuver's first sample"),
    ("vn_gps", "m/s", "GPS north velocity (Earth-relative)"),
    ("ve_gps", "m/s", "GPS east velocity"),
    ("vd_gps", "m/s", "GPS down velocity"),
    ("wind_n", "m/s", "wind (air-mass velocity over the Earth) towards north, if estimated"),
    ("wind_e", "m/s", "wind towards east"),
    ("wind_d", "m/s", "wind downwards"),
    ("x_cg", "m", "c.g. position along body x from the sensor-geometry reference point"),
    ("y_cg", "m", "c.g. position along body y from the reference point"),
    ("z_cg", "m", "c.g. position along body z from the reference point"),
    ("n1", "-", "engine fan (low-pressure spool) speed, fraction of 100 % (mean of engines)"),
    ("fuel_flow", "kg/s", "total engine fuel flow"),
]
#: Sensor channels of the identification table that real aircraft may lack (no sideslip
#: vane, no heading, no accelerometers): optional. The reconstruction estimates or flags
#: what they would have given.
SENSOR_COLUMNS: tuple[str, ...] = ("beta", "psi", "ax", "ay", "az")
_TRUE_EXTRA = [
    ("true_qbar", "Pa", "true dynamic pressure 0.5 rho V^2"),
    ("true_CX", "-", "aerodynamic force coefficient along body x, thrust excluded"),
    ("true_CY", "-", "aerodynamic force coefficient along body y, thrust excluded"),
    ("true_CZ", "-", "aerodynamic force coefficient along body z, thrust excluded"),
    ("true_Cl", "-", "aerodynamic rolling-moment coefficient about the c.g. (ref. S b)"),
    ("true_Cm", "-", "aerodynamic pitching-moment coefficient about the c.g. (ref. S cbar)"),
    ("true_Cn", "-", "aerodynamic yawing-moment coefficient about the c.g. (ref. S b)"),
    ("true_CL", "-", "lift coefficient, CX sin(alpha) - CZ cos(alpha)"),
    ("true_CD", "-", "drag coefficient (wind axes), -(CX ca cb + CY sb + CZ sa cb)"),
]
_TRUE_OF = [r for r in _ID + _OPT if r[0] not in
            ("t", "mass", "Ixx", "Iyy", "Izz", "Ixz") and not r[0].startswith("thrust")
            and r[0] not in ("dte", "flap", "gear", "speedbrake", "x_cg", "y_cg", "z_cg",
                             "n1", "fuel_flow")]

#: Every column the schema knows, by name.
FLIGHT_DATA_COLUMNS: dict[str, ColumnSpec] = {
    "maneuver": ColumnSpec("maneuver", "", "int", True,
                           "maneuver id; validation splits are made by maneuver"),
    **_spec(_ID, True),
    **_spec(_OPT, False),
    "condition": ColumnSpec("condition", "", "int", False, "flight-condition id"),
    "maneuver_type": ColumnSpec("maneuver_type", "", "str", False,
                                "e.g. '3211-elevator', 'doublet-rudder', 'sum-of-sines'"),
    **{f"true_{n}": ColumnSpec(f"true_{n}", unit, "float", False, f"true value of '{n}'")
       for n, unit, _ in _TRUE_OF},
    **_spec(_TRUE_EXTRA, False),
}

#: Columns every file must have.
REQUIRED_COLUMNS: tuple[str, ...] = tuple(n for n, s in FLIGHT_DATA_COLUMNS.items()
                                          if s.required)
#: Metadata keys every file must have (S, b, cbar in m^2, m, m).
REQUIRED_METADATA: tuple[str, ...] = ("schema", "aircraft", "S", "b", "cbar")

#: Slack beyond +-2 pi for the wrapped angles phi and psi [rad]: a heading recorded in
#: [0, 2 pi) plus sensor noise lies just above 2 pi when flying north.
_WRAP_SLACK = 0.2

# plausibility bounds of values in the documented unit: (low, high, hint)
_HALF_PI = (-math.pi / 2, math.pi / 2, "radians")
_WRAPPED = (-2 * math.pi - _WRAP_SLACK, 2 * math.pi + _WRAP_SLACK, "radians")
_BOUNDS = {
    "alpha": _HALF_PI, "beta": _HALF_PI, "theta": _HALF_PI, "phi": _WRAPPED, "psi": _WRAPPED,
    "de": _HALF_PI, "da": _HALF_PI, "dr": _HALF_PI,
    "tas": (0.0, math.inf, "m/s"), "rho": (0.0, 5.0, "kg/m^3"), "mass": (0.0, math.inf, "kg"),
    "Ixx": (0.0, math.inf, "kg m^2"), "Iyy": (0.0, math.inf, "kg m^2"),
    "Izz": (0.0, math.inf, "kg m^2"), "mach": (0.0, 10.0, "-"),
}
_POSITIVE = {"tas", "rho", "mass", "Ixx", "Iyy", "Izz"}


@dataclass(frozen=True)
class NanGap:
    """A run of NaN in one column within one maneuver.

    Attributes
    ----------
    column : str
    maneuver : int
    t_start : float
        Time of the first NaN sample [s].
    samples : int
        Length of the run.
    """

    column: str
    maneuver: int
    t_start: float
    samples: int


@dataclass
class FlightDataReport:
    """What validation found.

    Attributes
    ----------
    rows, maneuvers : int
    nan_gaps : list of NanGap
    unknown_columns : list of str
        Columns the schema does not define (kept, not checked).
    empty_columns : list of str
        Optional columns that are entirely NaN: treated as absent (no NaN gaps listed).
    """

    rows: int
    maneuvers: int
    nan_gaps: list = field(default_factory=list)
    unknown_columns: list = field(default_factory=list)
    empty_columns: list = field(default_factory=list)

    def summary(self) -> str:
        """One-paragraph human-readable summary."""
        s = f"{self.rows} rows in {self.maneuvers} maneuvers"
        if self.nan_gaps:
            cols = sorted({g.column for g in self.nan_gaps})
            s += (f"; {len(self.nan_gaps)} NaN gap(s) in column(s) {cols} "
                  f"(first: {self.nan_gaps[0]})")
        if self.empty_columns:
            s += f"; column(s) {self.empty_columns} entirely NaN (treated as absent)"
        return s


def without_metadata(df):
    """``df`` without its metadata: a new frame sharing the columns, with empty ``attrs``.

    pandas deep-copies ``attrs`` into every column and frame it hands out (``df[name]``,
    ``df.loc[...]``, ``df.copy()``). Flight-data metadata are nested lists that grow with
    the maneuvers (a reconstructed 60-maneuver campaign's: ~10 ms per copy), and a check
    or a reconstruction looks up hundreds of columns: validating that campaign took 4.5 s
    of copies, for a check that reads each column once. The metadata travel separately.

    Parameters
    ----------
    df : pandas.DataFrame

    Returns
    -------
    pandas.DataFrame
        The same columns (no data copied), ``attrs == {}``.
    """
    import pandas as pd  # optional dependency (the 'aero' extra)

    plain = pd.DataFrame(df, copy=False)
    plain.attrs = {}
    return plain


def present_columns(df) -> list[str]:
    """Columns of ``df`` that hold data: every column except those entirely NaN.

    A sensor column that is entirely NaN (an empty channel of a real record) counts as
    absent, exactly as if it were missing. Non-numeric columns always count as present.

    Parameters
    ----------
    df : pandas.DataFrame

    Returns
    -------
    list of str
        In the order of ``df.columns``.
    """
    import pandas as pd  # optional dependency (the 'aero' extra)

    out = []
    for name in df.columns:
        col = df[name]
        if (len(col) and pd.api.types.is_float_dtype(col.dtype)
                and np.isnan(col.to_numpy(dtype=float)).all()):
            continue
        out.append(name)
    return out


#: Channels that may carry a time lag in metadata ``sensor_geometry.lag_s``.
LAG_CHANNELS: tuple[str, ...] = (
    "alpha", "beta", "tas", "mach", "h", "rho", "p", "q", "r", "phi", "theta", "psi",
    "ax", "ay", "az", "de", "da", "dr", "x_gps", "y_gps", "z_gps", "vn_gps", "ve_gps",
    "vd_gps")
#: Largest time lag accepted [s]: anything longer is a time-base error, not a sensor lag.
MAX_LAG_S = 2.0
#: Largest sensor distance from the reference point accepted [m] (a unit error beyond).
MAX_ARM_M = 100.0


@dataclass(frozen=True)
class VaneCalibration:
    """Position and calibration of one air-flow vane.

    The vane reads ``scale * angle_at_vane + offset``, where ``angle_at_vane`` is the flow
    angle of the air velocity at the vane, ``V + omega x (r_vane - r_cg)``.

    Attributes
    ----------
    position_m : (3,) tuple of float
        Vane position in body axes (x forward, y right, z down) from the reference point
        [m] (the c.g. when the table has no ``x_cg, y_cg, z_cg`` columns).
    scale : float
        Scale factor (1 for a calibrated vane); positive.
    offset_rad : float
        Offset [rad].
    """

    position_m: tuple = (0.0, 0.0, 0.0)
    scale: float = 1.0
    offset_rad: float = 0.0


@dataclass(frozen=True)
class SensorGeometry:
    """Sensor positions, calibrations and lags from metadata ``sensor_geometry``.

    Attributes
    ----------
    alpha_vane, beta_vane : VaneCalibration
    imu_position_m : (3,) tuple of float
        Accelerometer position in body axes from the reference point [m].
    lag_s : dict of str to float
        Time lag per channel [s]: the recorded value at t is the true one at t - lag.
    given : tuple of str
        The entries the metadata gave (``alpha_vane``, ``beta_vane``, ``imu``, ``lag_s``);
        the others are defaults (at the reference point, calibrated, no lag).
    positions_given : tuple of str
        The vanes (``alpha_vane``, ``beta_vane``) whose ``position_m`` the metadata gave:
        the reconstruction estimates the others' position along x where observable.
    """

    alpha_vane: VaneCalibration = VaneCalibration()
    beta_vane: VaneCalibration = VaneCalibration()
    imu_position_m: tuple = (0.0, 0.0, 0.0)
    lag_s: dict = field(default_factory=dict)
    given: tuple = ()
    positions_given: tuple = ()


def _vector(value, where: str) -> tuple:
    try:
        v = tuple(float(x) for x in value)
    except (TypeError, ValueError):
        v = ()
    if len(v) != 3 or not all(math.isfinite(x) and abs(x) <= MAX_ARM_M for x in v):
        _fail(f"metadata {where} must be three finite numbers [m] (x forward, y right, "
              f"z down from the reference point, each within {MAX_ARM_M:g} m); got {value!r}")
    return v


def _number(value, where: str, *, positive: bool = False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if not math.isfinite(v) or (positive and v <= 0):
        _fail(f"metadata {where} must be a finite{' positive' if positive else ''} number; "
              f"got {value!r}")
    return v


def sensor_geometry(metadata: Mapping) -> SensorGeometry:
    """Parse and check metadata ``sensor_geometry`` (see docs/flight-data-schema.md).

    Parameters
    ----------
    metadata : mapping
        Flight-data metadata; ``sensor_geometry`` is optional::

            {"alpha_vane": {"position_m": [x, y, z], "scale": 1.0, "offset_rad": 0.0},
             "beta_vane": {...}, "imu": {"position_m": [x, y, z]},
             "lag_s": {"alpha": 0.05, "tas": 0.1}}

    Returns
    -------
    SensorGeometry
        Defaults (sensors at the reference point, calibrated, no lags) for what is absent.

    Raises
    ------
    FlightDataError
        An unknown key, a position that is not three numbers within 100 m, a non-positive
        scale, a lag outside 0 .. 2 s or for an unknown channel.
    """
    geo = metadata.get("sensor_geometry", {}) or {}
    if not isinstance(geo, Mapping):
        _fail("metadata 'sensor_geometry' must be a mapping (see docs/flight-data-schema.md)")
    unknown = set(geo) - {"alpha_vane", "beta_vane", "imu", "lag_s"}
    if unknown:
        _fail(f"metadata sensor_geometry has unknown key(s) {sorted(unknown)}; known: "
              "alpha_vane, beta_vane, imu, lag_s")
    vanes = {}
    for name in ("alpha_vane", "beta_vane"):
        entry = geo.get(name, {}) or {}
        if not isinstance(entry, Mapping) or set(entry) - {"position_m", "scale",
                                                            "offset_rad"}:
            _fail(f"metadata sensor_geometry.{name} must be a mapping with keys position_m, "
                  f"scale, offset_rad; got {entry!r}")
        vanes[name] = VaneCalibration(
            _vector(entry.get("position_m", (0, 0, 0)), f"sensor_geometry.{name}.position_m"),
            _number(entry.get("scale", 1.0), f"sensor_geometry.{name}.scale", positive=True),
            _number(entry.get("offset_rad", 0.0), f"sensor_geometry.{name}.offset_rad"))
    imu = geo.get("imu", {}) or {}
    if not isinstance(imu, Mapping) or set(imu) - {"position_m"}:
        _fail(f"metadata sensor_geometry.imu must be a mapping with key position_m; got {imu!r}")
    arm = _vector(imu.get("position_m", (0, 0, 0)), "sensor_geometry.imu.position_m")
    lags = geo.get("lag_s", {}) or {}
    if not isinstance(lags, Mapping):
        _fail("metadata sensor_geometry.lag_s must map channel names to lags [s]")
    lag_s = {}
    for ch, v in lags.items():
        if ch not in LAG_CHANNELS:
            _fail(f"metadata sensor_geometry.lag_s names unknown channel {ch!r}; channels: "
                  f"{list(LAG_CHANNELS)}")
        lag = _number(v, f"sensor_geometry.lag_s.{ch}")
        if not 0 <= lag <= MAX_LAG_S:
            _fail(f"metadata sensor_geometry.lag_s.{ch} = {lag:g} s is outside 0 .. "
                  f"{MAX_LAG_S:g} s: a lag is a delay in seconds (check the unit)")
        lag_s[ch] = lag
    return SensorGeometry(vanes["alpha_vane"], vanes["beta_vane"], arm, lag_s,
                          tuple(k for k in ("alpha_vane", "beta_vane", "imu", "lag_s")
                                if k in geo),
                          tuple(k for k in ("alpha_vane", "beta_vane")
                                if "position_m" in (geo.get(k) or {})))


def _fail(msg: str):
    raise FlightDataError(msg)


def _check_metadata(metadata) -> None:
    if not isinstance(metadata, Mapping):
        _fail("flight-data metadata must be a mapping (dict); got "
              f"{type(metadata).__name__}")
    for key in REQUIRED_METADATA:
        if key not in metadata:
            _fail(f"metadata key {key!r} is missing; the schema requires "
                  f"{list(REQUIRED_METADATA)}")
    if metadata["schema"] != SCHEMA_VERSION:
        _fail(f"metadata 'schema' is {metadata['schema']!r}; this version of simplexspline "
              f"reads {SCHEMA_VERSION!r}")
    for key in ("S", "b", "cbar"):
        try:
            v = float(metadata[key])
        except (TypeError, ValueError):
            v = math.nan
        if not (math.isfinite(v) and v > 0):
            _fail(f"metadata {key!r} must be a positive number (SI: m^2 for S, m for b and "
                  f"cbar); got {metadata[key]!r}")
    units = metadata.get("units", {})
    if not isinstance(units, Mapping):
        _fail("metadata 'units' must map column names to unit strings")
    if "sensor_geometry" in metadata:
        sensor_geometry(metadata)


def _nan_runs(values: np.ndarray, maneuver: np.ndarray, t: np.ndarray, column: str) -> list:
    bad = np.isnan(values)
    if not bad.any():
        return []
    edges = np.diff(np.concatenate(([0], bad.view(np.int8), [0])))
    # a maneuver change also starts a new run
    starts = np.flatnonzero(edges == 1)
    stops = np.flatnonzero(edges == -1)
    gaps = []
    for a, z in zip(starts, stops):
        m = maneuver[a:z]
        cuts = np.flatnonzero(np.diff(m)) + 1
        for s0, s1 in zip(np.r_[0, cuts], np.r_[cuts, z - a]):
            gaps.append(NanGap(column, int(m[s0]), float(t[a + s0]), int(s1 - s0)))
    return gaps


def validate_flight_data(df, metadata: Mapping | None = None, *,
                         nan: str = "warn") -> FlightDataReport:
    """Check a table and its metadata against the schema.

    Parameters
    ----------
    df : pandas.DataFrame
        One row per sample.
    metadata : mapping, optional
        The schema metadata; ``df.attrs`` if None.
    nan : {'warn', 'raise', 'ignore'}
        What to do about NaN gaps (always listed in the report).

    Returns
    -------
    FlightDataReport

    Raises
    ------
    FlightDataError
        Naming the offending column or metadata key.
    """
    import pandas as pd  # optional dependency (the 'aero' extra)

    if nan not in ("warn", "raise", "ignore"):
        raise InputError(f"nan must be 'warn', 'raise' or 'ignore', got {nan!r}")
    if not isinstance(df, pd.DataFrame):
        _fail(f"flight data must be a pandas DataFrame, got {type(df).__name__}")
    metadata = df.attrs if metadata is None else metadata
    _check_metadata(metadata)
    df = without_metadata(df)
    units = metadata.get("units", {})
    missing = [c for c in REQUIRED_COLUMNS if c not in df.columns]
    if missing:
        _fail(f"required column(s) {missing} missing; the schema requires "
              f"{list(REQUIRED_COLUMNS)} (see docs/flight-data-schema.md)")
    for name in df.columns:
        spec = FLIGHT_DATA_COLUMNS.get(name)
        if spec is None:
            continue
        tag = units.get(name)
        if tag is not None and spec.unit and tag != spec.unit:
            _fail(f"column {name!r} has unit {tag!r} in the metadata; the schema requires "
                  f"{spec.unit!r}: convert the data and fix the unit tag")
        col = df[name]
        if spec.kind == "int":
            if not pd.api.types.is_integer_dtype(col.dtype):
                _fail(f"column {name!r} must hold integers, got dtype {col.dtype}")
        elif spec.kind == "str":
            if not (pd.api.types.is_string_dtype(col.dtype)
                    or isinstance(col.dtype, pd.CategoricalDtype)):
                _fail(f"column {name!r} must hold strings, got dtype {col.dtype}")
        else:
            if not (pd.api.types.is_numeric_dtype(col.dtype)
                    and not pd.api.types.is_bool_dtype(col.dtype)):
                _fail(f"column {name!r} must be numeric, got dtype {col.dtype}")
    maneuver = df["maneuver"].to_numpy()
    t = df["t"].to_numpy(dtype=float)
    gaps, empty = [], []
    for name in df.columns:
        spec = FLIGHT_DATA_COLUMNS.get(name)
        if spec is None or spec.kind != "float":
            continue
        x = df[name].to_numpy(dtype=float)
        if np.isinf(x).any():
            row = int(np.flatnonzero(np.isinf(x))[0])
            _fail(f"column {name!r} contains infinite values (first at row {row})")
        if len(x) and np.isnan(x).all() and name != "t":
            if spec.required:
                _fail(f"required column {name!r} is entirely NaN (a column without data "
                      "counts as missing); the schema requires "
                      f"{list(REQUIRED_COLUMNS)} (see docs/flight-data-schema.md)")
            empty.append(name)
            continue
        gaps.extend(_nan_runs(x, maneuver, t, name))
        if name in _BOUNDS and len(x):
            lo, hi, unit = _BOUNDS[name]
            with np.errstate(invalid="ignore"):
                outside = (x <= lo) | (x > hi) if name in _POSITIVE else (x < lo) | (x > hi)
            if outside.any():
                row = int(np.flatnonzero(outside)[0])
                _fail(f"column {name!r} has value {x[row]:.6g} at row {row}, impossible in "
                      f"{unit} (allowed {lo:.4g} .. {hi:.4g}): check its unit")
    if np.isnan(t).any():
        _fail("column 't' contains NaN; time must be known for every sample")
    if len(t) > 1:
        order = np.argsort(maneuver, kind="stable")
        ms, ts = maneuver[order], t[order]
        same = ms[1:] == ms[:-1]
        bad = same & ~(np.diff(ts) > 0)
        if bad.any():
            j = int(np.flatnonzero(bad)[0])
            _fail(f"column 't' is not strictly increasing within maneuver {int(ms[j])} "
                  f"(row {int(order[j + 1])}: t = {ts[j + 1]:.6g} s after {ts[j]:.6g} s)")
    report = FlightDataReport(
        rows=len(df), maneuvers=int(len(np.unique(maneuver))), nan_gaps=gaps,
        unknown_columns=[c for c in df.columns if c not in FLIGHT_DATA_COLUMNS],
        empty_columns=empty)
    if gaps and nan == "raise":
        g = gaps[0]
        _fail(f"column {g.column!r} has {g.samples} NaN sample(s) in maneuver {g.maneuver} "
              f"from t = {g.t_start:.6g} s ({len(gaps)} gap(s) in total); NaN gaps are "
              "never interpolated: remove or repair them")
    if gaps and nan == "warn":
        warnings.warn(f"flight data: {report.summary()}", FlightDataWarning, stacklevel=2)
    return report


def sidecar_path(path: str | os.PathLike) -> Path:
    """The JSON sidecar of a CSV file: ``<file>.csv.json``."""
    p = Path(path)
    return p.with_name(p.name + ".json")


def _format(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix in (".parquet", ".pq"):
        return "parquet"
    if suffix == ".csv":
        return "csv"
    raise InputError(f"unknown flight-data file type {path.suffix!r} for {str(path)!r}: "
                     "use .parquet (preferred) or .csv")


def write_flight_data(df, path: str | os.PathLike, metadata: Mapping | None = None) -> Path:
    """Validate and write flight data atomically (temporary file + ``os.replace``).

    Parameters
    ----------
    df : pandas.DataFrame
    path : path-like
        ``.parquet`` (metadata in the Parquet key-value metadata, one key per metadata
        entry, JSON-encoded values) or ``.csv`` (metadata in ``<file>.csv.json``).
    metadata : mapping, optional
        Schema metadata; ``df.attrs`` if None. ``schema`` is filled in if absent and the
        ``units`` of the schema's columns are added.

    Returns
    -------
    pathlib.Path
        The written data file.
    """
    import pandas as pd  # optional dependency (the 'aero' extra)

    path = Path(path)
    fmt = _format(path)
    meta = dict(df.attrs if metadata is None else metadata)
    meta.setdefault("schema", SCHEMA_VERSION)
    units = dict(meta.get("units", {}))
    for name in df.columns:
        if name in FLIGHT_DATA_COLUMNS and FLIGHT_DATA_COLUMNS[name].unit:
            units.setdefault(name, FLIGHT_DATA_COLUMNS[name].unit)
    meta["units"] = units
    plain = without_metadata(df)
    validate_flight_data(plain, meta, nan="ignore")
    if not path.parent.is_dir():
        raise InputError(f"cannot write {str(path)!r}: directory {str(path.parent)!r} "
                         "does not exist")
    encoded = {k: json.dumps(jsonable(v)) for k, v in meta.items()}
    if fmt == "parquet":
        import pyarrow as pa  # optional dependency (the 'aero' extra)
        import pyarrow.parquet as pq

        table = pa.Table.from_pandas(plain, preserve_index=False)
        kv = dict(table.schema.metadata or {})
        kv.update({k.encode(): v.encode() for k, v in encoded.items()})
        table = table.replace_schema_metadata(kv)
        # dictionary-encode only labels and ids: trying it on float columns costs time
        # and gains nothing for sensor data
        labels = [c for c in plain.columns if not pd.api.types.is_float_dtype(plain[c].dtype)]
        atomic_write(path, lambda tmp: pq.write_table(table, tmp, use_dictionary=labels))
    else:
        atomic_write(path, lambda tmp: plain.to_csv(tmp, index=False, float_format="%.17g"))
        write_text(sidecar_path(path), json.dumps(jsonable(meta), indent=1))
    return path


def read_flight_data(path: str | os.PathLike, *, validate: bool = True,
                     nan: str = "warn"):
    """Read flight data and their metadata.

    Parameters
    ----------
    path : path-like
        A ``.parquet`` file, or a ``.csv`` file with its ``<file>.csv.json`` sidecar.
    validate : bool
        Check the data against the schema (recommended).
    nan : {'warn', 'raise', 'ignore'}
        Handling of NaN gaps (see :func:`validate_flight_data`).

    Returns
    -------
    df : pandas.DataFrame
        The table; ``df.attrs`` holds the metadata too.
    metadata : dict

    Raises
    ------
    FlightDataError
        If the file is missing, unreadable, or not in the schema.
    """
    import pandas as pd  # optional dependency (the 'aero' extra)

    path = Path(path)
    fmt = _format(path)
    if not path.is_file():
        _fail(f"flight-data file {str(path)!r} does not exist")
    if fmt == "parquet":
        import pyarrow.parquet as pq  # optional dependency (the 'aero' extra)

        try:
            table = pq.read_table(path)
        except Exception as exc:  # pyarrow raises several types for corrupt files
            _fail(f"cannot read Parquet file {str(path)!r}: {exc}")
        meta = {}
        for k, v in (table.schema.metadata or {}).items():
            key = k.decode()
            if key == "pandas" or key.startswith("ARROW:"):
                continue
            try:
                meta[key] = json.loads(v)
            except ValueError:
                meta[key] = v.decode(errors="replace")
        df = table.to_pandas()
    else:
        side = sidecar_path(path)
        if not side.is_file():
            _fail(f"CSV flight data need their metadata sidecar {str(side)!r}; it does not "
                  "exist")
        try:
            meta = json.loads(side.read_text())
        except ValueError as exc:
            _fail(f"metadata sidecar {str(side)!r} is not valid JSON: {exc}")
        try:
            df = pd.read_csv(path, engine="pyarrow")
        except Exception as exc:  # pyarrow raises several types for malformed CSV
            _fail(f"cannot read CSV file {str(path)!r}: {exc}")
        for name in df.columns:  # '%.17g' writes integral floats without a decimal point
            spec = FLIGHT_DATA_COLUMNS.get(name)
            if spec is not None and spec.kind == "float" and \
                    pd.api.types.is_integer_dtype(df[name].dtype):
                df[name] = df[name].astype(float)
        if "maneuver_type" in df.columns:
            df["maneuver_type"] = df["maneuver_type"].astype("category")
    if validate:
        validate_flight_data(df, meta, nan=nan)
    df.attrs = dict(meta)
    return df, meta
