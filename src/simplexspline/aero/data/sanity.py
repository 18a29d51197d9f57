"""Sanity checks of an imported record: signs, units and calibration against kinematics.

A wrong sign or unit in a mapping file is cheap to catch at import and expensive to find in a
bad model. :func:`check_record` compares the channels with what kinematics say they must be
and names the channel that disagrees:

* **rate signs**: d(phi)/dt against ``p + tan(theta) (q sin(phi) + r cos(phi))``, d(theta)/dt
  against ``q cos(phi) - r sin(phi)``, d(psi)/dt (or the GPS track rate when there is no
  heading) against ``(q sin(phi) + r cos(phi)) / cos(theta)``, or, with neither, r in turns
  (bank beyond 10 deg) against the coordinated-turn rate ``g sin(phi) cos(theta) / V``; a
  strong negative correlation names the rate ('p', 'q', 'r') as sign-inverted.
* **specific force**: the accelerometers rotated to north-east-down against the GPS
  accelerations ``d(v_gps)/dt - g`` (only the down component when there is no heading); a
  channel whose flipped sign halves the RMS difference (of more than 0.05 m/s^2; 1 m/s^2
  for the mean) is named. Without GPS velocities only the mean
  of the down component is checked (about -g).
* **angle of attack**: in steady wings-level flight alpha is about theta - gamma (still air);
  the mean difference (a vane offset, or wind) and an inverted sign are reported.
* **units**: angles that look like degrees, rates like deg/s, altitudes like feet,
  accelerations in g.

Everything works on one continuous time base with NaN where data are missing; samples on the
ground should be masked out by the caller.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from simplexspline.aero.reconstruction.kinematics import euler_rates

__all__ = ["SanityCheck", "SanityReport", "check_record", "G0"]

G0 = 9.80665
_STATUS = ("ok", "warning", "failed", "skipped")
#: Correlation beyond which a sign is called inverted (negative) or confirmed (positive).
_CORR = 0.5
#: Fewest samples banked beyond 10 deg for the turn-coordination check of r.
_MIN_BANKED = 100


@dataclass(frozen=True)
class SanityCheck:
    """One check.

    Attributes
    ----------
    name : str
        e.g. 'rate sign p', 'specific force', 'alpha vs theta - gamma', 'units alpha'.
    status : {'ok', 'warning', 'failed', 'skipped'}
        'failed' for a sign error, 'warning' for something to look at.
    message : str
    channel : str or None
        The channel blamed (for 'failed' and 'warning').
    value : float or None
        The statistic (a correlation, an RMS difference [m/s^2], an offset [rad], ...).
    """

    name: str
    status: str
    message: str
    channel: str | None = None
    value: float | None = None


@dataclass
class SanityReport:
    """All checks of a record.

    Attributes
    ----------
    checks : list of SanityCheck
    """

    checks: list = field(default_factory=list)

    @property
    def problems(self) -> list:
        """Checks that failed or warn."""
        return [c for c in self.checks if c.status in ("failed", "warning")]

    def failed(self, channel: str | None = None) -> list:
        """Failed checks (of one channel if given)."""
        return [c for c in self.checks if c.status == "failed"
                and (channel is None or c.channel == channel)]

    def text(self) -> str:
        """The report for the console, one line per check."""
        mark = {"ok": "ok  ", "warning": "WARN", "failed": "FAIL", "skipped": "skip"}
        return "\n".join(f"  [{mark[c.status]}] {c.name}: {c.message}" for c in self.checks)

    def to_dict(self) -> list:
        """JSON-ready list of the checks."""
        return [asdict(c) for c in self.checks]


def _corr(a, b) -> tuple[float, int]:
    ok = np.isfinite(a) & np.isfinite(b)
    n = int(ok.sum())
    if n < 10:
        return float("nan"), n
    a, b = a[ok] - a[ok].mean(), b[ok] - b[ok].mean()
    den = np.sqrt((a * a).sum() * (b * b).sum())
    return (float((a * b).sum() / den) if den > 0 else float("nan")), n


def _rate_check(name, channel, measured, predicted, label, min_std) -> SanityCheck:
    std = float(np.nanstd(measured)) if np.isfinite(measured).any() else 0.0
    if not std > min_std:
        return SanityCheck(name, "skipped", f"too little motion to check (std of {label} "
                           f"{np.degrees(std):.2g} deg/s)", channel)
    c, n = _corr(measured, predicted)
    if not np.isfinite(c):
        return SanityCheck(name, "skipped", f"too few samples ({n})", channel)
    if c < -_CORR:
        return SanityCheck(name, "failed", f"channel {channel!r} looks sign-inverted: "
                           f"correlation {c:.2f} with {label}", channel, c)
    if c < _CORR:
        return SanityCheck(name, "warning", f"channel {channel!r} correlates weakly with "
                           f"{label} ({c:.2f}): check its sign, unit and time base",
                           channel, c)
    return SanityCheck(name, "ok", f"correlation {c:.2f} with {label}", channel, c)


def _deriv(x, dt, wrap=False):
    x = np.asarray(x, dtype=float)
    if wrap:
        ok = np.isfinite(x)
        y = x.copy()
        if ok.any():
            y[ok] = np.unwrap(x[ok])
        x = y
    if x.size < 3:
        return np.full(x.shape, np.nan)
    return np.gradient(x, dt)


def _rates(d, dt, mask, report):
    phi, theta, p, q, r = (d[k] for k in ("phi", "theta", "p", "q", "r"))
    min_std = np.radians(0.5)

    def sel(x):
        return np.where(mask, x, np.nan)

    phi_rate, theta_rate, psi_rate = euler_rates(p, q, r, phi, theta)
    phid = sel(_deriv(phi, dt, wrap=True))
    report.checks.append(_rate_check("rate sign p", "p", phid, sel(phi_rate), "d(phi)/dt",
                                     min_std))
    thetad = sel(_deriv(theta, dt))
    report.checks.append(_rate_check("rate sign q", "q", thetad, sel(theta_rate),
                                     "d(theta)/dt", min_std))
    pred = sel(psi_rate)
    if "psi" in d:
        report.checks.append(_rate_check("rate sign r", "r", sel(_deriv(d["psi"], dt, True)),
                                         pred, "d(psi)/dt", min_std))
    elif "vn_gps" in d and "ve_gps" in d:
        track = np.arctan2(d["ve_gps"], d["vn_gps"])
        slow = np.hypot(d["ve_gps"], d["vn_gps"]) < 20.0
        trackd = sel(np.where(slow, np.nan, _deriv(track, dt, wrap=True)))
        report.checks.append(_rate_check("rate sign r", "r", trackd, pred,
                                         "d(GPS track)/dt", min_std))
    elif "tas" in d:
        # no heading, no GPS track: in banked flight the turn is about coordinated, so
        # r = psi_dot cos(phi) cos(theta) with psi_dot = g tan(phi) / V
        with np.errstate(invalid="ignore", divide="ignore"):
            banked = mask & (np.abs(phi) > np.radians(10)) & (d["tas"] > 10)
            turn = np.where(banked, G0 / d["tas"] * np.sin(phi) * np.cos(theta), np.nan)
        if int(banked.sum()) < _MIN_BANKED:
            report.checks.append(SanityCheck(
                "rate sign r", "skipped", f"no heading, no GPS track and only "
                f"{int(banked.sum())} samples banked more than 10 deg (turns) to compare with",
                "r"))
        else:
            report.checks.append(_rate_check("rate sign r", "r", np.where(banked, r, np.nan),
                                             turn, "g sin(phi) cos(theta) / V in turns",
                                             min_std))
    else:
        report.checks.append(SanityCheck("rate sign r", "skipped",
                                         "no heading and no GPS track to compare with", "r"))


def _body_to_ned(phi, theta, psi, f):
    """Rotate body vectors f (3, n) to NED with Euler 3-2-1 angles (psi may be None)."""
    cf, sf, ct, st = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta)
    down = -st * f[0] + sf * ct * f[1] + cf * ct * f[2]
    if psi is None:
        return None, None, down
    cp, sp = np.cos(psi), np.sin(psi)
    north = (ct * cp * f[0] + (sf * st * cp - cf * sp) * f[1] + (cf * st * cp + sf * sp) * f[2])
    east = (ct * sp * f[0] + (sf * st * sp + cf * cp) * f[1] + (cf * st * sp - sf * cp) * f[2])
    return north, east, down


def _specific_force(d, dt, mask, report):
    axes = [k for k in ("ax", "ay", "az") if k in d]
    if len(axes) < 3:
        absent = sorted({"ax", "ay", "az"} - set(axes))
        report.checks.append(SanityCheck("specific force", "skipped",
                                         f"accelerometer channel(s) {absent} missing"))
        return
    f = np.vstack([d["ax"], d["ay"], d["az"]])
    psi = d.get("psi")
    gps = all(k in d for k in ("vn_gps", "ve_gps", "vd_gps"))
    if gps:
        kin = [_deriv(d["vn_gps"], dt), _deriv(d["ve_gps"], dt), _deriv(d["vd_gps"], dt) - G0]
        source = "the GPS accelerations"
    else:
        kin = [None, None, np.full(f.shape[1], -G0)]
        source = "-g (no GPS velocities: mean only)"
    comps = [2] if psi is None or not gps else [0, 1, 2]

    def rms(flip):
        g = f.copy()
        if flip is not None:
            g[flip] = -g[flip]
        ned = _body_to_ned(d["phi"], d["theta"], psi, g)
        res = np.concatenate([np.where(mask, ned[c] - kin[c], np.nan) for c in comps])
        if not gps:  # compare means only
            res = np.array([np.nanmean(res)])
        res = res[np.isfinite(res)]
        return float(np.sqrt(np.mean(res ** 2))) if res.size else float("nan")

    base = rms(None)
    if not np.isfinite(base):
        report.checks.append(SanityCheck("specific force", "skipped", "no overlapping samples"))
        return
    flipped = {ax: rms(i) for i, ax in enumerate(("ax", "ay", "az"))}
    best = min(flipped, key=lambda k: flipped[k])
    what = "north-east-down" if comps == [0, 1, 2] else "down component"
    # the mean of the down component against -g resolves only errors of order g
    floor = 0.05 if gps else 1.0
    if flipped[best] < 0.5 * base and base > floor:
        report.checks.append(SanityCheck(
            "specific force", "failed",
            f"channel {best!r} looks sign-inverted: RMS difference from {source} "
            f"{base:.2f} m/s^2 ({what}), {flipped[best]:.2f} m/s^2 with its sign flipped",
            best, base))
    elif base > 1.0:
        report.checks.append(SanityCheck(
            "specific force", "warning",
            f"RMS difference from {source} is {base:.2f} m/s^2 ({what}): check the "
            "accelerometer units (g?), lever arm and time base", None, base))
    else:
        report.checks.append(SanityCheck(
            "specific force", "ok", f"RMS difference from {source} {base:.2f} m/s^2 ({what})",
            None, base))


def _alpha(d, dt, mask, report):
    if "alpha" not in d or "tas" not in d:
        report.checks.append(SanityCheck("alpha vs theta - gamma", "skipped",
                                         "alpha or tas missing", "alpha"))
        return
    if "vd_gps" in d:
        climb, source = -d["vd_gps"], "GPS vertical speed"
    else:
        climb, source = _deriv(d["h"], dt), "d(h)/dt"
    with np.errstate(invalid="ignore"):
        gamma = np.arcsin(np.clip(climb / d["tas"], -1, 1))
        steady = (mask & (np.abs(d["phi"]) < np.radians(5)) & (np.abs(d["q"]) < np.radians(2))
                  & (np.abs(d["p"]) < np.radians(3)) & np.isfinite(gamma)
                  & np.isfinite(d["alpha"]) & np.isfinite(d["theta"]))
    n = int(steady.sum())
    if n < 20:
        report.checks.append(SanityCheck("alpha vs theta - gamma", "skipped",
                                         f"only {n} steady wings-level samples", "alpha"))
        return
    a = float(np.median(d["alpha"][steady]))
    tg = float(np.median((d["theta"] - gamma)[steady]))
    diff = a - tg
    if abs(a + tg) < 0.5 * abs(diff) and abs(tg) > np.radians(1.0):
        report.checks.append(SanityCheck(
            "alpha vs theta - gamma", "failed",
            f"channel 'alpha' looks sign-inverted: median {np.degrees(a):.2f} deg in steady "
            f"wings-level flight where theta - gamma is {np.degrees(tg):.2f} deg "
            f"(gamma from {source}, {n} samples)", "alpha", diff))
    elif abs(diff) > np.radians(2.0):
        report.checks.append(SanityCheck(
            "alpha vs theta - gamma", "warning",
            f"alpha exceeds theta - gamma by {np.degrees(diff):.2f} deg in steady wings-level "
            f"flight (gamma from {source}, {n} samples): a vane offset (set 'offset' in the "
            "mapping or metadata sensor_geometry.alpha_vane.offset_rad) or vertical wind",
            "alpha", diff))
    else:
        report.checks.append(SanityCheck(
            "alpha vs theta - gamma", "ok",
            f"alpha - (theta - gamma) = {np.degrees(diff):.2f} deg in steady wings-level "
            f"flight (gamma from {source}, {n} samples)", "alpha", diff))


#: column -> (statistic, limit, what it looks like): |x| percentile 99 above the limit
_TOO_BIG = {
    "alpha": (1.2, "degrees"), "beta": (1.2, "degrees"), "theta": (1.6, "degrees"),
    "de": (1.2, "degrees"), "da": (1.2, "degrees"), "dr": (1.2, "degrees"),
    "phi": (3.3, "degrees"), "psi": (6.5, "degrees"),
    "p": (4.0, "deg/s"), "q": (4.0, "deg/s"), "r": (4.0, "deg/s"),
    "tas": (400.0, "knots or km/h"), "h": (20000.0, "feet"),
}


def _units(d, mask, report):
    for name, (limit, looks) in _TOO_BIG.items():
        if name not in d:
            continue
        x = np.abs(np.where(mask, d[name], np.nan))
        if not np.isfinite(x).any():
            continue
        p99 = float(np.nanpercentile(x, 99))
        if p99 > limit:
            report.checks.append(SanityCheck(
                f"units {name}", "warning",
                f"channel {name!r} looks like {looks}: 99 % of |values| up to {p99:.4g} after "
                f"conversion (plausible up to {limit:g} in SI/radians); check its 'unit'",
                name, p99))
    for name in ("phi", "theta"):
        if name in d:
            x = np.abs(np.where(mask, d[name], np.nan))
            if np.isfinite(x).sum() > 100 and float(np.nanmax(x)) < np.radians(0.2):
                report.checks.append(SanityCheck(
                    f"units {name}", "warning",
                    f"channel {name!r} never exceeds 0.2 deg: radians labelled as degrees?",
                    name, float(np.nanmax(x))))
    for name in ("ax", "ay", "az"):
        if name in d and name == "az":
            m = float(np.nanmean(np.where(mask, d[name], np.nan)))
            if np.isfinite(m) and 0.5 < abs(m) < 2.0:
                report.checks.append(SanityCheck(
                    "units az", "warning",
                    f"channel 'az' averages {m:.3g} m/s^2: in g rather than m/s^2? (unit "
                    "'g0' converts)", "az", m))
    if not any(c.name.startswith("units") for c in report.checks):
        report.checks.append(SanityCheck("units", "ok", "angles, rates, speeds and altitudes "
                                         "in plausible ranges"))


def check_record(data, dt: float, airborne=None) -> SanityReport:
    """Run the sanity checks on a record in schema units on one time base.

    Parameters
    ----------
    data : mapping of str to ndarray, shape (n,)
        Schema columns (a DataFrame works); absent columns skip their checks. ``phi``,
        ``theta``, ``p``, ``q``, ``r`` are needed for the rate checks.
    dt : float
        Sample interval [s].
    airborne : ndarray of bool, shape (n,), optional
        Samples to use (all if None).

    Returns
    -------
    SanityReport
    """
    d = {k: np.asarray(data[k], dtype=float) for k in data
         if np.issubdtype(np.asarray(data[k]).dtype, np.number)}
    d = {k: v for k, v in d.items() if np.isfinite(v).any()}
    n = len(next(iter(d.values()))) if d else 0
    mask = np.ones(n, bool) if airborne is None else np.asarray(airborne, bool)
    report = SanityReport()
    if all(k in d for k in ("phi", "theta", "p", "q", "r")):
        _rates(d, dt, mask, report)
    else:
        report.checks.append(SanityCheck("rate signs", "skipped",
                                         "phi, theta, p, q and r are needed"))
    if "phi" in d and "theta" in d:
        _specific_force(d, dt, mask, report)
    if all(k in d for k in ("theta", "phi", "p", "q", "h")):
        _alpha(d, dt, mask, report)
    _units(d, mask, report)
    return report
