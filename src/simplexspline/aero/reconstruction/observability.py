"""Which states a maneuver's channels can observe: the plan the filter follows.

Per maneuver, from the channels that hold data (a column that is absent or entirely NaN in
the maneuver counts as missing), :func:`observability_plan` decides which states the filter
estimates and which it holds at their prior (variance at the numerical floor, so the gain
never moves them), and says why. Rules (each one a structural observability argument; the
filter's own variance reduction is checked afterwards by :func:`variance_reduction`):

* **no GPS** (neither velocity nor position): the wind is unobservable (air data and IMU
  only see the air-relative motion), and so are the vanes' scale factors: wind held at
  zero (or at the ``wind_*`` columns when given), scale factors at zero, the same in every
  maneuver instead of a different guess per maneuver. The vane offsets and the airspeed
  bias are observable over a campaign: each changes the air-relative velocity by a
  constant that the kinematics see through the rotation terms ``omega x V`` (an
  angle-of-attack offset moves w, and the roll rate turns w into the lateral acceleration
  the sideslip vane sees; a wrong airspeed turns by the wrong amount; in a constant wind
  the air-relative velocity obeys the same kinematics). One maneuver's rates barely tell
  them, but the campaign's pass over its maneuvers does: the offsets in the first pass
  (``calibration_pass``), the airspeed bias in a pass that holds them
  (``airspeed_pass``: estimated together, the alpha-vane offset traded against it), and
  the last pass holds all at the campaign's estimates; what the campaign does not pin is
  held at zero. Held at zero, an offset also corrupts the kinematics: on a 40-maneuver A-4
  campaign without GPS a 0.2 deg alpha offset made the sideslip 2.2e-4 rad RMS off within
  each maneuver (p times the offset's w) and the rolling moment's model 1.9 times its
  noise; estimated by the campaign, 4.4e-5 rad and 0.8 times.
* **no sideslip vane**: its offset and scale are not estimated. With GPS, the changes of
  beta follow from the lateral kinematics (ay, p, r, phi and the GPS velocities), but a
  constant crosswind and a constant sideslip look the same in straight flight; without GPS
  the lateral velocity is a dead-reckoning integral of a biased ``ay``. Either way the
  filter keeps the kinematic dynamics and assumes a zero mean over the maneuver (a
  pseudo-measurement beta = 0 with a wide sigma, ``beta_pseudo_std``: maneuvers start from
  trimmed, near-symmetric flight). With GPS in still air, where the maneuver holds at
  least :data:`TRIM_MIN_S` of trimmed flight (:func:`trimmed`: wings level, no rotation,
  the ball centred), the sideslip is zero there instead, within :data:`TRIM_SIDESLIP`
  over those samples together, and nothing is assumed elsewhere: a doublet's or a pulse's
  mean sideslip is not zero, and the weak zero mean let the filter's own slight model
  errors decide the split between heading and sideslip (a still-air rudder doublet's
  sideslip came out 2.5e-3 rad off, its true mean 4e-5). Where a straight still-air
  maneuver holds no trimmed flight, its zero mean weighs at least :data:`MEAN_SIDESLIP`
  over the maneuver, however few its samples (a turn keeps the weak zero mean: its mean
  sideslip is not zero). Without GPS the models in beta (CY, Cl, Cn) are flagged
  and the lateral accelerometer bias is held at zero (estimated against the zero-mean
  assumption it differed from maneuver to maneuver: CY's per-maneuver mean error reached
  5.7 times its noise on a 10-maneuver real-like campaign).
* **no heading**: with GPS the heading follows from the GPS track, the air data and the
  wind in turns; in straight flight a heading error and a crosswind error give the same
  data, so the driver starts heading and wind from the wind triangle
  (:mod:`~simplexspline.aero.reconstruction.wind_triangle`) when the maneuver turns by at
  least ``MIN_HEADING_CHANGE`` and otherwise flags the crosswind and heading as weak.
  Without GPS it is not observable and not needed (nothing else depends on it): it is not
  reconstructed (NaN).
* **no accelerometers**: the body velocities become a random walk observed by the air data
  (and GPS); accelerometer biases are not estimated and the force coefficients are not
  computed (moment coefficients only).
* **GPS latitude and longitude only** (no ``z_gps``, no ``vd_gps``): the horizontal wind is
  estimated; the vertical wind is not observable (the Earth-relative vertical velocity is
  not measured) and is held at zero.
* **vane scale factors** are estimated only with GPS and when asked for.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from simplexspline.aero.reconstruction.kinematics import euler_rates

__all__ = ["GPS_VELOCITY", "GPS_POSITION", "ACCELEROMETERS", "MEAN_SIDESLIP",
           "POSITION_GIVEN", "POSITION_NOT_REQUESTED", "TRIM_AY", "TRIM_BANK", "TRIM_MIN_S",
           "TRIM_RATE", "TRIM_SIDESLIP", "channels_present", "heading_excursion",
           "observability_plan", "trimmed", "variance_reduction"]

GPS_VELOCITY = ("vn_gps", "ve_gps", "vd_gps")
GPS_POSITION = ("x_gps", "y_gps", "z_gps")
ACCELEROMETERS = ("ax", "ay", "az")
_AIR_DATA_ERRORS = ("btas", "balpha", "bbeta")
_WIND = ("wind_n", "wind_e", "wind_d")

#: Trimmed flight (:func:`trimmed`): body roll and yaw rates below this [rad/s] (0.5 deg/s),
TRIM_RATE = np.radians(0.5)
#: the bank angle below this [rad] (2 deg),
TRIM_BANK = np.radians(2.0)
#: and the lateral specific force within this of its bias [m/s^2] (the ball centred: five
#: times a typical accelerometer's noise; at 200 m/s a sideslip of 2e-3 rad gives 0.08).
TRIM_AY = 0.05
#: Trimmed flight a maneuver must hold [s] for its sideslip to be taken as zero there.
TRIM_MIN_S = 1.0
#: Sigma [rad] of the trimmed samples' mean sideslip about zero (a symmetric aircraft
#: trimmed with the ball centred; the sigma of their pseudo-measurements together).
TRIM_SIDESLIP = 1e-3
#: In still air with GPS, a straight maneuver without trimmed flight: the sigma [rad] of
#: its mean sideslip about zero, whatever its sample count (a pseudo-measurement sigma of
#: ``beta_pseudo_std`` per sample weighs a detected 8 s segment at 10 Hz 5.6e-3, and the
#: filter's slight model errors put one aileron input's sideslip 3.95e-3 rad off; with
#: this sigma 1.0e-3). Long maneuvers keep ``beta_pseudo_std`` per sample where that is
#: tighter.
MEAN_SIDESLIP = 1.5e-3


def _has(task: Mapping, name: str) -> bool:
    x = task.get(name)
    return x is not None and bool(np.isfinite(np.asarray(x, dtype=float)).any())


def channels_present(task: Mapping) -> dict:
    """Which sensor groups hold data in one maneuver.

    Parameters
    ----------
    task : mapping
        Column name -> (n,) array of one maneuver.

    Returns
    -------
    dict of str to bool
        ``gps_velocity`` (all three axes), ``gps_position`` (north and east: a record of
        latitude and longitude without GPS altitude counts), ``gps_vertical`` (``z_gps`` or
        ``vd_gps``), ``accelerometers``, ``beta``, ``psi``, ``wind_given`` (``wind_*``
        columns).
    """
    return {
        "gps_velocity": all(_has(task, c) for c in GPS_VELOCITY),
        "gps_position": all(_has(task, c) for c in GPS_POSITION[:2]),
        "gps_vertical": _has(task, "z_gps") or _has(task, "vd_gps"),
        "accelerometers": all(_has(task, c) for c in ACCELEROMETERS),
        "beta": _has(task, "beta"),
        "psi": _has(task, "psi"),
        "wind_given": all(_has(task, c) for c in _WIND),
    }


#: Why a vane's position error is held: the sensor geometry gives the position.
POSITION_GIVEN = "given in the sensor geometry: held there"
#: Why a vane's position error is held with ``estimate_vane_position=False``.
POSITION_NOT_REQUESTED = ("not requested (estimate_vane_position=False): held at the given "
                          "position")


def observability_plan(present: Mapping, *, estimate_vane_scale: bool = True,
                       estimate_vane_position: bool = True,
                       positions_given: tuple = (), calibration_pass: bool = False,
                       airspeed_pass: bool = False) -> dict:
    """The states to estimate and to hold, with the reasons.

    Parameters
    ----------
    present : mapping
        :func:`channels_present`.
    estimate_vane_scale : bool
        Estimate the vane scale-factor errors where observable (with GPS).
    estimate_vane_position : bool
        Estimate the vanes' position errors along x where observable (with GPS).
    positions_given : tuple of str
        The vanes (``alpha_vane``, ``beta_vane``) whose position the sensor geometry gives:
        held there.
    calibration_pass : bool
        The campaign's first pass (its estimates are combined over the maneuvers): without
        GPS the vane offsets are estimated there when the accelerometers are present
        (through ``omega x V``; see the module docstring), and held otherwise.
    airspeed_pass : bool
        The campaign's pass without GPS that estimates the airspeed bias, the vane offsets
        held at the first pass's estimates.

    Returns
    -------
    dict
        ``held``: state name -> reason (held at its prior); ``beta``, ``psi``, ``wind``,
        ``forces``: one-line statements of what the reconstruction gives for each;
        ``beta_pseudo``: True when beta is stabilised by a zero-mean pseudo-measurement;
        ``psi_output``: False when the heading is not reconstructed.
    """
    gps = bool(present["gps_velocity"] or present["gps_position"])
    held = {}
    if not gps:
        why = "unobservable without GPS"
        for s in _WIND:
            held[s] = why + (": held at the given wind_* columns" if present["wind_given"]
                             else ": held at zero (still air)")
        for s in _AIR_DATA_ERRORS:
            if present["accelerometers"]:
                if airspeed_pass if s == "btas" else calibration_pass:
                    continue      # the campaign's rotations tell it (module docstring)
                held[s] = (why + " but through the campaign's rotations, which did not "
                           "pin it: held at zero (the sensor's calibration error stays in "
                           "the data)")
                continue
            held[s] = why + ": held at zero (the sensor's calibration error stays in the data)"
        held["kalpha"] = held["kbeta"] = why + ": held at zero"
        held["xalpha"] = held["xbeta"] = why + ": held at the given position"
    if gps and not present.get("gps_vertical", True):
        held["wind_d"] = ("unobservable without a vertical GPS channel (z_gps or vd_gps): "
                          "held at zero")
    if not estimate_vane_scale:
        held.setdefault("kalpha", "not requested (estimate_vane_scale=False)")
        held.setdefault("kbeta", "not requested (estimate_vane_scale=False)")
    for state, vane in (("xalpha", "alpha_vane"), ("xbeta", "beta_vane")):
        if vane in positions_given:
            held.setdefault(state, POSITION_GIVEN)
        elif not estimate_vane_position:
            held.setdefault(state, POSITION_NOT_REQUESTED)
    if not present["beta"]:
        held["bbeta"] = "no sideslip vane"
        held["kbeta"] = "no sideslip vane"
        held["xbeta"] = "no sideslip vane"
        if not gps and present["accelerometers"]:
            held["bay"] = ("unobservable without GPS and sideslip vane (it trades against "
                           "the sideslip): held at zero")
    if not present["accelerometers"]:
        for s in ("bax", "bay", "baz"):
            held[s] = "no accelerometers"
    if present["beta"]:
        beta = "measured (vane), reconstructed"
    elif gps:
        beta = ("estimated from the lateral kinematics and GPS (no sideslip vane), zero mean "
                "over the maneuver assumed")
    else:
        beta = ("NOT OBSERVABLE (no sideslip vane, no GPS): dead-reckoned from ay, p, r, phi "
                "with a zero mean assumed; CY, Cl, Cn models in beta are unreliable")
    if present["psi"]:
        psi = "measured, reconstructed"
    elif present["gps_velocity"]:
        psi = "estimated from the GPS track, air data and wind (no heading channel)"
    elif gps:
        psi = "estimated from GPS positions (no heading channel): weak"
    else:
        psi = "not observable (no heading, no GPS): not reconstructed (NaN); not needed"
    if gps:
        wind = "estimated (constant or random walk per maneuver, GPS)"
    elif present["wind_given"]:
        wind = "not observable without GPS: the given wind_* columns are used"
    else:
        wind = "not observable without GPS: still air assumed (held at zero)"
    forces = ("computed" if present["accelerometers"] else
              "NOT computed (no accelerometers): moment coefficients only")
    return {"held": held, "beta": beta, "psi": psi, "wind": wind, "forces": forces,
            "beta_pseudo": not present["beta"],
            "psi_output": bool(present["psi"] or gps)}


def variance_reduction(prior_sd: np.ndarray, posterior_sd: np.ndarray) -> np.ndarray:
    """Posterior over prior standard deviation per state (1: the data taught nothing).

    Parameters
    ----------
    prior_sd, posterior_sd : (m,) ndarray

    Returns
    -------
    (m,) ndarray
        A ratio above about 0.5 marks a state the maneuver barely observes.
    """
    prior_sd = np.asarray(prior_sd, dtype=float)
    return np.asarray(posterior_sd, dtype=float) / np.where(prior_sd > 0, prior_sd, np.inf)


def heading_excursion(task: Mapping) -> float:
    """Heading change within a maneuver [rad], from the gyros and attitude.

    ``max - min`` of the integrated Euler heading rate ``(q sin(phi) + r cos(phi)) /
    cos(theta)``: what separates a constant wind from constant air-data errors (the
    campaign calibration prefers maneuvers that turn).

    Parameters
    ----------
    task : mapping
        ``t`` [s], ``q``, ``r`` [rad/s], ``phi``, ``theta`` [rad], (n,) arrays each.

    Returns
    -------
    float
    """
    t = np.asarray(task["t"], dtype=float)
    if t.size < 2:
        return 0.0
    psidot = euler_rates(0.0, *(np.asarray(task[c], dtype=float)
                                for c in ("q", "r", "phi", "theta")))[2]
    psi = np.nancumsum(psidot) * float(np.median(np.diff(t)))
    return float(np.nanmax(psi) - np.nanmin(psi))


def trimmed(task: Mapping, biases: Mapping | None = None) -> np.ndarray:
    """The samples of a maneuver flown trimmed: wings level, not rotating, ball centred.

    A symmetric aircraft trimmed like this flies at about zero sideslip; a lateral
    maneuver usually starts so, and its free response may end so.

    Parameters
    ----------
    task : mapping
        ``p``, ``r`` [rad/s], ``phi`` [rad] and ``ay`` [m/s^2], (n,) arrays each.
    biases : mapping, optional
        ``bp``, ``br`` [rad/s] and ``bay`` [m/s^2] (value, sigma) pairs: the IMU biases to
        take off first (the campaign's); missing ones are zero.

    Returns
    -------
    ndarray of bool, shape (n,)
        True where ``|p|, |r| <`` :data:`TRIM_RATE`, ``|phi| <`` :data:`TRIM_BANK` and
        ``|ay| <`` :data:`TRIM_AY` (biases off); False where a channel is NaN or missing.
    """
    b = {k: float((biases or {}).get(k, (0.0, 0.0))[0]) for k in ("bp", "br", "bay")}
    n = len(np.asarray(task["phi"]))

    def col(c):
        return np.asarray(task[c], dtype=float) if c in task else np.full(n, np.nan)

    with np.errstate(invalid="ignore"):
        return ((np.abs(col("p") - b["bp"]) < TRIM_RATE)
                & (np.abs(col("r") - b["br"]) < TRIM_RATE)
                & (np.abs(col("phi")) < TRIM_BANK)
                & (np.abs(col("ay") - b["bay"]) < TRIM_AY))
