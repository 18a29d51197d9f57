"""The mapping file of an import: which source channel is which schema column, in what unit.

A TOML file (``docs/import.md`` documents every key) with four tables:

``[record]``
    Where the data are and how they are stored: ``format`` ('channels': one text file per
    channel; 'csv'; 'mat'; 'parquet'), ``path`` (relative to the mapping file), the time
    channel or the sample rate, and the output rate.
``[aircraft]``
    Name, reference geometry ``S``, ``b``, ``cbar`` and the mass properties (ramp mass;
    radii of gyration or an inertia table over mass), every value with its unit.
``[channels]``
    One entry per schema column (or auxiliary input such as ``cas``, ``temperature``,
    ``fuel_used``, ``lat``, ``lon``, ``wow``): ``source`` (file stem or column name; for
    fuel used and thrust a list of them, summed: one per engine),
    ``unit`` (a pint unit string), optional ``sign`` (+1/-1), ``offset`` (in the source unit,
    subtracted before the conversion), ``rate_hz`` or ``time`` (the channel's own time base).
``[segments]`` and ``[metadata]``
    How a continuous flight is cut into maneuvers; metadata passed through to the schema
    (sensor geometry, time lags, calibrations: whatever keys the schema defines).

Every problem raises :class:`~simplexspline.errors.InputError` naming the mapping file, the
line and what to write instead.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simplexspline.aero.data.flight_data import FLIGHT_DATA_COLUMNS
from simplexspline.aero.data.units import UnitError, conversion, quantity
from simplexspline.errors import InputError

__all__ = ["AUXILIARY_CHANNELS", "AVERAGED", "FORMATS", "SEGMENT_METHODS", "SUMMABLE", "ChannelMap",
           "AircraftSpec", "RecordSpec", "SegmentSpec", "ImportMapping", "read_mapping",
           "MappingError"]


class MappingError(InputError):
    """A mapping file that cannot be used (the message names the file and line)."""


#: Inputs that are not schema columns but from which schema columns are derived: name ->
#: (SI unit, meaning).
AUXILIARY_CHANNELS: dict[str, tuple[str, str]] = {
    "cas": ("m/s", "calibrated airspeed (-> mach, tas)"),
    "ias": ("m/s", "indicated airspeed, used as calibrated when no cas (-> mach, tas)"),
    "temperature": ("K", "static air temperature (-> rho, tas)"),
    "total_temperature": ("K", "total air temperature (-> static temperature with mach)"),
    "fuel_used": ("kg", "fuel used since the ramp mass was weighed (-> mass)"),
    "lat": ("rad", "GPS latitude (-> x_gps)"),
    "lon": ("rad", "GPS longitude (-> y_gps)"),
    "alt_gps": ("m", "GPS altitude above the ellipsoid or MSL (-> z_gps)"),
    "wow": ("-", "weight on wheels, 1 on the ground (-> ground segments dropped)"),
}
#: Schema columns a mapping may fill from a channel (labels and truth columns excluded).
_TARGETS = {n: s.unit for n, s in FLIGHT_DATA_COLUMNS.items()
            if s.kind == "float" and not n.startswith("true_") and n != "t"}
#: Columns that may be the sum of several channels (one per engine).
SUMMABLE = ("fuel_used", "fuel_flow", "thrust_x", "thrust_y", "thrust_z", "thrust_l",
            "thrust_m", "thrust_n")
#: Columns that may be the mean of several channels (one per engine).
AVERAGED = ("n1",)
FORMATS = ("channels", "csv", "mat", "parquet")
SEGMENT_METHODS = ("auto", "list", "excitation", "airborne")


@dataclass(frozen=True)
class ChannelMap:
    """One entry of ``[channels]``.

    Attributes
    ----------
    target : str
        Schema column or auxiliary input.
    source : str
        Channel name in the record (file stem or column); ``sources`` when several.
    sources : tuple of str
        The record's channels whose converted values are summed into the target (one
        per engine for fuel used or fuel flow, for example; averaged for the fan speed
        ``n1``); ``(source,)`` for a single channel.
    unit : str
        Pint unit string of the source.
    sign : float
        +1 or -1, applied after the conversion.
    offset : float
        Subtracted from the raw values, in the source unit, before the conversion.
    rate_hz : float or None
        Sample rate of a channel stored without time stamps (overrides the record's).
    time : str or None
        Name of the channel holding this channel's time stamps (overrides the record's).
    line : int
        Line of the entry in the mapping file (for messages).
    """

    target: str
    source: str
    unit: str
    sign: float = 1.0
    offset: float = 0.0
    rate_hz: float | None = None
    time: str | None = None
    line: int = 0
    sources: tuple = ()

    def __post_init__(self):
        if not self.sources:
            object.__setattr__(self, "sources", (self.source,))

    @property
    def si_unit(self) -> str:
        """The unit the target column is stored in."""
        if self.target in AUXILIARY_CHANNELS:
            return AUXILIARY_CHANNELS[self.target][0]
        return _TARGETS[self.target]

    def convert(self, raw):
        """Raw values (array_like) -> the target's SI unit, sign and offset applied."""
        raw = np.asarray(raw, dtype=float)
        return self.sign * conversion(self.unit, self.si_unit)(raw - self.offset)


@dataclass(frozen=True)
class AircraftSpec:
    """``[aircraft]``: reference geometry [m^2, m, m] and mass properties (SI).

    Attributes
    ----------
    name : str
    S, b, cbar : float
    ramp_mass : float or None
        Mass at the start of the record [kg] (fuel used is subtracted).
    radii : dict or None
        Radii of gyration {'x', 'y', 'z'} [m] and optionally a signed 'xz' [m]
        (Ixz = sign(xz) m xz^2).
    inertia_table : dict or None
        {'mass': [...], 'Ixx': [...], 'Iyy': [...], 'Izz': [...], 'Ixz': [...]} in SI,
        mass strictly increasing.
    """

    name: str
    S: float
    b: float
    cbar: float
    ramp_mass: float | None = None
    radii: dict | None = None
    inertia_table: dict | None = None


@dataclass(frozen=True)
class RecordSpec:
    """``[record]``: where the data are and their time base.

    Attributes
    ----------
    format : {'channels', 'csv', 'mat', 'parquet'}
    path : Path
        Directory of channel files, or the file.
    pattern : str
        File name of a channel in a 'channels' directory; ``{source}`` is replaced.
    time : str or None
        Time channel (column) of csv/mat/parquet records; for 'channels' records files with
        two columns hold their own time stamps.
    time_unit : str
    rate_hz : float or None
        Sample rate of channels without time stamps.
    output_rate_hz : float or None
        Rate of the common time base (default: the fastest channel's).
    gap_factor : float
        A time step longer than this many nominal steps is a dropout.
    """

    format: str
    path: Path
    pattern: str = "{source}.txt"
    time: str | None = "time"
    time_unit: str = "s"
    rate_hz: float | None = None
    output_rate_hz: float | None = None
    gap_factor: float = 2.5


@dataclass(frozen=True)
class SegmentSpec:
    """``[segments]``: how a continuous flight becomes maneuvers.

    Attributes
    ----------
    method : {'auto', 'list', 'excitation', 'airborne'}
        A maneuver time list; detection of control/rate activity; or every airborne stretch
        as one maneuver. 'auto' (the default): the list when one is given, else detection,
        else (when detection finds fewer than two maneuvers: a record of one maneuver) every
        airborne stretch.
    list : Path or None
        CSV (columns start, end, type) or TOML (``[[maneuver]]`` start, end, type) in record
        time [s].
    threshold : float
        Excitation: activity above ``threshold`` times the quiet level around it.
    window_s, pad_s, merge_s, min_duration_s : float
        Activity window, padding before/after, merging of nearby maneuvers, shortest kept.
    quiet_s : float
        Excitation: window of the running quiet level (0: one level for the record).
    turns : bool
        Excitation: the turns that no detected maneuver overlaps become maneuvers too
        (type ``turn``, :func:`~simplexspline.aero.data.segmentation.detect_turns`):
        without a heading channel they are what observes the wind. Default true.
    steady : bool
        Excitation: the stationary measurements between the maneuvers and turns become
        maneuvers too (type ``steady``, straight and level at one airspeed for 30 s or more,
        :func:`~simplexspline.aero.data.segmentation.detect_steady`): they tell a vane's
        offset from its scale error and trace the lift curve. Default true.
    min_airspeed : float
        Without a weight-on-wheels channel, samples slower than this [m/s] are ground.
    min_height : float
        ... or lower than this [m] above the lowest altitude of the record.
    """

    method: str = "auto"
    list: Path | None = None
    threshold: float = 30.0
    window_s: float = 1.0
    pad_s: float = 2.0
    merge_s: float = 8.0
    min_duration_s: float = 5.0
    quiet_s: float = 300.0
    turns: bool = True
    steady: bool = True
    min_airspeed: float = 25.0
    min_height: float = 15.0


@dataclass(frozen=True)
class ImportMapping:
    """A parsed mapping file.

    Attributes
    ----------
    path : Path
    record : RecordSpec
    aircraft : AircraftSpec
    channels : dict of str to ChannelMap
        By target.
    segments : SegmentSpec
    metadata : dict
        Passed through into the output's schema metadata.
    """

    path: Path
    record: RecordSpec
    aircraft: AircraftSpec
    channels: dict
    segments: SegmentSpec = field(default_factory=SegmentSpec)
    metadata: dict = field(default_factory=dict)

    def where(self, target: str) -> str:
        """'file line N' of a channel entry, for messages."""
        ch = self.channels.get(target)
        return f"{self.path} line {ch.line}" if ch is not None else str(self.path)


def _line(text: str, section: str, key: str | None = None) -> int:
    """1-based line of ``[section]`` / ``[section.key]`` / ``key =`` inside the section."""
    lines = text.splitlines()
    head = re.compile(r"^\s*\[\s*" + re.escape(section) + r"\s*\]")
    if key is not None:
        sub = re.compile(r"^\s*\[\s*" + re.escape(section) + r"\s*\.\s*\"?"
                         + re.escape(key) + r"\"?\s*\]")
        for i, ln in enumerate(lines):
            if sub.match(ln):
                return i + 1
    start = next((i for i, ln in enumerate(lines) if head.match(ln)), None)
    if start is None:
        return 0
    if key is None:
        return start + 1
    item = re.compile(r"^\s*\"?" + re.escape(key) + r"\"?\s*[=.]")
    for i in range(start + 1, len(lines)):
        if re.match(r"^\s*\[", lines[i]):
            break
        if item.match(lines[i]):
            return i + 1
    return start + 1


class _Reader:
    """Typed access to one table of the TOML file with messages naming the line."""

    def __init__(self, path: Path, text: str, section: str, table, line: int | None = None):
        self.path, self.text, self.section, self.line = path, text, section, line
        if not isinstance(table, dict):
            self.fail(None, f"[{section}] must be a table")
        self.table = table

    def fail(self, key, msg: str):
        line = self.line if self.line is not None else _line(self.text, self.section, key)
        where = f"{self.section}.{key}" if key else f"[{self.section}]"
        raise MappingError(f"{self.path} line {line} ({where}): {msg}")

    def unknown(self, allowed):
        extra = sorted(set(self.table) - set(allowed))
        if extra:
            self.fail(extra[0], f"unknown key {extra[0]!r}; [{self.section}] knows "
                      f"{sorted(allowed)}")

    def str(self, key, default=None, choices=None):
        v = self.table.get(key, default)
        if v is None:
            return None
        if not isinstance(v, str) or not v:
            self.fail(key, f"must be a non-empty string, got {v!r}")
        if choices is not None and v not in choices:
            self.fail(key, f"must be one of {list(choices)}, got {v!r}")
        return v

    def number(self, key, default=None, *, positive=True):
        v = self.table.get(key, default)
        if v is None:
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                or (positive and v <= 0):
            self.fail(key, f"must be a {'positive ' if positive else ''}finite number, "
                      f"got {v!r}")
        return float(v)

    def quantity(self, key, target, required=False):
        v = self.table.get(key)
        if v is None:
            if required:
                self.fail(None, f"{key!r} is missing: give it with its unit, e.g. "
                          f"{key} = \"... {target}\"")
            return None
        try:
            value = quantity(v, target)
        except UnitError as exc:
            self.fail(key, str(exc))
        if value <= 0:
            self.fail(key, f"must be positive, got {v!r}")
        return value


def _aircraft(r: _Reader) -> AircraftSpec:
    r.unknown({"name", "S", "b", "cbar", "ramp_mass", "radii_of_gyration", "inertia_table"})
    name = r.str("name", "unnamed aircraft")
    radii = None
    if "radii_of_gyration" in r.table:
        rr = _Reader(r.path, r.text, "aircraft.radii_of_gyration",
                     r.table["radii_of_gyration"])
        rr.unknown({"x", "y", "z", "xz"})
        radii = {k: rr.quantity(k, "m", required=True) for k in ("x", "y", "z")}
        if "xz" in rr.table:
            v = rr.table["xz"]
            sign = -1.0 if isinstance(v, str) and v.strip().startswith("-") else 1.0
            try:
                radii["xz"] = sign * quantity(v.strip().lstrip("-") if isinstance(v, str)
                                              else v, "m")
            except UnitError as exc:
                rr.fail("xz", str(exc))
    table = None
    if "inertia_table" in r.table:
        tr = _Reader(r.path, r.text, "aircraft.inertia_table", r.table["inertia_table"])
        tr.unknown({"mass", "Ixx", "Iyy", "Izz", "Ixz", "mass_unit", "inertia_unit"})
        mu = tr.str("mass_unit", "kg")
        iu = tr.str("inertia_unit", "kg*m^2")
        table = {}
        for key, unit, target in (("mass", mu, "kg"), ("Ixx", iu, "kg*m^2"),
                                  ("Iyy", iu, "kg*m^2"), ("Izz", iu, "kg*m^2"),
                                  ("Ixz", iu, "kg*m^2")):
            v = tr.table.get(key)
            if v is None and key == "Ixz":
                continue
            if not isinstance(v, list) or len(v) < 1 or not all(
                    isinstance(x, (int, float)) and not isinstance(x, bool)
                    and math.isfinite(x) for x in v):
                tr.fail(key if v is not None else None,
                        f"{key!r} must be a list of numbers (in {unit!r})")
            try:
                table[key] = conversion(unit, target)(v).tolist()
            except UnitError as exc:
                tr.fail("mass_unit" if key == "mass" else "inertia_unit", str(exc))
        n = len(table["mass"])
        if any(len(v) != n for v in table.values()):
            tr.fail(None, "'mass' and the inertia lists must have the same length")
        if any(b <= a for a, b in zip(table["mass"], table["mass"][1:])):
            tr.fail("mass", "masses must be strictly increasing")
    if radii is not None and table is not None:
        r.fail("inertia_table", "give either radii_of_gyration or inertia_table, not both")
    return AircraftSpec(name=name, S=r.quantity("S", "m^2", True), b=r.quantity("b", "m", True),
                        cbar=r.quantity("cbar", "m", True),
                        ramp_mass=r.quantity("ramp_mass", "kg"), radii=radii,
                        inertia_table=table)


def _record(r: _Reader, base: Path) -> RecordSpec:
    r.unknown({"format", "path", "pattern", "time", "time_unit", "rate_hz", "output_rate_hz",
               "gap_factor"})
    fmt = r.str("format", choices=FORMATS)
    if fmt is None:
        r.fail(None, f"'format' is missing: one of {list(FORMATS)}")
    p = r.str("path")
    if p is None:
        r.fail(None, "'path' is missing: the channel directory or the data file")
    pattern = r.str("pattern", "{source}.txt")
    if "{source}" not in pattern:
        r.fail("pattern", "must contain '{source}' (the channel's name)")
    time_unit = r.str("time_unit", "s")
    try:
        conversion(time_unit, "s")
    except UnitError as exc:
        r.fail("time_unit", str(exc))
    gap = r.number("gap_factor", 2.5)
    if gap <= 1:
        r.fail("gap_factor", f"must be > 1 (steps longer than gap_factor nominal steps are "
               f"dropouts), got {gap}")
    return RecordSpec(format=fmt, path=(base / p).resolve(), pattern=pattern,
                      time=r.str("time", "time" if fmt != "channels" else None),
                      time_unit=time_unit, rate_hz=r.number("rate_hz"),
                      output_rate_hz=r.number("output_rate_hz"), gap_factor=gap)


def _channel(path: Path, text: str, target: str, entry) -> ChannelMap:
    line = _line(text, "channels", target)
    if target not in _TARGETS and target not in AUXILIARY_CHANNELS:
        known = sorted(set(_TARGETS) | set(AUXILIARY_CHANNELS))
        raise MappingError(f"{path} line {line} (channels.{target}): unknown column "
                           f"{target!r}; a channel maps to a schema column or an auxiliary "
                           f"input: {known}")
    if isinstance(entry, str):
        entry = {"source": entry}
    if not isinstance(entry, dict):
        raise MappingError(f"{path} line {line} (channels.{target}): must be a table "
                           "{ source = ..., unit = ... }")
    r = _Reader(path, text, f"channels.{target}", entry, line=line)
    r.unknown({"source", "unit", "sign", "offset", "rate_hz", "time"})
    many = entry.get("source")
    if isinstance(many, list):
        if not many or not all(isinstance(x, str) and x for x in many) \
                or len(set(many)) != len(many):
            r.fail("source", f"must be a channel name or a list of distinct channel names "
                   f"(summed, e.g. fuel used per engine), got {many!r}")
        if target not in SUMMABLE + AVERAGED:
            r.fail("source", f"{target!r} cannot be a sum of channels; a list of sources "
                   f"(one per engine) is summed for {', '.join(SUMMABLE)} and averaged "
                   f"for {', '.join(AVERAGED)}")
        sources = tuple(many)
        source = " + ".join(sources)
    else:
        source = r.str("source", target)
        sources = (source,)
    unit = r.str("unit")
    si = AUXILIARY_CHANNELS[target][0] if target in AUXILIARY_CHANNELS else _TARGETS[target]
    if unit is None:
        r.fail(None, f"'unit' is missing: the unit of {source!r} (pint string, e.g. "
               f"{'deg' if si.startswith('rad') else si!r}); the schema stores {si!r}")
    try:
        conversion(unit, si)
    except UnitError as exc:
        r.fail("unit", f"{exc} (column {target!r} is stored in {si!r})")
    sign = r.number("sign", 1.0, positive=False)
    if sign not in (1.0, -1.0):
        r.fail("sign", f"must be 1 or -1, got {entry['sign']!r}")
    return ChannelMap(target=target, source=source, unit=unit, sign=sign,
                      offset=r.number("offset", 0.0, positive=False),
                      rate_hz=r.number("rate_hz"), time=r.str("time"), line=line,
                      sources=sources)


def _segments(r: _Reader, base: Path) -> SegmentSpec:
    fields = {"threshold", "window_s", "merge_s", "min_duration_s"}
    r.unknown({"method", "list", "pad_s", "quiet_s", "turns", "steady", "min_airspeed",
               "min_height"} | fields)
    method = r.str("method", "auto", choices=SEGMENT_METHODS)
    lst = r.str("list")
    if method == "list" and lst is None:
        r.fail("method", "method 'list' needs list = \"maneuvers.csv\" (start, end, type)")
    kw = {k: r.number(k) for k in fields if k in r.table}
    kw["pad_s"] = r.number("pad_s", 2.0, positive=False)
    kw["quiet_s"] = r.number("quiet_s", 300.0, positive=False)
    if kw["quiet_s"] < 0:
        r.fail("quiet_s", "must be a finite number of seconds >= 0 (0: one quiet level for "
                          f"the whole record), got {kw['quiet_s']:g}")
    for flag in ("turns", "steady"):
        value = r.table.get(flag, True)
        if not isinstance(value, bool):
            r.fail(flag, f"must be true or false, got {value!r}")
        kw[flag] = value
    if "min_airspeed" in r.table:
        kw["min_airspeed"] = r.quantity("min_airspeed", "m/s")
    if "min_height" in r.table:
        kw["min_height"] = r.quantity("min_height", "m")
    return SegmentSpec(method=method, list=(base / lst).resolve() if lst else None, **kw)


def read_mapping(path: str | os.PathLike) -> ImportMapping:
    """Read and check a mapping file.

    Parameters
    ----------
    path : path-like
        The TOML mapping file; relative paths inside it are relative to its directory.

    Returns
    -------
    ImportMapping

    Raises
    ------
    MappingError
        Naming the file, the line and the problem (unknown key, column or unit, a value
        without a unit, a wrong sign).
    """
    try:
        import tomllib
    except ModuleNotFoundError:  # Python < 3.11: the 'aero' extra installs tomli
        import tomli as tomllib

    path = Path(path)
    if not path.is_file():
        raise MappingError(f"mapping file {str(path)!r} does not exist")
    text = path.read_text(encoding="utf-8")
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise MappingError(f"{path}: not valid TOML: {exc}") from None
    allowed = {"record", "aircraft", "channels", "segments", "metadata"}
    extra = sorted(set(doc) - allowed)
    if extra:
        raise MappingError(f"{path} line {_line(text, extra[0])}: unknown table "
                           f"[{extra[0]}]; a mapping has {sorted(allowed)}")
    for need in ("record", "aircraft", "channels"):
        if need not in doc:
            raise MappingError(f"{path}: table [{need}] is missing (see docs/import.md)")
    base = path.resolve().parent
    record = _record(_Reader(path, text, "record", doc["record"]), base)
    aircraft = _aircraft(_Reader(path, text, "aircraft", doc["aircraft"]))
    if not isinstance(doc["channels"], dict) or not doc["channels"]:
        raise MappingError(f"{path} line {_line(text, 'channels')}: [channels] is empty")
    channels = {t: _channel(path, text, t, e) for t, e in doc["channels"].items()}
    segments = _segments(_Reader(path, text, "segments", doc.get("segments", {})), base)
    metadata = doc.get("metadata", {})
    if not isinstance(metadata, dict):
        raise MappingError(f"{path}: [metadata] must be a table")
    clash = sorted(set(metadata) & {"schema", "aircraft", "S", "b", "cbar", "units"})
    if clash:
        raise MappingError(f"{path} line {_line(text, 'metadata', clash[0])} "
                           f"(metadata.{clash[0]}): set by the import from [aircraft]; "
                           "remove it from [metadata]")
    return ImportMapping(path=path, record=record, aircraft=aircraft, channels=channels,
                         segments=segments, metadata=dict(metadata))
