"""A simulated campaign written the way a real flight-test record arrives.

:func:`write_channel_record` joins a campaign's maneuvers into one continuous flight (or
takes a whole flight as flown, :mod:`simplexspline.sim.whole_flight`), puts it between two
ground segments, and writes one text file per channel (``time value`` per line, 10 Hz) in
aviation units, with the gaps of a real instrumentation package: no sideslip vane, an empty
heading channel, GPS latitude and longitude only (no GPS velocities), indicated airspeed
and static air temperature instead of true airspeed and density, the normal load factor
instead of the body z specific force, fuel used instead of mass, and the engines' fuel flow
and fan speed N1 (when the campaign holds them) but no thrust. Beside the channels:
``maneuvers.csv`` (start, end, type of every maneuver on the record's clock),
``mapping.toml`` (the mapping file of ``simplexspline import``) and ``truth.csv`` (the
simulator's truth at the same instants, SI units and schema names, for checking an
import).
"""

from __future__ import annotations

import math
import os
import shutil
from pathlib import Path

import numpy as np

from simplexspline._files import write_together
from simplexspline.aero.data.atmosphere import GAMMA, R_AIR, cas_from_mach
from simplexspline.errors import InputError
from simplexspline.sim import units as u

__all__ = ["write_channel_record", "RECORD_CHANNELS"]

#: File name (without .txt) -> (schema column it comes from, unit written, meaning).
RECORD_CHANNELS: dict[str, tuple[str, str, str]] = {
    "vane_aoa": ("alpha", "deg", "angle-of-attack vane"),
    "ias": ("tas", "knot", "indicated (calibrated) airspeed"),
    "hp": ("h", "ft", "pressure altitude"),
    "sat": ("rho", "degC", "static air temperature"),
    "roll_rate": ("p", "deg/s", "body roll rate"),
    "pitch_rate": ("q", "deg/s", "body pitch rate"),
    "yaw_rate": ("r", "deg/s", "body yaw rate"),
    "roll_angle": ("phi", "deg", "bank angle"),
    "pitch_angle": ("theta", "deg", "pitch attitude"),
    "heading": ("psi", "deg", "heading (empty: the channel failed)"),
    "ax_g": ("ax", "g0", "longitudinal specific force"),
    "ay_g": ("ay", "g0", "lateral specific force"),
    "an_g": ("az", "g0", "normal load factor, +1 in level flight (= -az / g0)"),
    "delta_e": ("de", "deg", "elevator"),
    "delta_a": ("da", "deg", "aileron"),
    "delta_r": ("dr", "deg", "rudder"),
    "fuel_used": ("mass", "lb", "fuel used since the start of the record"),
    "fuel_flow": ("fuel_flow", "lb/hour", "fuel flow, all engines"),
    "n1": ("n1", "percent", "fan speed N1, mean of the engines (turbines only)"),
    "gps_lat": ("x_gps", "deg", "GPS latitude"),
    "gps_lon": ("y_gps", "deg", "GPS longitude"),
}
_BLENDED = ("alpha", "tas", "mach", "h", "rho", "p", "q", "r", "phi", "theta", "ax", "ay",
            "az", "de", "da", "dr", "vn_gps", "ve_gps", "mass")
#: Engine channels written when the campaign holds them (older campaigns do not).
_ENGINE = ("fuel_flow", "n1")
_LAT0, _LON0 = math.radians(52.0), math.radians(4.4)
_T0_RECORD = 1000.0  # the recorder's clock does not start at zero


def _air_data(mach, true_tas, true_mach, true_rho):
    """CAS [m/s] of the measured Mach at the true static pressure, and the true static
    temperature [K] (from the true speed of sound; pressure from the gas law)."""
    temp = (true_tas / true_mach) ** 2 / (GAMMA * R_AIR)
    pressure = true_rho * R_AIR * temp
    return cas_from_mach(mach, pressure), temp


def _ground(first: dict, n: int, lowest_m: float) -> dict:
    """``n`` samples taxiing at 8 m/s, 300 m below the lowest altitude of the flight
    ``lowest_m`` (an airfield below every maneuver), wings level."""
    g = {c: np.full(n, v[0]) for c, v in first.items()}
    a_sound = first["true_tas"][0] / first["true_mach"][0]
    h_field = max(0.0, lowest_m - 300.0)
    for prefix in ("", "true_"):
        for c, v in (("tas", 8.0), ("mach", 8.0 / a_sound), ("h", h_field), ("alpha", 0.0),
                     ("p", 0.0), ("q", 0.0), ("r", 0.0), ("phi", 0.0), ("theta", 0.0),
                     ("ax", 0.0), ("ay", 0.0), ("az", -u.G0), ("de", 0.0), ("da", 0.0),
                     ("dr", 0.0), ("vn_gps", 8.0), ("ve_gps", 0.0)):
            if prefix + c in g:
                g[prefix + c] = np.full(n, v)
    return g


#: Segment types of a whole flight (:mod:`simplexspline.sim.whole_flight`) that are not
#: maneuvers: the flying between them.
_NOT_MANEUVERS = ("steady", "turn", "transition")


def _pieces(df, step: int, turns: bool = False):
    """The flight pieces at the output rate, in flight order, with their maneuvers as
    ``(first, last, type, id)`` sample spans inside each piece: a campaign's maneuvers by
    decreasing mass (fuel is burnt), one maneuver each; or a whole flight (metadata
    ``flight``) as one piece holding every maneuver it flew (and its turns, with
    ``turns``)."""
    segments = (df.attrs.get("flight") or {}).get("segments")
    if segments is not None and df["maneuver"].nunique() == 1:
        g = df.iloc[::step]
        t = g["t"].to_numpy(dtype=float)
        spans, k = [], 0
        for seg in segments:
            if seg["type"] in _NOT_MANEUVERS and not (turns and seg["type"] == "turn"):
                continue
            a = int(np.searchsorted(t, seg["start_s"] - 1e-9))
            b = int(np.searchsorted(t, seg["end_s"] + 1e-9)) - 1
            if b > a:
                spans.append((a, b, str(seg["type"]), k))
                k += 1
        return [(g, spans)]
    groups = sorted((g.iloc[::step] for _, g in df.groupby("maneuver", sort=True)),
                    key=lambda g: -float(g["mass"].iloc[0]))
    return [(g, [(0, len(g) - 1, str(g["maneuver_type"].iloc[0]),
                  int(g["maneuver"].iloc[0]))]) for g in groups]


def _gyro_samples(df):
    """A copy of ``df`` with the rates ``p, q, r`` as gyros sampling JSBSim's attitude
    history read them: the mean of steps k - 1 and k, per maneuver (write_channel_record,
    Notes)."""
    out = df.copy()
    out.attrs = df.attrs
    for c in ("p", "q", "r"):
        prev = out.groupby("maneuver", sort=False)[c].shift(1)
        x = out[c].to_numpy(dtype=float)
        out[c] = np.where(prev.isna(), x, 0.5 * (x + prev.to_numpy(dtype=float)))
    return out


def _joined(df, rate_hz: float, transition_s: float, ground_s: float, turns: bool = False):
    """One continuous flight at ``rate_hz``: a ground segment, the flight pieces with
    smooth cosine transitions between them, a ground segment; returns columns, truth
    names, times and the maneuver list."""
    step = int(round(float(df.attrs.get("sample_rate_hz", 100.0)) / rate_hz))
    pieces = _pieces(df, step, turns)
    truth_cols = [c for c in df.columns if c.startswith("true_")]
    n_blend = int(round(transition_s * rate_hz))
    w = 0.5 - 0.5 * np.cos(np.linspace(0.0, math.pi, n_blend + 2)[1:-1])
    names = _BLENDED + tuple(c for c in _ENGINE if c in df.columns) + tuple(truth_cols)
    blocks, spans, start = [], [], 0
    n_ground = int(round(ground_s * rate_hz))
    lowest = min(float(np.nanmin(g["h"].to_numpy(dtype=float))) for g, _ in pieces)
    if n_ground:
        first = {c: pieces[0][0][c].to_numpy(dtype=float) for c in names}
        ground = _ground(first, n_ground, lowest)
        blocks.append(ground)
        blocks.append({c: ground[c][-1] + (first[c][0] - ground[c][-1]) * w for c in names})
        start += n_ground + n_blend
    for i, (g, inner) in enumerate(pieces):
        piece = {c: g[c].to_numpy(dtype=float) for c in names}
        spans += [(start + a, start + b, typ, m) for a, b, typ, m in inner]
        blocks.append(piece)
        start += len(g)
        if i + 1 < len(pieces):
            nxt = pieces[i + 1][0]
            blocks.append({c: piece[c][-1] + (nxt[c].iloc[0] - piece[c][-1]) * w
                           for c in piece})
            start += n_blend
    if n_ground:   # the landing: back on the ground, taxiing in
        last = {c: blocks[-1][c][-1:] for c in names}
        ground = _ground(last, n_ground, lowest)
        blocks.append({c: last[c][0] + (ground[c][0] - last[c][0]) * w for c in names})
        blocks.append(ground)
        start += n_blend + n_ground
    cols = {c: np.concatenate([b[c] for b in blocks]) for c in blocks[0]}
    t = _T0_RECORD + np.arange(start) / rate_hz
    return cols, truth_cols, t, spans


def _position(vn, ve, rate_hz: float):
    """Latitude and longitude [rad] integrated from the north and east velocities, with
    the WGS84 radii where the aircraft is (a sortie flies hundreds of kilometres: with the
    radii of the start, the east distance of a maneuver 3 deg further north came out 7 %
    long, and its GPS ground speed with it)."""
    e2 = 6.69437999014e-3
    north = 0.5 * (vn[1:] + vn[:-1]) / rate_hz          # per step, trapezoid [m]
    east = 0.5 * (ve[1:] + ve[:-1]) / rate_hz
    lat = np.full(len(vn), _LAT0)
    for _ in range(3):      # the meridian radius depends on the latitude it integrates to
        mid = 0.5 * (lat[1:] + lat[:-1])
        r_n = 6378137.0 * (1 - e2) / (1 - e2 * np.sin(mid) ** 2) ** 1.5
        lat = _LAT0 + np.concatenate([[0.0], np.cumsum(north / r_n)])
    mid = 0.5 * (lat[1:] + lat[:-1])
    r_e = 6378137.0 / np.sqrt(1 - e2 * np.sin(mid) ** 2)
    return lat, _LON0 + np.concatenate([[0.0], np.cumsum(east / (r_e * np.cos(mid)))])


def _mapping(meta: dict, rate_hz: float, ramp_kg: float, radii: dict,
             engine: tuple = ()) -> str:
    lines = [
        "# Mapping of a simulated real-format record (simplexspline.sim.record_export) to the",
        "# flight-data schema, for `simplexspline import`. Units are pint strings.",
        "",
        "[record]",
        'format = "channels"',
        'path = "."',
        'pattern = "{source}.txt"',
        f"rate_hz = {rate_hz:g}",
        "",
        "[aircraft]",
        f'name = "{meta.get("aircraft", "simulated")} (simulated real-format record)"',
        f'S = "{meta["S"]:.6g} m^2"',
        f'b = "{meta["b"]:.6g} m"',
        f'cbar = "{meta["cbar"]:.6g} m"',
        f'ramp_mass = "{ramp_kg / u.LB:.6g} lb"',
        "radii_of_gyration = { " + ", ".join(f'{a} = "{radii[a]:.4g} m"' for a in "xyz")
        + " }",
        "",
        "[channels]",
        'alpha = { source = "vane_aoa", unit = "deg" }',
        'ias = { source = "ias", unit = "knot" }',
        'h = { source = "hp", unit = "ft" }',
        'temperature = { source = "sat", unit = "degC" }',
        'p = { source = "roll_rate", unit = "deg/s" }',
        'q = { source = "pitch_rate", unit = "deg/s" }',
        'r = { source = "yaw_rate", unit = "deg/s" }',
        'phi = { source = "roll_angle", unit = "deg" }',
        'theta = { source = "pitch_angle", unit = "deg" }',
        'psi = { source = "heading", unit = "deg" }',
        'ax = { source = "ax_g", unit = "g0" }',
        'ay = { source = "ay_g", unit = "g0" }',
        'az = { source = "an_g", unit = "g0", sign = -1 }',
        'de = { source = "delta_e", unit = "deg" }',
        'da = { source = "delta_a", unit = "deg" }',
        'dr = { source = "delta_r", unit = "deg" }',
        'fuel_used = { source = "fuel_used", unit = "lb" }',
        *(f'{c} = {{ source = "{c}", unit = "{RECORD_CHANNELS[c][1]}" }}' for c in engine),
        'lat = { source = "gps_lat", unit = "deg" }',
        'lon = { source = "gps_lon", unit = "deg" }',
        "",
        "[segments]",
        'method = "list"',
        'list = "maneuvers.csv"',
        "",
    ]
    return "\n".join(lines)


def write_channel_record(df, directory: str | os.PathLike, *, rate_hz: float = 10.0,
                         transition_s: float = 15.0, ground_s: float = 20.0,
                         turns: bool = False) -> Path:
    """Write a campaign as a real-format record: one text file per channel, aviation units.

    Parameters
    ----------
    df : pandas.DataFrame
        A simulated campaign (:meth:`Campaign.run`) or a whole flight
        (:meth:`~simplexspline.sim.whole_flight.WholeFlight.run`): measured and ``true_*``
        columns, the metadata in ``df.attrs``.
    directory : path-like
        A directory that does not exist yet (or is empty); its files are written together
        (all or none, :func:`simplexspline._files.write_together`).
    rate_hz : float
        Output rate [Hz]; must divide the campaign's rate (instantaneous sampling, as a
        recorder without anti-alias filter).
    transition_s : float
        Length of the smooth transition between two maneuvers of a campaign, and between
        the ground and the flight [s] (not a maneuver).
    ground_s : float
        Length of the ground segments (taxiing at 8 m/s, 300 m below the lowest maneuver)
        that start and end the record, as a real flight does [s]; 0 for none.
    turns : bool
        A whole flight's ``maneuvers.csv`` also lists its turns (type ``turn``), as a
        flight-test engineer who logs them does (the real Citation II record's list held
        turns). Without a heading channel they are what observes the wind
        (:func:`~simplexspline.aero.reconstruction.campaign_calibration.campaign_wind`).

    Returns
    -------
    pathlib.Path
        The directory.

    Notes
    -----
    A campaign's maneuvers are joined in order of decreasing mass, so that fuel used
    grows; a whole flight is written as flown, ``maneuvers.csv`` listing the maneuvers of
    its metadata ``flight.segments`` (not its steady flight, turns and climbs). The
    channels carry the campaign's measured values (noise, biases, lags, sensor geometry)
    converted to aviation units: ``ias`` is the calibrated airspeed of the measured Mach
    at the true static pressure; ``sat`` the true static temperature (a probe without
    noise); ``hp`` the measured pressure altitude. There is no sideslip channel, the
    heading file is empty and GPS gives latitude and longitude only (integrated from the
    true ground velocity).

    Rate gyros: JSBSim turns its attitude over each step by the rate at the step's start
    (explicit Euler), so its attitude history is that of a rate half a step later; a gyro
    sampled at ``t_k`` reads, for that history, the mean of the campaign's rates at steps
    k - 1 and k, which is what the record holds. (With the campaign's own rate at ``t_k``
    a 10 Hz record reconstructed with perfect sensors had angle-of-attack errors of up to
    4.6e-4 rad and airspeed errors of 0.26-0.38 m/s, against 0.8e-4 rad and 0.06-0.19 m/s;
    at the campaign's own rate the reconstruction uses the same convention, the Euler
    step.)
    """
    out = Path(directory)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise InputError(f"{str(out)!r} exists and is not an empty directory: a record is "
                         "written into a new directory")
    if not out.parent.is_dir():
        raise InputError(f"directory {str(out.parent)!r} does not exist")
    rate_in = float(df.attrs.get("sample_rate_hz", 100.0))
    ratio = rate_in / float(rate_hz)
    if not (rate_hz > 0 and ratio >= 1 and abs(ratio - round(ratio)) < 1e-9):
        raise InputError(f"rate_hz = {rate_hz!r} must divide the campaign's {rate_in:g} Hz")
    missing = [c for c in _BLENDED + ("true_tas", "true_mach", "true_rho")
               if c not in df.columns]
    if missing or "maneuver_type" not in df.columns:
        raise InputError(f"the table lacks {missing or ['maneuver_type']}: write_channel_record "
                         "needs a simulated campaign with its measured and mass columns")
    if ratio > 1:
        df = _gyro_samples(df)
    cols, truth_cols, t, spans = _joined(df, float(rate_hz), float(transition_s),
                                         float(ground_s), bool(turns))
    cas, temp = _air_data(cols["mach"], cols["true_tas"], cols["true_mach"], cols["true_rho"])
    lat, lon = _position(cols["true_vn_gps"] if "true_vn_gps" in cols else cols["vn_gps"],
                         cols["true_ve_gps"] if "true_ve_gps" in cols else cols["ve_gps"],
                         float(rate_hz))
    ramp = float(np.max(cols["mass"]))
    values = {
        "vane_aoa": np.degrees(cols["alpha"]), "ias": cas / u.KT, "hp": cols["h"] / u.FT,
        "sat": temp - 273.15,
        "roll_rate": np.degrees(cols["p"]), "pitch_rate": np.degrees(cols["q"]),
        "yaw_rate": np.degrees(cols["r"]), "roll_angle": np.degrees(cols["phi"]),
        "pitch_angle": np.degrees(cols["theta"]),
        "ax_g": cols["ax"] / u.G0, "ay_g": cols["ay"] / u.G0, "an_g": -cols["az"] / u.G0,
        "delta_e": np.degrees(cols["de"]), "delta_a": np.degrees(cols["da"]),
        "delta_r": np.degrees(cols["dr"]),
        "fuel_used": (ramp - cols["mass"]) / u.LB,
        "gps_lat": np.degrees(lat), "gps_lon": np.degrees(lon),
    }
    engine = tuple(c for c in _ENGINE if c in cols)
    if "fuel_flow" in cols:
        values["fuel_flow"] = cols["fuel_flow"] / u.LB * 3600.0
    if "n1" in cols:
        values["n1"] = cols["n1"] * 100.0
    first = df.groupby("maneuver").head(1)
    radii = {a: float(np.sqrt((first[f"I{a * 2}"] / first["mass"]).mean())) for a in "xyz"}
    files = {}
    for name, v in values.items():
        body = "\n".join(f"{a:.2f} {b:.8g}" for a, b in zip(t, v))
        files[f"{name}.txt"] = f"time {name}\n{body}\n"
    files["heading.txt"] = ""  # the channel exists but failed
    files["maneuvers.csv"] = "start,end,type,maneuver\n" + "".join(
        f"{t[a]:.2f},{t[b]:.2f},{typ},{m}\n" for a, b, typ, m in spans)
    files["mapping.toml"] = _mapping(df.attrs, float(rate_hz), ramp, radii, engine)
    stacked = np.column_stack([t] + [cols[c] for c in truth_cols] + [cols["mass"]])
    files["truth.csv"] = "\n".join(
        ["t_record," + ",".join(c[5:] for c in truth_cols) + ",mass"]
        + [",".join(f"{x:.10g}" for x in row) for row in stacked]) + "\n"
    created = not out.exists()
    out.mkdir(exist_ok=True)
    try:
        write_together({out / name: text.encode("utf-8") for name, text in files.items()})
    except BaseException:
        if created:
            shutil.rmtree(out, ignore_errors=True)
        raise
    return out
