"""Import of a flight-test record into the flight-data schema (``simplexspline import``).

:func:`import_record` reads a mapping file (:mod:`~simplexspline.aero.data.mapping`), reads
the record's channels (:mod:`~simplexspline.aero.data.records`), converts units and signs,
repairs and reports time-stamp glitches and puts every channel on one time base
(:mod:`~simplexspline.aero.data.time_base`), derives what the record lacks (Mach and true
airspeed from calibrated airspeed, density from pressure altitude and temperature:
:mod:`~simplexspline.aero.data.atmosphere`; mass and inertias:
:mod:`~simplexspline.aero.data.mass_properties`; GPS positions from latitude and longitude),
runs the sanity checks (:mod:`~simplexspline.aero.data.sanity`) and cuts the flight into
maneuvers (:mod:`~simplexspline.aero.data.segmentation`). The result is a schema table with
``maneuver``, ``t`` restarting per maneuver, ``maneuver_type`` and ``t_record`` (record time),
and an :class:`ImportResult` that says what was found, missing, derived, repaired and cut.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simplexspline.aero.data import atmosphere, mass_properties, segmentation
from simplexspline.aero.data.flight_data import (
    FLIGHT_DATA_COLUMNS,
    REQUIRED_COLUMNS,
    SCHEMA_VERSION,
    SENSOR_COLUMNS,
)
from simplexspline.aero.data.mapping import AVERAGED, ImportMapping, read_mapping
from simplexspline.aero.data.records import read_channels
from simplexspline.aero.data.sanity import SanityReport, check_record
from simplexspline.aero.data.time_base import (
    clean_time_stamps, common_grid, held_updates, resample,
)
from simplexspline.aero.data.units import conversion
from simplexspline.aero.reconstruction.wind_triangle import MIN_HEADING_CHANGE
from simplexspline.errors import FlightDataError, InputError

__all__ = ["ImportResult", "import_record"]

#: Angles that wrap at +-pi (unwrapped before resampling).
_WRAPPING = ("phi", "psi", "lon")
#: WGS84 semi-major axis [m] and first eccentricity squared (flat-earth GPS positions).
_WGS84_A, _WGS84_E2 = 6378137.0, 6.69437999014e-3
#: Optional columns the summary lists as missing sensors when absent.
_SENSORS = SENSOR_COLUMNS + ("x_gps", "y_gps", "z_gps", "vn_gps", "ve_gps", "vd_gps",
                             "pdot", "qdot", "rdot", "thrust_x")
#: GPS channels: a receiver updates at 1-5 Hz, and a faster recorder holds each fix
#: (:func:`~simplexspline.aero.data.time_base.held_updates`).
_GPS_CHANNELS = ("lat", "lon", "alt_gps", "x_gps", "y_gps", "z_gps", "vn_gps", "ve_gps",
                 "vd_gps")
#: Channels that a working sensor never holds at one value through a whole record (noise,
#: gusts and the flight itself move them): one that does is dead or unconnected, e.g. a
#: heading channel recorded as zeros, and is treated as a channel without data.
_LIVE = ("alpha", "beta", "phi", "theta", "psi", "p", "q", "r", "ax", "ay", "az", "pdot",
         "qdot", "rdot", "tas", "cas", "ias", "h", "temperature", "total_temperature", "lat",
         "lon", "alt_gps", "x_gps", "y_gps", "z_gps", "vn_gps", "ve_gps", "vd_gps", "de", "da",
         "dr")


@dataclass
class ImportResult:
    """An imported record and everything the import did.

    Attributes
    ----------
    data : pandas.DataFrame
        The schema table; metadata in ``data.attrs``.
    metadata : dict
    sanity : SanityReport
    found : list of str
        Mapped channels with data (schema names).
    empty : list of str
        Mapped channels without data (an empty file or all NaN, or a sensor channel constant
        through the whole record: ``constant``).
    constant : dict of str to float
        Sensor channels (:data:`_LIVE`) at one value through the whole record (SI), dead or
        unconnected: they are in ``empty`` and left out of the table.
    missing : list of str
        Sensor columns of the schema neither mapped nor derived.
    derived : dict of str to str
        Column -> how it was derived.
    time_issues : list of TimeIssue
    segment_notes : list of str
    ground_rule : str
    rate_hz : float
        The common time base.
    record_duration_s, airborne_s : float
    """

    data: object
    metadata: dict
    sanity: SanityReport
    found: list = field(default_factory=list)
    empty: list = field(default_factory=list)
    constant: dict = field(default_factory=dict)
    missing: list = field(default_factory=list)
    derived: dict = field(default_factory=dict)
    time_issues: list = field(default_factory=list)
    segment_notes: list = field(default_factory=list)
    ground_rule: str = ""
    rate_hz: float = 0.0
    record_duration_s: float = 0.0
    airborne_s: float = 0.0

    def segments(self) -> list[dict]:
        """One entry per maneuver: id, type, record start [s], duration [s], samples."""
        df = self.data
        out = []
        for m, g in df.groupby("maneuver", sort=True):
            out.append({"maneuver": int(m), "type": str(g["maneuver_type"].iloc[0]),
                        "start_s": float(g["t_record"].iloc[0]),
                        "duration_s": float(g["t"].iloc[-1]), "samples": int(len(g))})
        return out

    def summary(self) -> str:
        """The console summary: channels, missing sensors, derived quantities, segments."""
        lines = [f"record: {self.record_duration_s:.1f} s at {self.rate_hz:g} Hz; airborne "
                 f"{self.airborne_s:.1f} s (ground by {self.ground_rule})",
                 f"channels found ({len(self.found)}): {', '.join(self.found)}"]
        if self.empty:
            lines.append(f"channels without data: {', '.join(self.empty)}")
        if self.constant:
            lines.append("channels at one value through the whole record, a dead or "
                         "unconnected sensor (treated as without data): "
                         + ", ".join(f"{k} = {v:g}" for k, v in self.constant.items()))
        lines.append("missing sensors: " + (", ".join(self.missing) if self.missing
                                             else "none"))
        lines.append("derived:")
        lines += [f"  {k}: {v}" for k, v in self.derived.items()]
        if self.time_issues:
            lines.append(f"time-stamp glitches ({len(self.time_issues)}):")
            lines += [f"  {i.text()}" for i in self.time_issues]
        segs = self.segments()
        total = sum(s["duration_s"] for s in segs)
        lines.append(f"maneuvers: {len(segs)} ({total:.1f} s)")
        for s in segs:
            lines.append(f"  {s['maneuver']:3d} {s['type']:<22} from {s['start_s']:9.2f} s, "
                         f"{s['duration_s']:7.2f} s")
        if self.segment_notes:
            lines.append("segmentation notes:")
            lines += [f"  {n}" for n in self.segment_notes]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """JSON-ready summary (stored in the output's metadata ``import``)."""
        return {"found": self.found, "empty": self.empty, "constant": self.constant,
                "missing": self.missing,
                "derived": self.derived, "rate_hz": self.rate_hz,
                "record_duration_s": self.record_duration_s, "airborne_s": self.airborne_s,
                "ground_rule": self.ground_rule,
                "time_issues": [i.text() for i in self.time_issues],
                "segment_notes": self.segment_notes, "sanity": self.sanity.to_dict()}


def _flat_earth(lat, lon, rows):
    """North and east [m] of a maneuver's samples from its first sample (WGS84 radii)."""
    lat0, lon0 = lat[rows[0]], lon[rows[0]]
    s2 = np.sin(lat0) ** 2
    r_n = _WGS84_A * (1 - _WGS84_E2) / (1 - _WGS84_E2 * s2) ** 1.5
    r_e = _WGS84_A / np.sqrt(1 - _WGS84_E2 * s2)
    dlon = (lon[rows] - lon0 + np.pi) % (2 * np.pi) - np.pi
    return (lat[rows] - lat0) * r_n, dlon * r_e * np.cos(lat0)


def _derive(cols: dict, mapping: ImportMapping, derived: dict) -> None:
    """Fill tas, mach, rho, mass (in place) from what the record has."""
    if "h" not in cols:
        raise InputError(f"{mapping.path}: no pressure altitude: map channel 'h' (the schema "
                         "needs it, and density and Mach are derived from it)")
    h = cols["h"]
    with np.errstate(invalid="ignore"):
        if np.nanmax(np.abs(h)) > atmosphere.CEILING_M:
            raise InputError(f"{mapping.where('h')}: pressure altitude reaches "
                             f"{np.nanmax(h):.6g} m, beyond the ISA model: check its unit "
                             "(feet given as metres?)")
    pressure = atmosphere.isa_pressure(np.where(np.isfinite(h), h, 0.0))
    pressure[~np.isfinite(h)] = np.nan
    speed = "cas" if "cas" in cols else "ias" if "ias" in cols else None
    if "mach" not in cols and speed is not None:
        cols["mach"] = atmosphere.mach_from_cas(cols[speed], pressure)
        which = ("calibrated" if speed == "cas" else
                 "indicated (taken as calibrated: no position-error correction)")
        derived["mach"] = (f"from {which} airspeed and ISA static pressure at the pressure "
                           "altitude")
    if "temperature" in cols:
        temp = cols["temperature"]
        how = "measured static temperature"
    elif "total_temperature" in cols and "mach" in cols:
        temp = atmosphere.static_temperature_from_total(cols["total_temperature"], cols["mach"])
        how = "static temperature from total temperature and Mach (recovery factor 1)"
    else:
        temp = atmosphere.isa_temperature(np.where(np.isfinite(h), h, 0.0))
        temp[~np.isfinite(h)] = np.nan
        how = "ISA standard-day temperature (no temperature channel)"
    if "tas" not in cols:
        if "mach" not in cols:
            raise InputError(f"{mapping.path}: no airspeed: map 'tas', or 'cas' / 'ias' with "
                             "'h' (and 'temperature') to derive it")
        cols["tas"] = cols["mach"] * atmosphere.speed_of_sound(temp)
        derived["tas"] = f"Mach x speed of sound at the {how}"
    elif "mach" not in cols:
        cols["mach"] = cols["tas"] / atmosphere.speed_of_sound(temp)
        derived["mach"] = f"true airspeed / speed of sound at the {how}"
    if "rho" not in cols:
        cols["rho"] = atmosphere.density(pressure, temp)
        derived["rho"] = f"ideal gas: ISA pressure at the pressure altitude, {how}"
    air = mapping.aircraft
    if "mass" not in cols:
        if air.ramp_mass is None:
            raise InputError(f"{mapping.path}: no mass: map a 'mass' channel or give "
                             "[aircraft] ramp_mass (with 'fuel_used' mapped if fuel is burnt)")
        if "fuel_used" in cols:
            cols["mass"] = mass_properties.mass_from_fuel(air.ramp_mass, cols["fuel_used"])
            derived["mass"] = f"ramp mass {air.ramp_mass:.6g} kg - fuel used"
        else:
            cols["mass"] = np.full(h.shape, air.ramp_mass)
            derived["mass"] = (f"constant ramp mass {air.ramp_mass:.6g} kg (no 'fuel_used' "
                               "channel)")


def _inertias(mass: np.ndarray, mapping: ImportMapping, cols: dict, derived: dict) -> dict:
    have = [k for k in mass_properties.INERTIAS if k in cols]
    if len(have) == 4:
        return {}
    air = mapping.aircraft
    if air.radii is not None:
        out = mass_properties.inertias_from_radii(mass, air.radii)
        how = "mass x radii of gyration squared" + ("" if "xz" in air.radii
                                                    else " (Ixz = 0: no 'xz' radius)")
    elif air.inertia_table is not None:
        out = mass_properties.inertias_from_table(mass, air.inertia_table)
        how = "inertia table interpolated in mass" + (
            "" if "Ixz" in air.inertia_table else " (Ixz = 0: not in the table)")
    else:
        need = [k for k in mass_properties.INERTIAS if k not in have]
        raise InputError(f"{mapping.path}: no inertias: give [aircraft] radii_of_gyration or "
                         f"inertia_table, or map {need}")
    derived[", ".join(k for k in mass_properties.INERTIAS if k not in have)] = how
    return {k: v for k, v in out.items() if k not in have}


def import_record(mapping: str | os.PathLike | ImportMapping) -> ImportResult:
    """Import a flight-test record described by a mapping file.

    Parameters
    ----------
    mapping : path-like or ImportMapping
        The TOML mapping file (``docs/import.md``) or its parsed form.

    Returns
    -------
    ImportResult
        ``result.data`` is a schema table ready for
        :func:`~simplexspline.aero.data.flight_data.write_flight_data`.

    Raises
    ------
    InputError
        A mapping problem (naming the file and line), a missing quantity that cannot be
        derived, a unit that makes values impossible.
    FlightDataError
        A record problem: missing file or channel, a clock reset, no usable maneuver.
    """
    import pandas as pd  # optional dependency (the 'aero' extra)

    m = mapping if isinstance(mapping, ImportMapping) else read_mapping(mapping)
    rec = m.record
    time_scale = float(conversion(rec.time_unit, "s")(1.0))
    wanted = {}
    for ch in m.channels.values():
        for source in ch.sources:
            wanted[source] = (ch.rate_hz or rec.rate_hz, m.where(ch.target), ch.time)
    raw = read_channels(rec.format, rec.path, wanted, pattern=rec.pattern, time=rec.time,
                        time_scale=time_scale)
    stamps = [float(r.t[0]) for r in raw.values() if r.timed and r.t.size]
    origin = min(stamps) if stamps else 0.0  # where channels without time stamps start
    clean, empty, issues = {}, [], []
    for target, ch in m.channels.items():
        if any(raw[source].values.size == 0 for source in ch.sources):
            empty.append(target)      # a sum with a term missing is missing
            continue
        parts = []
        for source in ch.sources:
            r = raw[source]
            try:
                values = ch.convert(r.values)
            except ValueError as exc:
                raise InputError(f"{m.where(target)}: cannot convert {source!r}: "
                                 f"{exc}") from None
            t = r.t if r.timed else origin + r.t
            name = target if len(ch.sources) == 1 else f"{target} ({source})"
            if target in _GPS_CHANNELS:   # a GPS fix held at the recorder's rate
                t, values, held = held_updates(name, t, values)
                issues += [held] if held else []
            c = clean_time_stamps(name, t, values, gap_factor=rec.gap_factor)
            issues += c.issues
            parts.append(c)
        clean[target] = parts
    grid = common_grid([c for parts in clean.values() for c in parts], rec.output_rate_hz)
    dt = float(grid[1] - grid[0]) if grid.size > 1 else 1.0
    # several sources (one per engine) are summed on the common time base (the fan speed
    # averaged)
    cols = {k: sum(resample(c, grid, wrap=k in _WRAPPING) for c in parts)
            / (len(parts) if k in AVERAGED else 1) for k, parts in clean.items()}
    constant = {}
    for k in [k for k in _LIVE if k in cols]:
        finite = cols[k][np.isfinite(cols[k])]
        if finite.size > 1 and finite.min() == finite.max():
            constant[k] = float(finite[0])
            empty.append(k)
            del cols[k]
    found = [k for k in m.channels if k in cols]
    derived = {}
    _derive(cols, m, derived)
    seg = m.segments
    airborne, rule = segmentation.airborne_mask(
        grid.size, wow=cols.get("wow"), tas=cols.get("tas"), h=cols.get("h"),
        min_airspeed=seg.min_airspeed, min_height=seg.min_height)
    schema_cols = [k for k in cols if k in FLIGHT_DATA_COLUMNS]
    usable = airborne & np.all([np.isfinite(cols[k]) for k in schema_cols], axis=0)
    sanity = check_record({k: cols[k] for k in schema_cols}, dt, airborne)
    method = seg.method
    if method == "auto":
        method = "list" if seg.list is not None else "excitation"
    notes = []
    if method == "list":
        segments = segmentation.read_maneuver_list(seg.list)
    elif method == "excitation":
        segments, _ = segmentation.detect_excitation(
            grid, cols, usable, threshold=seg.threshold, window_s=seg.window_s,
            pad_s=seg.pad_s, merge_s=seg.merge_s, quiet_s=seg.quiet_s)
        detected = segments
        if seg.turns:
            # the turns observe the wind of a record without heading: each one maneuver
            segments, n_turns = segmentation.absorb_turns(
                segments, segmentation.detect_turns(grid, cols, usable,
                                                    min_change=MIN_HEADING_CHANGE,
                                                    pad_s=seg.pad_s))
            if n_turns:
                notes.append(f"{n_turns} turn(s) cut as maneuvers of type 'turn' (each from "
                             "its roll-in to its roll-out, the maneuvers detected there with "
                             "it: without a heading channel they observe the wind)")
        if seg.steady:
            # the stationary measurements: a vane's calibration and the lift curve
            steady = segmentation.detect_steady(grid, cols, usable, segments)
            if steady:
                notes.append(f"{len(steady)} stationary measurement(s) cut as maneuvers of "
                             "type 'steady' (straight and level at one airspeed for "
                             f"{segmentation.STEADY_MIN_S:g} s or more between the detected "
                             "maneuvers)")
            segments = sorted(segments + steady, key=lambda x: x.start)
    else:
        segments = segmentation.airborne_segments(grid, usable)
    pieces, cut_notes = segmentation.cut(grid, usable, segments,
                                         min_duration_s=seg.min_duration_s)
    # 'auto' judges the detection by the maneuvers it found, without the turns and
    # stationary measurements cut between them
    detections = (len(segmentation.cut(grid, usable, detected,
                                       min_duration_s=seg.min_duration_s)[0])
                  if seg.method == "auto" and method == "excitation" else 2)
    if detections < 2:
        # a record of one maneuver (or of none that stands out): every airborne stretch
        # (the turns and stationary measurements between maneuvers go with it)
        segments = segmentation.airborne_segments(grid, usable)
        notes = [f"method 'auto': excitation detection found {detections} maneuver(s); "
                 "every airborne stretch is one instead"]
        method = "airborne"
        pieces, cut_notes = segmentation.cut(grid, usable, segments,
                                             min_duration_s=seg.min_duration_s)
    if seg.method == "auto":
        notes.insert(0, f"method 'auto': segments by {method}")
    notes += cut_notes
    if not pieces:
        blocking = [k for k in schema_cols if not np.isfinite(cols[k][airborne]).any()]
        if blocking:
            raise FlightDataError(f"no usable maneuver: channel(s) {blocking} have no data in "
                                  "flight (check their time base: do their time stamps overlap "
                                  "the others'?)")
        why = "; ".join(notes[:3]) or "none airborne"
        raise FlightDataError(f"no usable maneuver in the record ({len(segments)} segment(s) "
                              f"found by '{method}'; {why}): check the ground rule, "
                              "dropouts and the segmentation settings")
    rows = np.concatenate([p for p, _ in pieces])
    frame = {"maneuver": np.concatenate([np.full(p.size, i, np.int64)
                                         for i, (p, _) in enumerate(pieces)]),
             "t": np.concatenate([grid[p] - grid[p[0]] for p, _ in pieces])}
    for name in FLIGHT_DATA_COLUMNS:
        if name in cols and name not in frame:
            frame[name] = cols[name][rows]
    if "lat" in cols and "lon" in cols:
        north, east = zip(*(_flat_earth(cols["lat"], cols["lon"], p) for p, _ in pieces))
        frame["x_gps"], frame["y_gps"] = np.concatenate(north), np.concatenate(east)
        derived["x_gps, y_gps"] = ("north, east from latitude and longitude (WGS84 radii at "
                                   "each maneuver's first sample)")
    if "alt_gps" in cols:
        frame["z_gps"] = np.concatenate([-(cols["alt_gps"][p] - cols["alt_gps"][p[0]])
                                         for p, _ in pieces])
        derived["z_gps"] = "down from the GPS altitude at each maneuver's first sample"
    frame.update(_inertias(frame["mass"], m, cols, derived))
    df = pd.DataFrame(frame)
    order = [c for c in FLIGHT_DATA_COLUMNS if c in df.columns]
    df = df[order]
    df["maneuver_type"] = pd.Categorical(np.concatenate([[kind] * p.size for p, kind in pieces]))
    df["t_record"] = grid[rows]
    missing = [c for c in REQUIRED_COLUMNS if c not in df.columns]
    if missing:
        empty_req = [c for c in missing if c in empty]
        if empty_req:
            dead = [f"{k} = {constant[k]:g}" for k in empty_req if k in constant]
            why = (f"; at one value through the whole record: {', '.join(dead)} (a dead or "
                   "unconnected sensor, or the wrong source?)" if dead else "")
            raise FlightDataError(f"required channel(s) {empty_req} are mapped but hold no data "
                                  f"({m.where(empty_req[0])}){why}: the schema needs them")
        raise InputError(f"{m.path}: required column(s) {missing} are neither mapped nor "
                         "derivable: add them to [channels]")
    result = ImportResult(
        data=df, metadata={}, sanity=sanity, found=found, empty=empty, constant=constant,
        missing=[c for c in _SENSORS if c not in df.columns], derived=derived,
        time_issues=issues, segment_notes=notes, ground_rule=rule, rate_hz=round(1.0 / dt, 6),
        record_duration_s=float(grid[-1] - grid[0]), airborne_s=float(airborne.sum() * dt))
    meta = dict(m.metadata)
    if "lat" in cols and "latitude_deg" not in meta:   # for the reconstruction's Earth model
        lat = cols["lat"][rows]
        if np.isfinite(lat).any():
            meta["latitude_deg"] = round(float(np.degrees(np.nanmedian(lat))), 4)
            derived["latitude_deg"] = "metadata: the median GPS latitude of the maneuvers"
    meta.update({"schema": SCHEMA_VERSION, "aircraft": m.aircraft.name, "S": m.aircraft.S,
                 "b": m.aircraft.b, "cbar": m.aircraft.cbar,
                 "source": {"mapping": str(Path(m.path).resolve()), "record": str(rec.path)},
                 "import": result.to_dict()})
    result.metadata = meta
    df.attrs = meta
    return result
