"""Flight path reconstruction: per-maneuver IEKF + RTS smoother, in parallel.

Turns measured flight data (noisy, biased IMU, air data, attitude and GPS) into consistent
states: bias-corrected specific forces and rates, reconstructed alpha, beta, V and attitudes,
estimated sensor biases with standard deviations and innovation statistics (a data-
compatibility check), then the aerodynamic coefficients of Eq. 43-48. The filter is
described in ``docs/reconstruction.md``; the equations in
:mod:`simplexspline.aero.reconstruction.kinematics`, the filter in
:mod:`simplexspline.aero.reconstruction.iekf`.

Every maneuver is reconstructed independently (its own biases); a maneuver that cannot be
reconstructed (too short, a NaN burst in an IMU channel, a channel without any valid sample,
a diverging filter) is rejected with the reason and the others still process.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from simplexspline._workers import ignore_interrupts, process_context
from simplexspline._files import jsonable
from simplexspline.aero.data.atmosphere import hydrostatic_height
from simplexspline.aero.data.adaptive_smoothing import smooth_by_maneuver
from simplexspline.aero.data.coefficients import THRUST_COLUMNS, aerodynamic_coefficients
from simplexspline.aero.data.differentiation import SIMULATOR_STEP_MAX_S
from simplexspline.aero.data.flight_data import (
    present_columns, sensor_geometry, validate_flight_data, without_metadata,
)
from simplexspline.aero.data.whiteness import whiteness_band
from simplexspline.aero.reconstruction import filter_kernels
from simplexspline.aero.reconstruction.campaign_calibration import (FALSE_ALARM,
                                                                     LONE_SHARE,
                                                                     OBSERVED,
                                                                     SCALE_FROM_MEANS_MIN,
                                                                     CombinedEstimate,
                                                                     campaign_priors,
                                                                     campaign_wind,
                                                                     combine_campaign,
                                                                     combine_joint,
                                                                     lone_in_gusts,
                                                                     prior_conflicts,
                                                                     vane_scale_from_means)
from simplexspline.aero.reconstruction.iekf import (
    FilterNoise, IteratedUpdate, StateEstimate, rts_smooth, run_filter,
)
from simplexspline.aero.reconstruction.diagnosis import inconsistent_imu, likely_causes
from simplexspline.aero.reconstruction.gusts import (
    GustChoice, choose_gusts, gust_process, innovation_excess,
)
from simplexspline.aero.reconstruction.kinematics import (
    BIAS_STATES, GUST, INPUT_NAMES, MEASUREMENT_NAMES, NX, POSITION_STATES, SCALE_STATES,
    STATE_NAMES,
    WIND_STATES, EarthModel, measure, step_mean,
)
from simplexspline.aero.reconstruction.observability import (
    MEAN_SIDESLIP, POSITION_GIVEN, POSITION_NOT_REQUESTED, TRIM_MIN_S, TRIM_SIDESLIP,
    channels_present, heading_excursion, observability_plan, trimmed, variance_reduction,
)
from simplexspline.aero.reconstruction.sensor_corrections import (
    estimate_lag, estimate_lag_from_response, rotation_velocity, specific_force_at_cg,
    undo_lag,
)
from simplexspline.aero.reconstruction.wind_triangle import (
    MIN_HEADING_CHANGE, WindTriangle, wind_triangle,
)
from simplexspline.aero.variables import DEG
from simplexspline.errors import FlightDataError, InputError
from simplexspline.spline import kernels

__all__ = ["ReconstructionSettings", "Reconstruction", "reconstruct", "reconstruct_maneuver",
           "innovation_statistics", "significant_lags"]

#: Control-surface position columns smoothed when ``smooth_controls`` (those present).
CONTROL_COLUMNS = ("de", "da", "dr", "dte", "flap")
#: Constant air-data errors estimated for the whole campaign (``air_data_calibration``).
CALIBRATION_STATES = ("btas", "balpha", "bbeta", "kalpha", "kbeta", "xalpha", "xbeta")
#: Each vane's offset, scale error and position error along x, combined jointly by the
#: campaign calibration
#: (:func:`~simplexspline.aero.reconstruction.campaign_calibration.combine_joint`).
VANE_STATES = {"alpha": ("balpha", "kalpha", "xalpha"), "beta": ("bbeta", "kbeta", "xbeta")}
#: The constants that straight maneuvers without a heading channel give the campaign too:
#: the angle-of-attack vane's lie in the vertical plane, which the crosswind held at zero
#: does not reach (the airspeed bias trades against the wind along the track, the
#: sideslip vane's against the crosswind, the yaw-gyro bias against the heading).
STRAIGHT_CALIBRATION_STATES = ("balpha", "kalpha", "xalpha")
#: Without GPS the campaign's vane offsets and airspeed bias (observed through omega x V
#: only) are kept when their combined sigma is at most this share of the prior's (0.001
#: rad for the default 0.02, 0.1 m/s for the default 2 m/s), not half of it as with GPS:
#: a weakly observed offset is a guess that can be worse than the sensor's own error (one
#: f16 elevator pulse gave a sideslip-vane offset of +1.7e-3 +- 3.9e-3 rad for a true
#: -1.7e-3; six maneuvers -1.9e-3 +- 2.2e-4, forty A-4 maneuvers -1.74e-3 +- 5e-5).
OFFSET_SHARE_WITHOUT_GPS = 0.05
#: The campaign's wind starts a straight maneuver without a heading channel only when its
#: sigma is at most this share of the crosswind sigma the priors give
#: (:func:`_crosswind_prior_sd`): turns that disagree leave the crosswind held at zero.
INFORMATIVE_WIND = 0.5
#: IMU biases that the campaign's maneuvers share (one IMU): each maneuver's prior is the
#: others' estimate (``imu_calibration``).
IMU_STATES = ("bax", "bay", "baz", "bp", "bq", "br")
#: Why the vane scale factors are not estimated in a maneuver with gusts: measured on a
#: 3-maneuver f16 campaign in JSBSim's light turbulence (default sensors, no scale error),
#: estimated they came out at 0.2 and 0.34 +- 0.02 (the part of the gusts' angles of attack
#: and sideslip that the gust model does not follow correlates with the angles themselves).
GUST_HELD_SCALE = ("not estimated in turbulence (gusts in this maneuver): confounded with "
                   "the gusts; held at the given calibration")
#: Why the vanes' positions are not estimated in a maneuver with gusts: the gusts' angles
#: drive the pitch and yaw rates, so the rate-induced angles of a vane ahead of the c.g.
#: correlate with the part of the gusts the gust model does not follow (the same reason as
#: :data:`GUST_HELD_SCALE`).
GUST_HELD_POSITION = ("not estimated in turbulence (gusts in this maneuver): confounded "
                      "with the gusts; held at the given position or the campaign's")
#: Why the campaign calibration leaves out an airspeed bias (or sideslip-vane offset) that
#: one maneuver with gusts alone observes (:data:`LONE_IN_GUSTS_STATES`): measured on a
#: simulated A-4 sortie (10 Hz, light turbulence, no heading), its two turns gave airspeed
#: biases of -0.70 +- 1.66 (not observing it) and -2.51 +- 0.89 m/s, the truth about 0; the
#: second alone became the campaign's, and every airspeed of the flight came out 2.5 m/s off
#: (raw sensor: 0.6 m/s RMS). Turbulence biases such an estimate beyond its sigma, and with
#: one estimate nothing shows it; the constant is then held in the maneuvers with gusts, as
#: when no maneuver observes it. The same holds when the other estimates are too wide to
#: check it (it holds more than ``LONE_SHARE`` of their information: on a simulated 737
#: course a turn's 0.67 +- 0.15 m/s, truth 0, beside another turn's 0.17 +- 0.92 put every
#: airspeed 0.66 m/s off), and when every estimate comes from a maneuver with gusts (three
#: turns of another course agreed on +0.75 +- 0.17 m/s for a true 0); campaign_calibration
#: :func:`lone_in_gusts`.
LONE_IN_GUSTS = ("every maneuver that observes it had gusts (or one with gusts holds more "
                 f"than {LONE_SHARE:.0%} of what the maneuvers know of it), whose slow "
                 "horizontal part trades against it beyond its sigma, with nothing in still air "
                 "to check it against: held at its prior in the maneuvers with gusts")
#: The constants that trade against the horizontal wind (the airspeed bias along the track,
#: the sideslip-vane offset across it), whose gusts a maneuver's wind states follow only in
#: part. The angle-of-attack vane offset trades against the vertical wind, whose mean over a
#: maneuver is held near zero: on the same sorties one turbulent turn alone gave it well
#: (angle-of-attack errors 3.5-5.4e-3 rad; held at zero instead, the vane's 1.4e-2).
LONE_IN_GUSTS_STATES = ("btas", "bbeta")
#: Why the airspeed bias and the sideslip-vane offset are not estimated in a straight
#: maneuver with gusts: without a heading change they trade against the wind along and
#: across the track, and with the gusts free the filter drifts along that direction (on a
#: straight 21 s f16 maneuver in light turbulence the airspeed bias walked from 0 to 17 m/s
#: with a reported sigma of 1.8 m/s, the wind with it).
GUST_HELD_STRAIGHT = ("not estimated in a straight maneuver in turbulence (it trades against "
                      "the wind without a heading change): held at zero or the campaign "
                      "calibration")
#: Why the airspeed bias is not estimated in a straight maneuver in still air either when
#: the campaign calibration could not determine it (since stop 31): a constant on the
#: airspeed and the wind along the track are one in straight flight. On a simulated
#: flight-test course (global5000, no turns inside its maneuvers, so the campaign's
#: airspeed bias came out -0.22 +- 1.9 m/s, undetermined) the straight maneuvers' own
#: estimates put the airspeed -1.4..+3.6 m/s off, 1.16 m/s RMS against the raw sensor's
#: 0.10.
HELD_STRAIGHT = ("not estimated in a straight maneuver: the campaign calibration could not "
                 "determine it, and without a heading change it is one with the wind along "
                 "the track; held at zero (the sensor's calibration error stays in the data)")
#: Why an air-data error the campaign calibration could not determine is not estimated in a
#: maneuver with gusts: if the campaign's turning maneuvers together leave its sigma above
#: half the prior, one maneuver cannot do better, and in turbulence its estimate drifts with
#: the wind (a turning 15-20 s sum-of-sines in moderate turbulence: airspeed bias 3.8 +- 1.4
#: m/s for a true 0.5, the wind 3 m/s off).
GUST_HELD_UNCALIBRATED = ("not estimated in turbulence: the campaign calibration could not "
                          "determine it (sigma above half the prior, or one turbulent "
                          "maneuver alone); held at zero (the sensor's calibration error "
                          "stays in the data)")
#: Why a vane's position is not estimated when a channel's lag remains.
POSITION_AFTER_LAGS = ("not estimated: a lag remains in a channel (not undone, or still "
                       "significant), and the filter would take it for the vane's position; "
                       "held at the given position")
#: Why a maneuver holds a constant of the campaign's air-data calibration.
CAMPAIGN_HELD = "campaign air-data calibration (held at its estimate)"
#: Channels a maneuver cannot be reconstructed without (at least one valid sample each).
ESSENTIAL_MEASUREMENTS = ("tas", "alpha", "phi", "theta")


def _default_input_noise() -> dict:
    return {"ax": 0.01, "ay": 0.01, "az": 0.01, "p": 0.01 * DEG, "q": 0.01 * DEG,
            "r": 0.01 * DEG}


def _default_measurement_noise() -> dict:
    return {"x_gps": 2.0, "y_gps": 2.0, "z_gps": 4.0, "vn_gps": 0.05, "ve_gps": 0.05,
            "vd_gps": 0.1, "tas": 0.1, "alpha": 0.1 * DEG, "beta": 0.1 * DEG,
            "phi": 0.05 * DEG, "theta": 0.05 * DEG, "psi": 0.1 * DEG}


#: Latitude [deg] assumed when neither the settings nor the data give one: where standard
#: gravity is defined. Gravity differs by at most 0.026 m/s^2 to the poles or the equator
#: (the accelerometer biases take it), the Earth rate's vertical part by its sine.
ASSUMED_LATITUDE_DEG = 45.0


def _valid_latitude(value) -> bool:
    return (not isinstance(value, bool) and isinstance(value, (int, float))
            and math.isfinite(value) and -90.0 <= value <= 90.0)


def _latitude(settings, meta: Mapping) -> tuple:
    """The flights' latitude [deg] and where it came from (settings, metadata, assumed)."""
    if settings.latitude_deg is not None:
        return float(settings.latitude_deg), "settings"
    given = meta.get("latitude_deg")
    if given is not None:
        if not _valid_latitude(given):
            raise FlightDataError(f"metadata latitude_deg must be a latitude in degrees "
                                  f"(-90 .. 90), got {given!r}")
        return float(given), "metadata latitude_deg"
    return ASSUMED_LATITUDE_DEG, ("assumed (no latitude in the data: give metadata "
                                  "latitude_deg, a GPS latitude channel, or the setting)")


def _default_prior() -> dict:
    return {"position": 5.0, "velocity": 1.0, "attitude": 0.01, "accel_bias": 0.1,
            "gyro_bias": 2e-3, "vane_bias": 0.02, "tas_bias": 2.0, "wind": 10.0,
            "vertical_wind": 1.0, "vane_scale": 0.05, "heading": 0.3,
            "vane_position": 5.0}


@dataclass(frozen=True)
class ReconstructionSettings:
    """Noise model and options of the flight path reconstruction.

    Parameters
    ----------
    input_noise : dict
        IMU white-noise standard deviation per sample: ``ax, ay, az`` [m/s^2], ``p, q, r``
        [rad/s]. Defaults: the simulator's default sensors.
    measurement_noise : dict
        Standard deviation per measured channel (SI, rad), keys of
        :data:`~simplexspline.aero.reconstruction.kinematics.MEASUREMENT_NAMES`.
    prior : dict
        Initial standard deviations: ``position`` [m], ``velocity`` [m/s], ``attitude``
        [rad], ``accel_bias`` [m/s^2], ``gyro_bias`` [rad/s], ``vane_bias`` [rad],
        ``tas_bias`` [m/s], ``wind`` [m/s], ``vertical_wind`` [m/s] (the steady vertical
        wind of a maneuver with gusts: its mean is small outside convection and mountain
        waves, and with ``wind`` as its prior the gusts' slow part traded against the
        angle-of-attack vane offset: alpha errors of 7.3e-3 rad instead of 1.2e-3 on a
        3-maneuver f16 campaign in light turbulence), ``vane_scale`` [-], ``heading``
        [rad] (of the heading taken from the GPS track when there is no heading channel) and
        ``vane_position`` [m] (a vane's position error along x, where the geometry does not
        give it: 5 m covers a nose boom). Biases start at zero. States the channels cannot
        observe are held at their prior
        (:mod:`~simplexspline.aero.reconstruction.observability`).
    velocity_model_noise : float
        Extra process noise on u, v, w [m/s^2 per step, 1 sigma] for model errors
        (discretisation of the simulator's integrator, about 0.03 m/s^2).
    tol : float
        Stopping criterion of the iterated measurement update: the linearisation error at
        the new iterate, in units of each measured channel's noise standard deviation, must
        be below ``tol`` in every channel (:mod:`~simplexspline.aero.reconstruction.iekf`:
        relinearising on smaller errors moved the airspeed bias along the along-track wind
        in turbulence, 13-15 m/s in one straight maneuver).
    max_iter : int
        Maximum iterations (gain computations) per measurement update.
    smoother : bool
        Run the RTS backward smoother (recommended); otherwise the filtered states are used.
    latitude_deg : float or None
        Geodetic latitude of the flights [deg] (gravity, Earth rate). None (default): the
        data's metadata ``latitude_deg`` (written by the importer from the GPS latitude and
        by the simulator), else :data:`ASSUMED_LATITUDE_DEG`, said in the summary.
    earth_rotation : bool
        Model Earth rate, Coriolis and transport rate.
    min_duration_s : float
        Shorter maneuvers are rejected.
    accelerations : {'auto', 'measured', 'differentiate'}
        Source of pdot, qdot, rdot for the moment coefficients ('auto': the columns when
        present, else smoothed differentiation of the reconstructed rates).
    diff_half_window : int or None
    diff_degree : int
        Smoothed-differentiation settings (:mod:`simplexspline.aero.data.differentiation`).
        None (default): 8 samples each side in the forward-difference convention at the
        simulator's 100 Hz step; at coarser rates 0.08 s each side (at least 2 samples)
        centred on the samples.
    wind_random_walk : float
        Wind process noise [m/s per sqrt(s)]; 0 (default): a constant wind per maneuver.
        Used only with GPS (the wind is not observable without).
    gust_std : 'auto' or float
        Turbulence (:mod:`~simplexspline.aero.reconstruction.gusts`): the standard
        deviation [m/s] of the gusts on top of the steady wind, per NED axis, a zero-mean
        Gauss-Markov process. 'auto' (default): still air when the still-air model's
        air-data innovations are consistent, else the best of ``gust_candidates`` and
        ``gust_lengths_m`` by the likelihood of the measurements, per maneuver; 0: still
        air; a number: that intensity in every maneuver (the length still chosen). Not
        used without accelerometers (the body velocities are then a random walk that the
        gusts cannot be told from).
    gust_candidates : tuple of float
        Gust standard deviations [m/s] tried by 'auto' (light to moderate turbulence).
    gust_lengths_m : tuple of float
        Correlation lengths of the turbulence [m] tried (the gusts' time constant is the
        length over the airspeed); one value fixes it.
    estimate_vane_scale : bool
        Estimate the vanes' scale-factor errors (only with GPS).
    vane_scale_from_means : bool
        When turbulence kept every maneuver from estimating the angle-of-attack vane's
        scale error (and ``air_data_calibration='campaign'``): take it, with the offset,
        from the maneuvers' mean angles (one more pass, docs/reconstruction.md "The
        vane's scale in turbulence").
    estimate_vane_position : bool
        Estimate each vane's position error along the body x axis (states ``xalpha``,
        ``xbeta`` [m], prior sigma ``prior['vane_position']``) where the sensor geometry
        does not give the vane's position: a vane ahead of the c.g. reads the pitch rate's
        induced angle of attack ``-q x / V`` and the yaw rate's sideslip ``r x / V``.
        Combined over the campaign with the vane's offset and scale error
        (:func:`~simplexspline.aero.reconstruction.campaign_calibration.combine_joint`).
    beta_pseudo_std : float
        Without a sideslip vane and without GPS: the sigma [rad] of the zero-mean
        pseudo-measurement of beta that keeps the dead-reckoned sideslip from drifting.
    sideslip_prior : {'trim', 'mean'}
        Without a sideslip vane, with GPS and accelerometers, in a maneuver the filter
        finds in still air: 'trim' (default) takes the sideslip as zero where the maneuver
        flies trimmed (:func:`~simplexspline.aero.reconstruction.observability.trimmed`:
        wings level, no rotation, the ball centred; at least ``TRIM_MIN_S`` of it, within
        ``TRIM_SIDESLIP`` over those samples together) and assumes nothing elsewhere, and
        a maneuver without trimmed flight gets a zero mean weighing at least
        ``MEAN_SIDESLIP`` over the maneuver, however few its samples; 'mean' takes a zero
        mean over the whole maneuver (``beta_pseudo_std`` per sample), as in turbulence,
        without GPS and in the campaign's calibration pass. On the
        still-air real-like f16 record (``benchmarks/bench_real_like.py --turbulence
        none``) 'trim' more than halved the sideslip error (7.5e-4 -> 3.1e-4 rad RMS); a rudder
        doublet's true mean sideslip is not zero, and the weak zero mean had left its
        offset to the filter's slight model errors (2.5e-3 rad on a flight-test course).
    velocity_random_walk : float
        Without accelerometers: process noise of the body velocities [m/s^2 per step,
        1 sigma] (a random walk observed by the air data).
    estimate_lags : bool
        Estimate each air-data and attitude channel's time lag against the reconstruction
        (known lags go in metadata ``sensor_geometry.lag_s`` and are undone first).
    apply_estimated_lags : bool
        When a channel lags significantly (beyond 3 sigma and half a sample or 0.02 s, in
        most maneuvers), undo the median estimated lag (on top of any given one) and
        reconstruct again, at most 3 times while a significant lag remains
        (``Reconstruction.lags_applied``). Needs ``estimate_lags``.
    rate_integration : {'auto', 'euler', 'trapezoid', 'cubic'}
        How the IMU samples drive one step of the kinematic model: 'euler', the rates at
        the start of the step and the specific force's trapezoid (what JSBSim does at its
        100 Hz step, so exact for the simulator's full-rate data); 'trapezoid', the mean of
        the step's two samples for the rates too; 'cubic', for a record sampled coarser
        than the aircraft moves (10-20 Hz): the mean of every input over the step through
        the cubic of its four nearest samples
        (:func:`~simplexspline.aero.reconstruction.kinematics.step_mean`) and a step second
        order in dt (:func:`~simplexspline.aero.reconstruction.kinematics.propagate`). At
        10 Hz the trapezoid's error is 3 % of a 1 Hz motion and a first-order step leaves
        errors of dt g dtheta / 2: a 10 Hz record with perfect sensors had alpha errors up to
        4.6e-4 rad that way, 0.8e-4 with 'cubic'. 'auto' (default): 'euler' up to 0.01 s
        sample interval, else 'cubic'.
    air_data_calibration : {'campaign', 'maneuver'}
        With GPS, a constant wind and constant air-data errors (airspeed bias, vane offsets
        and scale factors) can be told apart only through heading changes, so one maneuver
        rarely separates them. 'campaign' (default): a first pass estimates them in every
        maneuver with GPS, their information-weighted combination is the campaign's
        calibration (the sensors are the same in every maneuver), and the second pass holds
        them there and estimates the wind per maneuver; without GPS anywhere the
        campaign's passes estimate the vane offsets and then the airspeed bias through the
        rotation terms (:mod:`~simplexspline.aero.reconstruction.observability`).
        'maneuver': one pass, everything per maneuver (without GPS: held at zero).
    imu_calibration : {'campaign', 'maneuver'}
        The IMU's biases are the same in every maneuver of a campaign flown with one IMU,
        but not every maneuver observes them: without a heading channel a straight
        maneuver cannot tell a yaw-rate gyro bias from a slow sideslip change (both keep
        the heading plus the sideslip on the GPS track), so a gyro bias of 1.7e-4 rad/s
        was estimated anywhere within +-1.2e-3 in the straight maneuvers of a real-like
        record, and the sideslip ramped by up to 1.2e-2 rad over 11 s, while every turn
        found it within 3e-5. 'campaign' (default): the first pass (that of
        ``air_data_calibration``, on the GPS maneuvers) also estimates the IMU biases,
        and each maneuver starts from the combination of the *other* maneuvers'
        estimates, with their sigma widened by the biases' own scatter between maneuvers
        (:func:`~simplexspline.aero.reconstruction.campaign_calibration.campaign_priors`):
        a prior, not a held value, so a maneuver that observes its biases still
        estimates them, and biases that change between flights give a wide prior.
        'maneuver': the filter's own prior (``prior['gyro_bias']``, ``accel_bias``).
    wind_calibration : {'campaign', 'maneuver'}
        Without a heading channel a straight maneuver cannot tell its heading from a
        crosswind. 'campaign' (default): the turns of the first pass (those of
        ``air_data_calibration``) observe the wind, and their combination
        (:func:`~simplexspline.aero.reconstruction.campaign_calibration.campaign_wind`)
        starts every straight maneuver, the heading at the GPS ground velocity's direction
        less the crab angle; on a still-air flight-test course whose record lists two
        turns, the sideslip error fell from 1.6e-3 to 3.6e-4 rad RMS (the pulses' from up
        to 6.8e-3 to 1.3e-4..7.7e-4). 'maneuver', or a campaign without turns: the
        crosswind is held at zero with the heading on the GPS track, and a lateral
        maneuver's sideslip takes the crab angle's change as its heading changes.
    calibration_maneuvers : int
        The first pass uses at most this many GPS maneuvers, those with the largest heading
        change (what separates a constant wind from air-data errors), so its cost stays
        bounded on large campaigns.
    smooth_controls : bool
        Smooth the measured control-surface positions (:data:`CONTROL_COLUMNS`) per
        maneuver by adaptive local polynomials
        (:mod:`~simplexspline.aero.data.adaptive_smoothing`): their sensor noise would
        otherwise pass into every model of them (on a light aircraft 0.02 deg of aileron
        noise is 1.8 times the noise of Cl). A channel without noise, or one that smoothing
        would not improve by its risk estimate, is left as measured. Default True.
    """

    input_noise: dict = field(default_factory=_default_input_noise)
    measurement_noise: dict = field(default_factory=_default_measurement_noise)
    prior: dict = field(default_factory=_default_prior)
    velocity_model_noise: float = 0.03
    tol: float = 0.1
    max_iter: int = 10
    smoother: bool = True
    latitude_deg: float | None = None
    earth_rotation: bool = True
    min_duration_s: float = 2.0
    accelerations: str = "auto"
    diff_half_window: int | None = None
    diff_degree: int = 4
    wind_random_walk: float = 0.0
    gust_std: object = "auto"
    gust_candidates: tuple = (0.3, 1.0, 3.0)
    gust_lengths_m: tuple = (100.0, 300.0, 1000.0)
    estimate_vane_scale: bool = True
    vane_scale_from_means: bool = True
    estimate_vane_position: bool = True
    beta_pseudo_std: float = 0.05
    sideslip_prior: str = "trim"
    velocity_random_walk: float = 5.0
    estimate_lags: bool = True
    apply_estimated_lags: bool = True
    rate_integration: str = "auto"
    air_data_calibration: str = "campaign"
    imu_calibration: str = "campaign"
    wind_calibration: str = "campaign"
    calibration_maneuvers: int = 20
    smooth_controls: bool = True

    def __post_init__(self):
        for name, keys in (("input_noise", INPUT_NAMES), ("measurement_noise",
                                                          MEASUREMENT_NAMES)):
            given = dict(getattr(self, name))
            unknown = set(given) - set(keys)
            if unknown:
                raise InputError(f"{name} has unknown channel(s) {sorted(unknown)}; "
                                 f"channels are {list(keys)}")
            full = {**(_default_input_noise() if name == "input_noise"
                       else _default_measurement_noise()), **given}
            if not all(math.isfinite(v) and v > 0 for v in full.values()):
                raise InputError(f"{name} must be positive finite numbers, got {full}")
            object.__setattr__(self, name, {k: float(v) for k, v in full.items()})
        prior = {**_default_prior(), **dict(self.prior)}
        if set(prior) != set(_default_prior()) or not all(v > 0 for v in prior.values()):
            raise InputError(f"prior must have positive entries {sorted(_default_prior())}")
        object.__setattr__(self, "prior", prior)
        if not (self.tol > 0 and self.max_iter >= 1 and self.min_duration_s >= 0
                and self.velocity_model_noise >= 0 and self.wind_random_walk >= 0
                and self.beta_pseudo_std > 0 and self.velocity_random_walk > 0):
            raise InputError("need tol > 0, max_iter >= 1, min_duration_s >= 0, "
                             "velocity_model_noise >= 0, wind_random_walk >= 0, "
                             "beta_pseudo_std > 0 and velocity_random_walk > 0")
        if not (self.gust_std == "auto" or (isinstance(self.gust_std, (int, float))
                                            and math.isfinite(self.gust_std)
                                            and self.gust_std >= 0)):
            raise InputError(f"gust_std must be 'auto' or a gust standard deviation >= 0 "
                             f"[m/s], got {self.gust_std!r}")
        for name in ("gust_candidates", "gust_lengths_m"):
            try:
                vals = tuple(float(c) for c in getattr(self, name))
            except (TypeError, ValueError):
                vals = ()
            if not vals or not all(math.isfinite(c) and c > 0 for c in vals):
                raise InputError(f"{name} must be positive numbers (gust standard deviations "
                                 f"[m/s], correlation lengths [m]), got "
                                 f"{getattr(self, name)!r}")
            object.__setattr__(self, name, vals)
        if int(self.calibration_maneuvers) != self.calibration_maneuvers or \
                self.calibration_maneuvers < 1:
            raise InputError("calibration_maneuvers must be a positive integer")
        if self.sideslip_prior not in ("trim", "mean"):
            raise InputError(f"sideslip_prior must be 'trim' or 'mean', got "
                             f"{self.sideslip_prior!r}")
        if self.rate_integration not in ("auto", "euler", "trapezoid", "cubic"):
            raise InputError("rate_integration must be 'auto', 'euler', 'trapezoid' or "
                             "'cubic'")
        for name in ("air_data_calibration", "imu_calibration", "wind_calibration"):
            if getattr(self, name) not in ("campaign", "maneuver"):
                raise InputError(f"{name} must be 'campaign' or 'maneuver', got "
                                 f"{getattr(self, name)!r}")
        if self.latitude_deg is not None and not _valid_latitude(self.latitude_deg):
            raise InputError(f"latitude_deg must be a latitude in degrees (-90 .. 90) or "
                             f"None (from the data), got {self.latitude_deg!r}")
        if self.accelerations not in ("auto", "measured", "differentiate"):
            raise InputError("accelerations must be 'auto', 'measured' or 'differentiate'")

    def to_dict(self) -> dict:
        """Plain data (for worker processes and file metadata)."""
        return asdict(self)


# ----------------------------------------------------------------------------- one maneuver

def innovation_statistics(innov: np.ndarray, innov_var: np.ndarray, max_lag: int = 20) -> dict:
    """Per-channel consistency and whiteness of filter innovations.

    Parameters
    ----------
    innov, innov_var : (n, 12) ndarray
        Innovations and their predicted variances (NaN where not measured).
    max_lag : int
        Autocorrelation lags checked for whiteness.

    Returns
    -------
    dict of str to dict
        Per measurement channel: ``samples``; ``mean`` and ``std`` of the normalised
        innovation (0 and 1 for a consistent filter); ``rho1`` the lag-1 autocorrelation;
        ``white`` the fraction of the autocorrelations at lags 1..max_lag inside the 95 %
        band :func:`~simplexspline.aero.data.whiteness.whiteness_band` (about 0.95 for a
        white sequence).
    """
    out = {}
    for j, name in enumerate(MEASUREMENT_NAMES):
        ok = np.isfinite(innov[:, j])
        n = int(ok.sum())
        if n < max_lag + 2:
            continue
        e = innov[ok, j]
        nu = e / np.sqrt(innov_var[ok, j])
        d = e - e.mean()
        # autocovariances at lags 0..max_lag as direct sums (no BLAS): O(max_lag n), where
        # an FFT of length 2n cost 30-100x more for the lengths that factor badly (2.4 ms
        # at n = 4507 against 0.07 ms; 1.2 s of a 60-maneuver reconstruction's 10 s)
        acov = np.array([(d[:n - lag] * d[lag:]).sum() for lag in range(max_lag + 1)])
        ac = acov[1:] / acov[0] if acov[0] > 0 else np.zeros(max_lag)
        out[name] = {"samples": n, "mean": float(nu.mean()), "std": float(nu.std()),
                     "rho1": float(ac[0]),
                     "white": float(np.mean(np.abs(ac) <= whiteness_band(n)))}
    return out


def _reject(maneuver: int, reason: str) -> dict:
    return {"maneuver": int(maneuver), "ok": False, "reason": reason}


def _nan_burst(x: np.ndarray, t: np.ndarray) -> tuple[float, int]:
    bad = ~np.isfinite(x)
    i = int(np.flatnonzero(bad)[0])
    j = i
    while j < len(x) and bad[j]:
        j += 1
    return float(t[i]), j - i


def reconstruct_maneuver(task: Mapping, settings: Mapping) -> dict:
    """Reconstruct one maneuver (the worker function; plain data in and out).

    Parameters
    ----------
    task : mapping
        ``maneuver`` (int), ``t`` (n,) [s], ``h`` (n,) [m] and one (n,) array per IMU input
        and per available measurement channel (SI).
    settings : mapping
        :meth:`ReconstructionSettings.to_dict`.

    Returns
    -------
    dict
        ``ok`` False with ``reason``, or ``ok`` True with ``states`` (dict of (n,) arrays:
        alpha, beta, tas, phi, theta, psi, ax..az, p..r), ``biases`` (name -> (value,
        sigma)), ``innovations`` (see :func:`innovation_statistics`), ``iterations``
        (mean, max of the iterated update), ``skipped`` (measurement samples that were NaN).
    """
    man = int(task["maneuver"])
    try:
        # small BLAS products only (26 x 26): OpenBLAS's threads gain nothing there and
        # their spinning adds CPU time (a 12-maneuver reconstruction: 2.1-2.8 s of CPU,
        # 1.6-1.8 s with one thread)
        with kernels.one_blas_thread():
            return _reconstruct(task, settings)
    except (np.linalg.LinAlgError, FloatingPointError, ValueError, ZeroDivisionError) as exc:
        return _reject(man, f"filter failed ({type(exc).__name__}: {exc})")


def _reconstruct(task: Mapping, s: Mapping) -> dict:
    man = int(task["maneuver"])
    t = np.asarray(task["t"], dtype=float)
    n = t.size
    duration = float(t[-1] - t[0]) if n > 1 else 0.0
    if n < 3 or duration < s["min_duration_s"]:
        return _reject(man, f"too short: {duration:.2f} s ({n} samples) < min_duration_s = "
                            f"{s['min_duration_s']:g} s")
    dts = np.diff(t)
    dt = float(np.median(dts))
    if np.max(np.abs(dts - dt)) > 0.01 * dt:
        k = int(np.argmax(np.abs(dts - dt)))
        return _reject(man, f"non-uniform sampling: step {dts[k]:.4g} s at t = {t[k]:.3f} s "
                            f"(median {dt:.4g} s); resample the maneuver")
    present = channels_present(task)
    for c in ESSENTIAL_MEASUREMENTS:
        if c not in task or not np.isfinite(np.asarray(task[c], dtype=float)).any():
            return _reject(man, f"channel {c!r} has no valid sample in this maneuver")
    inputs = INPUT_NAMES if present["accelerometers"] else INPUT_NAMES[3:]
    for c in inputs:
        x = np.asarray(task[c], dtype=float)
        if not np.isfinite(x).all():
            t0, k = _nan_burst(x, t)
            return _reject(man, f"NaN gap in IMU input {c!r} at t = {t0:.2f} s ({k} samples): "
                                "the inputs of the kinematic model must be complete")
    geo = task.get("geometry") or {}
    task = _corrected(task, geo, dt)
    rates = np.column_stack([task[c] for c in ("p", "q", "r")])
    cg = (np.column_stack([task[c] for c in ("x_cg", "y_cg", "z_cg")])
          if all(c in task for c in ("x_cg", "y_cg", "z_cg")) else np.zeros(3))
    cg = np.where(np.isfinite(cg), cg, 0.0)
    u = np.zeros((n, len(INPUT_NAMES)))
    u[:, 3:] = rates
    if present["accelerometers"]:
        acc = np.column_stack([task[c] for c in ("ax", "ay", "az")])
        imu = np.asarray(geo.get("imu_position_m", (0.0, 0.0, 0.0)), dtype=float)
        if np.any(imu != 0) or np.ndim(cg) == 2:
            acc = specific_force_at_cg(acc, rates, dt, imu - cg)
        u[:, :3] = acc
    mode = s["rate_integration"]
    if mode == "auto":
        mode = "euler" if dt <= SIMULATOR_STEP_MAX_S else "cubic"
    if mode == "cubic":
        # data sampled coarser than the aircraft moves: the mean of each input over the
        # step through the cubic of its four nearest samples (the trapezoid's error,
        # (omega dt)^2 / 12, is 3 % of a 1 Hz motion at 10 Hz: the reconstructed angle of
        # attack came out 1-3 % too small in its excursions with perfect sensors)
        u[:-1] = step_mean(u)
    else:
        if present["accelerometers"]:
            # trapezoidal specific force over each step (JSBSim's translational integration)
            u[:-1, :3] = 0.5 * (acc[:-1] + acc[1:])
        # the body rates enter at the start of the step (explicit Euler, as JSBSim at
        # 100 Hz), or as the mean of the step's two samples
        if mode == "trapezoid":
            u[:-1, 3:] = 0.5 * (rates[:-1] + rates[1:])
    # omega x r at each vane's given position, then omega x e_x: what a position error
    # along x adds per metre (the states xalpha, xbeta)
    arm = np.hstack([rotation_velocity(rates, np.asarray(geo.get(k, (0.0, 0.0, 0.0)),
                                                         dtype=float) - cg)
                     for k in ("alpha_vane_position_m", "beta_vane_position_m")]
                    + [rotation_velocity(rates, np.array((1.0, 0.0, 0.0)))])
    plan = observability_plan(present, estimate_vane_scale=s["estimate_vane_scale"],
                              estimate_vane_position=s["estimate_vane_position"],
                              positions_given=geo.get("vane_positions_given", ()),
                              calibration_pass=bool(s.get("calibration_pass")),
                              airspeed_pass=bool(s.get("airspeed_pass")))
    # the campaign's air-data calibration (from its GPS maneuvers) also serves the
    # maneuvers without GPS, which cannot observe it themselves
    calibration = {k: v for k, v in (task.get("calibration") or {}).items()
                   if k not in plan["held"] or plan["held"][k].startswith("unobservable")}
    for k in calibration:
        plan["held"][k] = CAMPAIGN_HELD
    z = np.full((n, len(MEASUREMENT_NAMES)), np.nan)
    for j, c in enumerate(MEASUREMENT_NAMES):
        if c in task:
            z[:, j] = task[c]
    skipped = {c: int((~np.isfinite(z[:, j])).sum()) for j, c in enumerate(MEASUREMENT_NAMES)
               if c in task and not np.isfinite(z[:, j]).all() and np.isfinite(z[:, j]).any()}
    meas_std = np.array([s["measurement_noise"][c] for c in MEASUREMENT_NAMES])
    jb = MEASUREMENT_NAMES.index("beta")
    if plan["beta_pseudo"]:
        z[:, jb] = 0.0                     # zero-mean pseudo-measurement (see observability)
        meas_std[jb] = s["beta_pseudo_std"]
    h = np.asarray(task["h"], dtype=float)
    baro = present["gps_position"] and not present["gps_vertical"] and np.isfinite(h).any()
    h_raw = h
    h = np.where(np.isfinite(h), h, np.nanmedian(h) if np.isfinite(h).any() else 0.0)
    earth = EarthModel(math.radians(s["latitude_deg"]), s["earth_rotation"])
    g = np.asarray(earth.gravity(h), dtype=float)
    if baro:
        # GPS latitude and longitude only: the barometric altitude change stands in for the
        # GPS altitude (its noise), or nothing ties the vertical motion and the angle-of-
        # attack vane offset trades against it (in turbulence: offset errors of 0.016 rad
        # on a 6-maneuver real-like record); as a geometric height change (hydrostatic:
        # a pressure altitude climbs T_ISA/T times faster than the aircraft)
        rho = np.asarray(task.get("rho", np.full(n, np.nan)), dtype=float)
        height = hydrostatic_height(h_raw, rho, g)
        if not np.isfinite(height).any():
            height = h_raw - h_raw[np.flatnonzero(np.isfinite(h_raw))[0]]
        z[:, MEASUREMENT_NAMES.index("z_gps")] = -height
        plan["wind"] += "; vertical motion from the barometric altitude (no GPS altitude)"

    q_model = np.zeros(NX)
    q_model[3:6] = ((s["velocity_model_noise"] if present["accelerometers"]
                     else s["velocity_random_walk"]) * dt) ** 2
    q_model[6:9] = (1e-6 * dt) ** 2
    q_model[9:] = 1e-16          # numerical floor on the (constant) biases
    if "wind_n" not in plan["held"]:
        q_model[18:21] = max(s["wind_random_walk"] ** 2 * dt, 1e-16)
    for name in plan["held"]:
        q_model[STATE_NAMES.index(name)] = 0.0
    noise = FilterNoise(input_std=np.array([s["input_noise"][c] for c in INPUT_NAMES]),
                        process_var=q_model, measurement_std=meas_std)
    triangle = None
    crosswind_sd = None
    campaign_wind = None
    if not present["psi"] and "wind_n" not in plan["held"]:
        triangle = _wind_triangle(z, rates, dt, present)
        turn = f"{math.degrees(MIN_HEADING_CHANGE):.0f} deg"
        if triangle is not None and triangle.heading_change < MIN_HEADING_CHANGE:
            crosswind_sd = _crosswind_prior_sd(s["prior"], float(np.nanmedian(task["tas"])))
            campaign_wind = task.get("wind_prior")
            if campaign_wind is not None and \
                    campaign_wind[2] <= INFORMATIVE_WIND * crosswind_sd:
                plan["wind"] += (f"; the heading changes by less than {turn} (no heading "
                                 f"channel): the wind starts at the campaign's turns' "
                                 f"({campaign_wind[0]:.1f}, {campaign_wind[1]:.1f}) +- "
                                 f"{campaign_wind[2]:.1f} m/s north, east, the heading at the "
                                 f"GPS track less the crab angle it makes")
                crosswind_sd = None
            else:
                campaign_wind = None
                plan["wind"] += (f"; crosswind and heading WEAK: no heading channel and the "
                                 f"heading changes by less than {turn}: the crosswind is not "
                                 f"observable, held at zero with the heading on the GPS "
                                 f"track, its sigma the prior's ({crosswind_sd:.1f} m/s)")
        elif triangle is not None:
            plan["psi"] = (f"estimated from the GPS track and the wind triangle (no heading "
                           f"channel; the maneuver turns by {turn} or more)")
    initial = initial_state(z, s["prior"], present=present, held=plan["held"], task=task,
                            triangle=triangle, wind_prior=campaign_wind)
    for k, (value, _) in calibration.items():
        initial.x[STATE_NAMES.index(k)] = value     # held there (variance at the floor)
    imu_prior = {k: v for k, v in (task.get("imu_prior") or {}).items()
                 if k not in plan["held"] and not s.get("calibration_pass")
                 and v[1] ** 2 < initial.P[STATE_NAMES.index(k), STATE_NAMES.index(k)]}
    own_prior = {}
    for k, (value, sd) in imu_prior.items():
        i = STATE_NAMES.index(k)
        own_prior[k] = (initial.x[i], initial.P[i, i])
        initial.x[i], initial.P[i, i] = value, sd ** 2
    if imu_prior:
        plan["imu_biases"] = ("estimated from a prior from the campaign's other maneuvers ("
                              + ", ".join(BIAS_STATES[k] for k in imu_prior) + ")")
    elif s["imu_calibration"] == "campaign" and not s.get("calibration_pass"):
        plan["imu_biases"] = "the filter's prior (no campaign estimate)"
    else:
        plan["imu_biases"] = "the filter's prior"
    if crosswind_sd is not None:
        initial.P[8, 8] = 1e-16     # heading held on the track: no crab, no crosswind
    tas = np.asarray(task["tas"], dtype=float)
    airspeed = float(np.nanmedian(tas))

    # in still air with GPS: zero sideslip where the maneuver flies trimmed, nothing assumed
    # elsewhere (observability.trimmed); a straight maneuver without trimmed flight a zero
    # mean of at least MEAN_SIDESLIP, whatever its sample count. The forward pass without
    # gusts takes these (not in the campaign's calibration pass: the vane's constants,
    # which it combines, moved with them on a course's straight maneuvers, the
    # angle-of-attack vane's position to 9.4 +- 0.7 m against a true 4)
    straight = heading_excursion(task) < MIN_HEADING_CHANGE
    z_still, std_still = z, meas_std
    trim = np.zeros(n, dtype=bool)
    if plan["beta_pseudo"] and s["sideslip_prior"] == "trim" \
            and present["accelerometers"] and not s.get("calibration_pass") \
            and (present["gps_position"] or present["gps_velocity"]):
        trim = trimmed(task, task.get("imu_prior"))
        z_still, std_still = z.copy(), meas_std.copy()
        if trim.sum() * dt >= TRIM_MIN_S:
            z_still[~trim, jb] = np.nan
            std_still[jb] = TRIM_SIDESLIP * math.sqrt(trim.sum())
        else:
            trim[:] = False
            if straight:
                # straight: a turn's mean sideslip is not zero (a Cessna's turns at 50 m/s:
                # 2-11e-3 rad off with this weight, 2-4e-3 without)
                std_still[jb] = min(meas_std[jb], MEAN_SIDESLIP * math.sqrt(n))

    def forward(std: float, length_m: float) -> dict:
        """The forward pass with gusts of standard deviation ``std`` [m/s] (0: held)."""
        decay, q_gust = gust_process(std, length_m, airspeed, dt)
        q = noise.process_var.copy()
        q[GUST] = q_gust
        start = StateEstimate(initial.x.copy(), initial.P.copy())
        start.P[GUST, GUST] = np.eye(3) * max(std, 1e-8) ** 2
        for k in ({**gust_held, **straight_held} if std > 0 else straight_held):
            # states held in turbulence (GUST_HELD_*) and in straight maneuvers
            i = STATE_NAMES.index(k)
            start.P[i, i], q[i] = 1e-16, 0.0
        if std > 0:
            start.P[20, 20] = min(start.P[20, 20], s["prior"]["vertical_wind"] ** 2)
        zs, zstd = (z, noise.measurement_std) if std > 0 else (z_still, std_still)
        with np.errstate(over="raise", invalid="raise", divide="raise"):
            return run_filter(start, u, zs, dt, g, earth,
                              FilterNoise(noise.input_std, q, zstd),
                              IteratedUpdate(tol=s["tol"], max_iter=s["max_iter"]), arm=arm,
                              specific_force=present["accelerometers"], gust_decay=decay,
                              second_order=mode == "cubic")

    air_data = [c for c in ("tas", "alpha", "beta") if c != "beta" or not plan["beta_pseudo"]]
    gust_held = {k: GUST_HELD_SCALE for k in SCALE_STATES if k not in plan["held"]}
    gust_held.update({k: GUST_HELD_POSITION for k in POSITION_STATES if k not in plan["held"]})
    if straight:
        gust_held.update({k: GUST_HELD_STRAIGHT for k in ("btas", "bbeta")
                          if k not in plan["held"]})
    straight_held = {}
    if "calibration" in task and not s.get("calibration_pass"):    # the campaign's 2nd pass
        gust_held.update({k: GUST_HELD_UNCALIBRATED for k in ("btas", "balpha", "bbeta")
                          if k not in plan["held"] and k not in gust_held})
        if straight and "btas" not in plan["held"]:
            # in still air too: the campaign could not determine it, and a straight
            # maneuver cannot (the sideslip-vane offset scales with the airspeed across
            # the track, the crosswind does not: it is left to the filter)
            straight_held["btas"] = HELD_STRAIGHT

    def choose() -> GustChoice:
        if not present["accelerometers"] or s["gust_std"] == 0:
            return GustChoice(forward(0.0, math.nan), 0.0, math.nan, {}, math.nan)
        return choose_gusts(
            forward, s["gust_candidates"] if s["gust_std"] == "auto" else [s["gust_std"]],
            s["gust_lengths_m"], None if s["gust_std"] != "auto" else lambda o: (
                innovation_excess(innovation_statistics(o["innov"], o["innov_var"]),
                                  air_data)))

    gusts = choose()
    conflict = _prior_conflict(gusts.out, imu_prior)
    if conflict:
        # the maneuver contradicts the biases the others share: its model is wrong (a
        # misjudged turbulence, a glitch), and holding it to the campaign moves the error
        # into its sideslip or wind; it keeps its own estimate and is named
        for k, (value, var) in own_prior.items():
            i = STATE_NAMES.index(k)
            initial.x[i], initial.P[i, i] = value, var
        plan["imu_biases"] = ("its own estimate from the filter's prior: it contradicts the "
                              "campaign's IMU biases")
        plan["imu_conflict"] = ", ".join(f"{BIAS_STATES[k]} {z:.1f} sigma" for k, z in
                                         sorted(conflict.items(), key=lambda kv: -kv[1]))
        gusts = choose()
    out = gusts.out
    if gusts.std == 0 and trim.any():
        plan["beta"] = ("estimated from the lateral kinematics and GPS (no sideslip vane), "
                        "zero where the maneuver flies trimmed (wings level, no rotation, "
                        "the ball centred)")
    if gusts.std > 0:
        for k, why in gust_held.items():
            plan["held"].setdefault(k, why)
    for k, why in straight_held.items():
        plan["held"].setdefault(k, why)
    if s.get("calibration_pass"):
        if not np.isfinite(out["x_filt"]).all():
            return _reject(man, "filter diverged in the calibration pass")
        P = out["P_filt"][-1]
        estimates = {
            k: (float(out["x_filt"][-1, STATE_NAMES.index(k)]),
                float(math.sqrt(P[STATE_NAMES.index(k), STATE_NAMES.index(k)])),
                float(math.sqrt(initial.P[STATE_NAMES.index(k), STATE_NAMES.index(k)])))
            for k in CALIBRATION_STATES + IMU_STATES if k not in plan["held"]}
        # a vane's constants together (a maneuver at one angle of attack observes the
        # offset plus the scale error times that angle only: combine_joint)
        joint = {}
        for vane, group in VANE_STATES.items():
            free = tuple(k for k in group if k in estimates)
            if len(free) > 1:
                i = [STATE_NAMES.index(k) for k in free]
                joint[vane] = (free, out["x_filt"][-1, i].astype(float),
                               P[np.ix_(i, i)].astype(float),
                               np.sqrt(np.diag(initial.P)[i]).astype(float))
        # a turn without a heading channel observes the wind (campaign_wind)
        wind = None
        if triangle is not None and triangle.heading_change >= MIN_HEADING_CHANGE:
            wind = tuple((float(out["x_filt"][-1, 18 + j]), float(math.sqrt(P[18 + j, 18 + j])),
                          float(s["prior"]["wind"])) for j in range(2))
        return {"maneuver": man, "ok": True, "gusts": gusts.std, "wind": wind,
                "altitude": float(np.nanmedian(h)), "calibration": estimates,
                "joint": joint}
    innov = out["innov"]
    stats = innovation_statistics(innov, out["innov_var"])
    if plan["beta_pseudo"]:
        stats.pop("beta", None)
    worst = max((abs(v["mean"]) + v["std"] for v in stats.values()), default=0.0)
    if not np.isfinite(out["x_filt"]).all() or worst > 50:
        causes = likely_causes(task, dt, stats, innov, present, MEASUREMENT_NAMES)
        return _reject(man, f"filter diverged (normalised innovations up to {worst:.3g} "
                            "sigma); likely causes: " + (causes or "none of the checks fired: "
                                                         "check the units and signs of the "
                                                         "channels"))
    if s["smoother"]:
        xs, _ = rts_smooth(out)
    else:
        xs = out["x_filt"]
    Pend = out["P_filt"][-1]
    sd_end = np.sqrt(np.maximum(Pend.diagonal(), 0.0))
    # against the filter's own prior: a state the campaign's prior determines is known
    own_var = initial.P.diagonal().copy()
    for k, (_value, var) in own_prior.items():
        own_var[STATE_NAMES.index(k)] = var
    ratio = variance_reduction(np.sqrt(own_var), sd_end)
    biases = {}
    for name, ch in {**BIAS_STATES, **{w: w for w in WIND_STATES},
                     **{k: k for k in SCALE_STATES},
                     **{k: k for k in POSITION_STATES}}.items():
        i = STATE_NAMES.index(name)
        biases[ch] = (float(xs[-1, i]), float(calibration[name][1] if name in calibration
                                              else sd_end[i]))
    if crosswind_sd is not None:
        # the filter's sigma is conditional on the held heading: add the prior's along
        # the crosswind (perpendicular to the ground track)
        chi = _ground_track(z)
        c = np.array([-math.sin(chi), math.cos(chi)])
        cov = Pend[18:20, 18:20] + crosswind_sd ** 2 * np.outer(c, c)
        for j, w in enumerate(WIND_STATES[:2]):
            biases[w] = (biases[w][0], float(math.sqrt(cov[j, j])))
    held = {BIAS_STATES.get(k, k): v for k, v in plan["held"].items()}
    weak = sorted(BIAS_STATES.get(k, k) for k in (*STATE_NAMES[9:GUST.start],
                                                  *POSITION_STATES)
                  if k not in plan["held"] and ratio[STATE_NAMES.index(k)] > 0.5)
    # air-relative velocity at the c.g.: V_b - C_bn W
    air = _air_velocity(xs)
    uu, vv, ww = air[:, 0], air[:, 1], air[:, 2]
    V = np.sqrt(uu * uu + vv * vv + ww * ww)
    states = {
        "alpha": np.arctan2(ww, uu), "beta": np.arcsin(vv / V), "tas": V,
        "phi": xs[:, 6], "theta": xs[:, 7],
        "psi": ((xs[:, 8] + math.pi) % (2 * math.pi) - math.pi if plan["psi_output"]
                else np.full(n, np.nan)),
    }
    for j, c in enumerate(INPUT_NAMES):
        if j < 3 and not present["accelerometers"]:
            states[c] = np.full(n, np.nan)
        elif j < 3:
            states[c] = acc[:, j] - xs[:, 9 + j]
        else:
            states[c] = rates[:, j - 3] - xs[:, 9 + j]
    if "wind_n" not in plan["held"]:
        for j, c in enumerate(WIND_STATES):       # steady wind plus gusts
            states[c] = xs[:, 18 + j] + xs[:, GUST.start + j]
    lags = _lag_estimates(xs, z, arm, dt, plan) if s["estimate_lags"] else {}
    if s["estimate_lags"] and gusts.std > 0 and present["accelerometers"]:
        # in gusts the states follow a late vane: its lag against the aerodynamic force
        for c, est in _lags_against_forces(z, acc, rates, V, task, dt, plan).items():
            if est is None:
                lags.pop(c, None)        # not told here: the reconstruction's says nothing
            else:
                lags[c] = est
    observability = {k: plan[k] for k in ("beta", "psi", "wind", "forces", "imu_biases",
                                          "imu_conflict") if k in plan}
    vane_means = None
    if s.get("vane_means") and gusts.std > 0 \
            and (present["gps_position"] or present["gps_velocity"]):
        # the kinematics without the vane: a filter that reads a vane at the wrong scale
        # leans its states towards it (on a global5000 course whose vane read 1.25x the
        # means gave 0.185 with the vane read, 0.196 without; truth 0.25)
        ja = MEASUREMENT_NAMES.index("alpha")
        vane = z[:, ja].copy()
        z[:, ja] = np.nan
        try:
            blind = forward(gusts.std, gusts.length_m)
        except FloatingPointError:
            blind = None
        z[:, ja] = vane
        if blind is not None and np.isfinite(blind["x_filt"]).all():
            vane_means = _vane_means(rts_smooth(blind)[0] if s["smoother"]
                                     else blind["x_filt"], z, arm)
    return {"maneuver": man, "ok": True, "states": states, "biases": biases,
            "held": held, "weak": weak, "observability": observability, "lags": lags,
            "vane_means": vane_means,
            "innovations": stats, "skipped": skipped,
            "iterations": (float(out["iterations"].mean()), int(out["iterations"].max())),
            "gusts": {"std": gusts.std,
                      "length_m": gusts.length_m if gusts.std else None,
                      "time_constant_s": gusts.length_m / airspeed if gusts.std else None,
                      "still_air_excess": gusts.evidence,
                      "loglik": {f"{a:g} m/s, {b:g} m": v
                                 for (a, b), v in gusts.scores.items()}}}


def _vane_means(xs: np.ndarray, z: np.ndarray, arm) -> tuple | None:
    """The maneuver's mean angle of attack at the vane from the kinematics alone (the
    smoothed ground velocity and attitude, the steady horizontal wind; no gusts, no
    vertical wind, no vane offset or scale error), the vane's mean reading minus it [rad],
    and the samples: one point of
    :func:`~simplexspline.aero.reconstruction.campaign_calibration.vane_scale_from_means`.
    None without vane readings."""
    j = MEASUREMENT_NAMES.index("alpha")
    at = xs.copy()
    at[:, GUST] = 0.0
    at[:, [STATE_NAMES.index(k) for k in ("wind_d", "kalpha", "balpha")]] = 0.0
    kinematic = _predicted(at, arm)[:, j]
    ok = np.isfinite(z[:, j]) & np.isfinite(kinematic)
    if ok.sum() < 10:
        return None
    return (float(kinematic[ok].mean()), float((z[ok, j] - kinematic[ok]).mean()),
            int(ok.sum()))


def _air_velocity(xs: np.ndarray) -> np.ndarray:
    """Air-relative body velocity ``V_b - C_bn W`` per sample, (n, 3)."""
    cf, sf = np.cos(xs[:, 6]), np.sin(xs[:, 6])
    ct, st = np.cos(xs[:, 7]), np.sin(xs[:, 7])
    cp, sp = np.cos(xs[:, 8]), np.sin(xs[:, 8])
    wn, we, wd = (xs[:, 18 + j] + xs[:, GUST.start + j] for j in range(3))   # wind + gust
    # C_bn W (rows of C_bn = columns of C_nb)
    wx = ct * cp * wn + ct * sp * we - st * wd
    wy = (sf * st * cp - cf * sp) * wn + (sf * st * sp + cf * cp) * we + sf * ct * wd
    wz = (cf * st * cp + sf * sp) * wn + (cf * st * sp - sf * cp) * we + cf * ct * wd
    return xs[:, 3:6] - np.column_stack([wx, wy, wz])


#: Channels whose time lag is estimated against the reconstruction (diagnostic).
_LAG_CHANNELS = ("tas", "alpha", "beta", "phi", "theta")
#: The position state of each vane channel.
_POSITION_OF = {ch: k for k, ch in POSITION_STATES.items()}


def _predicted(xs: np.ndarray, arm) -> np.ndarray:
    """Predicted measurements of every smoothed state, (n, 12)."""
    if filter_kernels.HAVE_NUMBA:
        hx = np.empty((xs.shape[0], len(MEASUREMENT_NAMES)))
        filter_kernels.measure_series(
            np.ascontiguousarray(xs), np.zeros((xs.shape[0], 9)) if arm is None
            else np.ascontiguousarray(arm, dtype=float), hx)
        return hx
    return np.array([measure(xs[k], None, None if arm is None else arm[k])
                     for k in range(xs.shape[0])])


def _lag_estimates(xs: np.ndarray, z: np.ndarray, arm, dt: float, plan: Mapping) -> dict:
    """Per channel: (lag, sigma) [s] of the measurement against the smoothed states.

    A vane whose position the sensor geometry does not give is compared with the
    reconstruction at the position it gives (or its estimate's start), the position's
    effect fitted with the lag
    (:func:`~simplexspline.aero.reconstruction.sensor_corrections.estimate_lag`)."""
    hx = _predicted(xs, arm)
    # a position the sensor geometry does not give: fitted with the lag
    free = [k for k in POSITION_STATES if plan["held"].get(k) != POSITION_GIVEN]
    given = ones = None
    if free:
        at = xs.copy()
        at[:, [STATE_NAMES.index(k) for k in free]] = 0.0
        given = _predicted(at, arm)
        at[:, [STATE_NAMES.index(k) for k in free]] = 1.0
        ones = _predicted(at, arm) - given        # per metre of position error
    out = {}
    for c in _LAG_CHANNELS:
        if c == "beta" and plan["beta_pseudo"]:
            continue
        j = MEASUREMENT_NAMES.index(c)
        if not np.isfinite(z[:, j]).any():
            continue
        if given is not None and _POSITION_OF.get(c) in free:
            lag, sd = estimate_lag(z[:, j] - given[:, j], np.gradient(given[:, j], dt),
                                   ones[:, j])
        else:
            lag, sd = estimate_lag(z[:, j] - hx[:, j], np.gradient(hx[:, j], dt))
        if math.isfinite(lag):
            out[c] = (lag, sd)
    return out


#: Per vane channel: the specific-force axis that follows its angle without delay, the
#: body rates (over V) that also enter that force or the vane's reading (``omega x r``),
#: and the control surfaces that enter the force (an elevator leads the angle of attack
#: it makes: without it one turbulent F-16 3211 at 100 Hz put the vane 0.055 s early).
_FORCE_OF = {"alpha": (2, (1,), ("de",)), "beta": (1, (0, 2), ("da", "dr"))}


def _lags_against_forces(z: np.ndarray, acc: np.ndarray, rates: np.ndarray, V: np.ndarray,
                         task: Mapping, dt: float, plan: Mapping) -> dict:
    """Per vane channel measured in a maneuver with gusts: (lag, sigma) [s] against the
    specific force it drives (the normal force for the angle of attack, the lateral force
    for the sideslip; :func:`~simplexspline.aero.reconstruction.sensor_corrections.
    estimate_lag_from_response`), which replaces the estimate against the reconstruction
    (that follows the late vane through the gusts, and finds no lag).

    On a 10 Hz Cessna 172 course in light turbulence (vane 0.05 s late, 4 m ahead of the
    c.g., scale error 4 %) the per-maneuver estimates were 0.045-0.060 s, 0.056 undone;
    on an F-16 sortie -0.05..+0.14, 0.052 undone (its lift is not linear in alpha over a
    maneuver): the majority rule of :func:`significant_lags` takes the median. None
    where the force cannot tell (too few samples, the best shift at the range's edge)."""
    rho = task.get("rho")
    rho = np.ones(len(V)) if rho is None else np.asarray(rho, dtype=float)
    rho = np.where(np.isfinite(rho) & (rho > 0), rho,
                   np.nanmedian(rho) if np.isfinite(rho).any() else 1.0)
    out = {}
    for c, (axis, rate_axes, controls) in _FORCE_OF.items():
        if c == "beta" and plan["beta_pseudo"]:
            continue
        j = MEASUREMENT_NAMES.index(c)
        if not np.isfinite(z[:, j]).sum() > 20:
            continue
        response = acc[:, axis] / (rho * V * V)
        surfaces = [np.asarray(task[k], dtype=float) for k in controls
                    if k in task and np.isfinite(np.asarray(task[k], dtype=float)).all()]
        regressors = np.column_stack([rates[:, list(rate_axes)] / V[:, None], *surfaces])
        lag, sd = estimate_lag_from_response(z[:, j], response, regressors, dt)
        out[c] = (lag, sd) if math.isfinite(lag) else None
    return out


def _corrected(task: Mapping, geo: Mapping, dt: float) -> dict:
    """The maneuver's channels with the known lags and vane calibrations undone."""
    task = dict(task)
    for c, lag in (geo.get("lag_s") or {}).items():
        if c in task and lag:
            task[c] = undo_lag(task[c], dt, float(lag), hold=c in INPUT_NAMES)
    for c in ("alpha", "beta"):
        if c in task:
            scale = float(geo.get(f"{c}_vane_scale", 1.0))
            offset = float(geo.get(f"{c}_vane_offset_rad", 0.0))
            if scale != 1.0 or offset != 0.0:
                task[c] = (np.asarray(task[c], dtype=float) - offset) / scale
    return task


def _wind_triangle(z: np.ndarray, rates: np.ndarray, dt: float,
                   present: Mapping) -> WindTriangle | None:
    """The wind triangle of one maneuver from its GPS positions, else integrated GPS
    velocities (:func:`~simplexspline.aero.reconstruction.wind_triangle.wind_triangle`)."""
    col = {c: z[:, j] for j, c in enumerate(MEASUREMENT_NAMES)}
    if present["gps_position"]:
        north, east = col["x_gps"], col["y_gps"]
    else:                                   # integrated velocities, gaps interpolated
        k = np.arange(z.shape[0])
        ok = np.isfinite(col["vn_gps"]) & np.isfinite(col["ve_gps"])
        north = np.cumsum(np.interp(k, k[ok], col["vn_gps"][ok])) * dt
        east = np.cumsum(np.interp(k, k[ok], col["ve_gps"][ok])) * dt
    return wind_triangle(dt, col["tas"], col["alpha"],
                         col["beta"] if present["beta"] else None, col["phi"], col["theta"],
                         rates[:, 1], rates[:, 2], north, east)


def _gps_track(z: np.ndarray) -> float:
    """Ground track [rad] at the start: GPS velocity, else the first ~2 s of positions."""
    jn, je = MEASUREMENT_NAMES.index("vn_gps"), MEASUREMENT_NAMES.index("ve_gps")
    ok = np.flatnonzero(np.isfinite(z[:, jn]) & np.isfinite(z[:, je]))
    if ok.size:
        return math.atan2(z[ok[0], je], z[ok[0], jn])
    jx, jy = MEASUREMENT_NAMES.index("x_gps"), MEASUREMENT_NAMES.index("y_gps")
    ok = np.flatnonzero(np.isfinite(z[:, jx]) & np.isfinite(z[:, jy]))
    if ok.size < 2:
        return math.nan
    a, b = ok[0], ok[min(ok.size - 1, 200)]
    return math.atan2(z[b, jy] - z[a, jy], z[b, jx] - z[a, jx])


def _ground_velocity(z: np.ndarray, dt: float) -> tuple[float, float]:
    """Ground velocity (north, east) [m/s] at the start of a maneuver: the first GPS
    velocity, else the slope of a straight line through the GPS positions of the first
    :data:`_GROUND_VELOCITY_S` seconds (sample interval ``dt`` [s]); NaN without either."""
    jn, je = MEASUREMENT_NAMES.index("vn_gps"), MEASUREMENT_NAMES.index("ve_gps")
    ok = np.flatnonzero(np.isfinite(z[:, jn]) & np.isfinite(z[:, je]))
    if ok.size:
        return float(z[ok[0], jn]), float(z[ok[0], je])
    jx, jy = MEASUREMENT_NAMES.index("x_gps"), MEASUREMENT_NAMES.index("y_gps")
    if not dt > 0:
        return math.nan, math.nan
    k = np.arange(min(len(z), max(2, int(round(_GROUND_VELOCITY_S / dt)))))
    ok = k[np.isfinite(z[k, jx]) & np.isfinite(z[k, jy])]
    if ok.size < 2:
        return math.nan, math.nan
    t = ok * dt
    return (float(np.polyfit(t, z[ok, jx], 1)[0]), float(np.polyfit(t, z[ok, jy], 1)[0]))


#: Span [s] of the GPS positions whose straight line gives a maneuver's initial ground
#: velocity (:func:`_ground_velocity`): at 10 Hz and 3 m of position noise, 10 s at 200 m/s
#: fix its direction to about 5e-4 rad.
_GROUND_VELOCITY_S = 10.0


def _ground_track(z: np.ndarray) -> float:
    """Mean ground track [rad] of a maneuver: first to last GPS position, else the mean
    GPS velocity."""
    jx, jy = MEASUREMENT_NAMES.index("x_gps"), MEASUREMENT_NAMES.index("y_gps")
    ok = np.flatnonzero(np.isfinite(z[:, jx]) & np.isfinite(z[:, jy]))
    if ok.size >= 2:
        return math.atan2(z[ok[-1], jy] - z[ok[0], jy], z[ok[-1], jx] - z[ok[0], jx])
    jn, je = MEASUREMENT_NAMES.index("vn_gps"), MEASUREMENT_NAMES.index("ve_gps")
    return math.atan2(float(np.nanmean(z[:, je])), float(np.nanmean(z[:, jn])))


def _crosswind_prior_sd(prior: Mapping, airspeed: float) -> float:
    """Sigma [m/s] of the crosswind when only the priors decide it (no heading channel,
    straight flight): a heading error ``d`` and a crosswind ``V d`` give the same data, so
    the wind prior and the heading prior (times the airspeed) combine along it."""
    return (prior["wind"] ** -2 + (airspeed * prior["heading"]) ** -2) ** -0.5


def _first_valid(z: np.ndarray, j: int) -> float:
    col = z[:, j]
    ok = np.flatnonzero(np.isfinite(col))
    return float(col[ok[0]]) if ok.size else math.nan


def initial_state(z: np.ndarray, prior: Mapping, *, present: Mapping | None = None,
                  held: Mapping | None = None, task: Mapping | None = None,
                  triangle: WindTriangle | None = None,
                  wind_prior: tuple | None = None) -> StateEstimate:
    """Initial state from the first valid air-data, attitude and GPS samples.

    Parameters
    ----------
    z : (n, 12) ndarray
        Measurements of one maneuver (NaN where missing).
    prior : mapping
        Initial standard deviations (:attr:`ReconstructionSettings.prior`).
    present : mapping, optional
        :func:`~simplexspline.aero.reconstruction.observability.channels_present`; None: all
        channels of ``z`` that have data, still air.
    held : mapping, optional
        States held at their prior (their standard deviation is set to 1e-8).
    task : mapping, optional
        The maneuver's columns (for given ``wind_*``).
    triangle : WindTriangle, optional
        Without a heading channel: the maneuver's wind triangle. When its heading change
        reaches :data:`~simplexspline.aero.reconstruction.wind_triangle.MIN_HEADING_CHANGE`,
        the heading and the wind start at its solution; otherwise the heading starts at the
        GPS track.
    wind_prior : (float, float, float), optional
        A straight maneuver without a heading channel: the campaign's wind (north, east
        [m/s]) and its sigma [m/s] (:func:`campaign_wind`). The wind starts there with that
        sigma, and the heading at the direction of the GPS ground velocity less the wind
        (the crab angle), its sigma the wind's over the airspeed.

    Returns
    -------
    StateEstimate
        Biases start at zero; the wind at zero, the mean of the given ``wind_*`` columns or
        the wind triangle's; the body velocity is the air data's plus the initial wind.
        The covariance is diagonal.
    """
    m = {c: _first_valid(z, j) for j, c in enumerate(MEASUREMENT_NAMES)}
    held = {} if held is None else held
    gps = present is None or present["gps_velocity"] or present["gps_position"]
    V, a = m["tas"], m["alpha"]
    b = m["beta"] if math.isfinite(m["beta"]) else 0.0
    x0 = np.zeros(NX)
    x0[0:3] = [0.0 if not math.isfinite(m[c]) else m[c] for c in ("x_gps", "y_gps", "z_gps")]
    x0[3:6] = [V * math.cos(a) * math.cos(b), V * math.sin(b), V * math.sin(a) * math.cos(b)]
    psi, psi_sd = m["psi"], prior["attitude"]
    if not math.isfinite(psi):
        track = _gps_track(z)
        if triangle is not None and triangle.heading_change >= MIN_HEADING_CHANGE:
            psi, psi_sd = triangle.psi0, prior["heading"]
            x0[18:20] = [triangle.wind_n, triangle.wind_e]
        elif math.isfinite(track) and wind_prior is not None:
            t = np.asarray(task["t"], dtype=float) if task is not None and "t" in task \
                else np.array([])
            vn, ve = _ground_velocity(z, float(np.median(np.diff(t))) if t.size > 1
                                      else math.nan)
            air_n, air_e = vn - wind_prior[0], ve - wind_prior[1]
            speed = math.hypot(air_n, air_e)
            if math.isfinite(speed) and speed > 0:
                psi = math.atan2(air_e, air_n) - b
                psi_sd = math.hypot(wind_prior[2] / speed, prior["attitude"])
                x0[18:20] = wind_prior[:2]
            else:
                psi, psi_sd, wind_prior = track, prior["heading"], None
        elif math.isfinite(track):
            psi, psi_sd = track, prior["heading"]
        else:
            psi, psi_sd = 0.0, 1e-8      # not observable and not needed
    x0[6:9] = [m["phi"], m["theta"], psi]
    if task is not None and all(c in task for c in WIND_STATES):
        x0[18:21] = [float(np.nanmean(task[c])) for c in WIND_STATES]
    # Earth-relative body velocity = air-relative + C_bn W (_air_velocity of a state at
    # rest is -C_bn W)
    at_rest = x0.copy()
    at_rest[3:6] = 0.0
    x0[3:6] -= _air_velocity(at_rest[None, :])[0]
    sd = np.empty(NX)
    sd[0:3] = prior["position"]
    sd[3:6] = prior["velocity"]
    if not math.isfinite(m["beta"]):
        sd[4] = max(prior["velocity"], 0.05 * V)
    if gps and "wind_n" not in held:
        sd[3:6] = np.maximum(sd[3:6], prior["wind"])
    sd[6:8] = prior["attitude"]
    sd[8] = psi_sd
    sd[9:12] = prior["accel_bias"]
    sd[12:15] = prior["gyro_bias"]
    sd[15:17] = prior["vane_bias"]
    sd[17] = prior["tas_bias"]
    sd[18:21] = prior["wind"]
    if wind_prior is not None and not math.isfinite(m["psi"]):
        sd[18:20] = wind_prior[2]
    sd[21:23] = prior["vane_scale"]
    sd[GUST] = 1e-8                  # gusts start held (the driver sets their variance)
    for name in POSITION_STATES:
        sd[STATE_NAMES.index(name)] = prior["vane_position"]
    for name in held:
        sd[STATE_NAMES.index(name)] = 1e-8
    return StateEstimate(x0, np.diag(sd ** 2))


# ----------------------------------------------------------------------------- campaign

def _prior_conflict(out: dict, prior: Mapping) -> dict:
    """:func:`~simplexspline.aero.reconstruction.campaign_calibration.prior_conflicts` of
    the filter's final estimate of the states with a campaign prior."""
    x, P = out["x_filt"][-1], out["P_filt"][-1]
    return prior_conflicts({k: (float(x[i]), float(P[i, i])) for k in prior
                            for i in (STATE_NAMES.index(k),)}, prior)


#: Lags [s] above this (and 3 sigma) count even when below half a sample.
MIN_LAG_S = 0.02


def significant_lags(per_maneuver: list, dt: float | None) -> dict:
    """Channels that lag the reconstruction in most maneuvers, with their median lag.

    Parameters
    ----------
    per_maneuver : list of dict
        Per maneuver, channel -> (lag, sigma) [s] (the ``lags`` of a maneuver's result).
    dt : float or None
        Sample interval [s]; a lag must exceed 3 sigma and the smaller of half a sample and
        :data:`MIN_LAG_S` to count (at 10 Hz a 0.05 s airspeed and vane lag biased the
        airspeed calibration by 2.5 m/s on a real-like record: half a sample is too coarse
        a limit there).

    Returns
    -------
    dict of str to float
        Channel -> median lag [s] over the maneuvers where it is significant, for the
        channels significant in more than half of the maneuvers.
    """
    lags: dict = {}
    for r in per_maneuver:
        for ch, (lag, sd) in r.items():
            if abs(lag) > 3 * sd and abs(lag) > (MIN_LAG_S if dt is None
                                                 else min(dt / 2, MIN_LAG_S)):
                lags.setdefault(ch, []).append(lag)
    return {ch: float(np.median(v)) for ch, v in lags.items()
            if len(v) > len(per_maneuver) / 2}



@dataclass
class Reconstruction:
    """The result of :func:`reconstruct`.

    Attributes
    ----------
    data : pandas.DataFrame
        The accepted maneuvers in the flight-data schema with reconstructed ``alpha, beta,
        tas, phi, theta, psi``, bias-corrected ``ax, ay, az, p, q, r``, the ``pdot, qdot,
        rdot`` used, and the added columns ``CX, CY, CZ, Cl, Cm, Cn, phat, qhat, rhat``;
        the control surfaces smoothed (``settings.smooth_controls``); every other column
        (``true_*``, ...) is kept. Metadata in ``data.attrs``
        with the key ``reconstruction`` (settings, biases, innovation statistics, rejected
        maneuvers, thrust handling).
    maneuvers : dict of int to dict
        Per accepted maneuver: ``biases`` (channel -> (value, sigma)), ``innovations``,
        ``iterations`` (mean, max), ``skipped`` (NaN measurement samples per channel).
    rejected : dict of int to str
        Maneuvers that could not be reconstructed, with the reason.
    thrust_subtracted : bool
        False when the coefficients include thrust (no thrust columns).
    accelerations : str
        'measured' or 'differentiated': where pdot, qdot, rdot came from.
    unused_channels : list of str
        Measurement channels absent from the table (not used by the filter).
    settings : ReconstructionSettings
    thrust : {'columns', 'model', 'included'}
        Where the subtracted thrust came from; 'included': none subtracted (in CX).
    lags_applied : dict of str to float
        Channel -> lag [s] undone before the filter (given in metadata plus estimated, see
        ``ReconstructionSettings.apply_estimated_lags``).
    moment_reference : dict
        The point ``Cl, Cm, Cn`` are about: ``point_m`` (x, y, z [m] in the frame of the
        c.g. columns; None: the c.g.) and ``source``
        (:func:`~simplexspline.aero.data.coefficients.aerodynamic_coefficients`).
    latitude : dict
        The latitude the Earth model used: ``deg`` and ``source`` (settings, metadata
        ``latitude_deg`` or assumed).
    control_smoothing : dict
        Control column -> ``noise_std`` (median estimated sensor noise, its unit),
        ``risk_ratio`` (median estimated error after smoothing over that noise),
        ``smoothed`` and ``runs`` (maneuver runs smoothed, of those long enough); empty
        when ``smooth_controls`` is off.
    calibration : dict
        The campaign's air-data calibration (``air_data_calibration='campaign'``): state
        -> (value, sigma); empty when none.
    calibration_excluded : dict
        State -> {maneuver: (value, sigma, z)}: first-pass estimates left out of the
        campaign calibration, z sigma from the others'
        (:func:`~simplexspline.aero.reconstruction.campaign_calibration.combine_estimates`).
    imu_calibration : dict
        IMU bias state (``bax`` .. ``br``) -> (value, sigma): the campaign's estimate, the
        prior of every maneuver outside the first pass (``imu_calibration='campaign'``;
        those in it start from the others' estimates).
    """

    data: object
    maneuvers: dict
    rejected: dict
    thrust_subtracted: bool
    accelerations: str
    unused_channels: list
    settings: ReconstructionSettings
    thrust: str = "columns"
    lags_applied: dict = field(default_factory=dict)
    moment_reference: dict = field(default_factory=lambda: {"point_m": None,
                                                            "source": "the c.g."})
    latitude: dict = field(default_factory=lambda: {"deg": ASSUMED_LATITUDE_DEG,
                                                    "source": "assumed"})
    control_smoothing: dict = field(default_factory=dict)
    calibration: dict = field(default_factory=dict)
    calibration_excluded: dict = field(default_factory=dict)
    imu_calibration: dict = field(default_factory=dict)

    def sensors(self) -> dict:
        """What the reconstruction gave for each missing or estimated quantity.

        Returns
        -------
        dict
            ``beta``, ``psi``, ``wind``, ``forces``, ``imu_biases`` (where each
            maneuver's IMU-bias prior came from): statement -> number of maneuvers;
            ``held``: state -> reason (held at its prior, not estimated: unobservable or
            no sensor); ``weakly_observed``: states whose final sigma exceeds half their
            prior in most maneuvers; ``lags_s``: channel -> median estimated lag [s] over
            the maneuvers where it is significant (:func:`significant_lags`); ``gusts``:
            in how many maneuvers turbulence was found and how strong;
            ``thrust``, ``angular_accelerations``; ``flags``: coefficient -> why its data
            are incomplete or its inputs unreliable.
        """
        out: dict = {}
        ms = list(self.maneuvers.values())
        for key in ("beta", "psi", "wind", "forces", "imu_biases"):
            counts: dict = {}
            for r in ms:
                st = r["observability"][key]
                counts[st] = counts.get(st, 0) + 1
            out[key] = counts
        held: dict = {}
        for r in ms:
            for k, why in r["held"].items():
                held.setdefault(k, why)
        out["held"] = held
        weak: dict = {}
        for r in ms:
            for k in r["weak"]:
                weak[k] = weak.get(k, 0) + 1
        out["weakly_observed"] = sorted(k for k, c in weak.items() if c > len(ms) / 2)
        dt = None
        if len(self.data) > 1:
            tt = self.data["t"].to_numpy(dtype=float)
            dt = float(np.median(np.abs(np.diff(tt))))
        out["lags_s"] = significant_lags([r["lags"] for r in ms], dt)
        stds = [r["gusts"]["std"] for r in ms if "gusts" in r]
        gusty = [x for x in stds if x > 0]
        out["gusts"] = (f"gusts estimated in {len(gusty)} of {len(stds)} maneuvers (std "
                        f"{min(gusty):g}-{max(gusty):g} m/s per axis, chosen by the "
                        f"likelihood), still air in the others" if gusty else
                        "still air in every maneuver (no gusts in the innovations)")
        out["thrust"] = {"columns": "subtracted (thrust_* columns)",
                         "model": "subtracted (thrust model)",
                         "included": "INCLUDED in CX (no thrust columns, no thrust model), "
                                     "as in the paper"}[self.thrust]
        out["angular_accelerations"] = self.accelerations
        flags = {}
        if any(st.startswith("NOT computed") for st in out["forces"]):
            for c in ("CX", "CY", "CZ"):
                flags[c] = "not computed in some or all maneuvers (no accelerometers)"
        if any(st.startswith("NOT OBSERVABLE") for st in out["beta"]):
            for c in ("CY", "Cl", "Cn"):
                flags.setdefault(c, "beta not observable (no sideslip vane, no GPS): models "
                                    "in beta unreliable")
        if self.thrust == "included":
            flags.setdefault("CX", "includes thrust")
        if str(held.get("tas", "")).startswith("unobservable"):
            flags["all"] = ("airspeed bias unobservable (no GPS, and the campaign's "
                            "rotations did not pin it) and held at zero: a bias b in V "
                            "scales every coefficient by about 1 - 2 b / V (0.5 % per 0.5 "
                            "m/s at 200 m/s), alike in all maneuvers; give a known airspeed "
                            "calibration, GPS, or more maneuvers with pitch and yaw rates")
        out["flags"] = flags
        return out

    def bias_table(self):
        """Estimated biases per maneuver: a DataFrame with ``<channel>`` and
        ``<channel>_sigma`` columns, indexed by maneuver."""
        import pandas as pd  # optional dependency (the 'aero' extra)

        rows = {m: {k: v for ch, (val, sd) in r["biases"].items()
                    for k, v in ((ch, val), (ch + "_sigma", sd))}
                for m, r in self.maneuvers.items()}
        return pd.DataFrame.from_dict(rows, orient="index").rename_axis("maneuver")

    def summary(self) -> str:
        """Human-readable summary: biases found, innovation whiteness, rejections."""
        lines = [f"reconstructed {len(self.maneuvers)} maneuver(s), rejected "
                 f"{len(self.rejected)}; {len(self.data):,} samples"]
        if self.maneuvers:
            bt = self.bias_table()
            lines.append("estimated biases (median over maneuvers, median sigma):")
            for ch in (*BIAS_STATES.values(), *WIND_STATES, *SCALE_STATES,
                       *POSITION_STATES):
                lines.append(f"  {ch:>6s}: {bt[ch].median(): .4g} +- "
                             f"{bt[ch + '_sigma'].median():.2g}")
            lines.append("innovations (median over maneuvers): normalised mean, std "
                         "(1 = consistent), whiteness (fraction of lags 1-20 in the 95% band)")
            for ch in MEASUREMENT_NAMES:
                st = [r["innovations"][ch] for r in self.maneuvers.values()
                      if ch in r["innovations"]]
                if st:
                    lines.append(f"  {ch:>6s}: {np.median([s['mean'] for s in st]): .2f} "
                                 f"{np.median([s['std'] for s in st]):.2f} "
                                 f"{np.median([s['white'] for s in st]):.2f}")
        if self.unused_channels:
            lines.append(f"channels not in the data (not used): {self.unused_channels}")
        if self.maneuvers:
            sens = self.sensors()
            lines.append("sensors and observability (statement: maneuvers):")
            for key in ("beta", "psi", "wind", "forces", "imu_biases"):
                for st, c in sens[key].items():
                    lines.append(f"  {key}: {st}: {c}")
            lines.append(f"  turbulence: {sens['gusts']}")
            for k, why in sens["held"].items():
                lines.append(f"  {k}: not estimated, {why}")
            if sens["weakly_observed"]:
                lines.append(f"  weakly observed (sigma > half the prior in most maneuvers): "
                             f"{sens['weakly_observed']}")
            for ch, lag in self.lags_applied.items():
                lines.append(f"  {ch}: lag {lag:.3g} s undone before the filter (given and "
                             "estimated)")
            for k, (value, sd) in self.calibration.items():
                lines.append(f"  {k}: campaign calibration {value:.4g} +- {sd:.2g}")
            for k, (value, sd) in self.imu_calibration.items():
                lines.append(f"  {BIAS_STATES[k]} bias: campaign estimate {value:.4g} +- "
                             f"{sd:.2g} (each maneuver's prior)")
            conflicts = {m: r["observability"]["imu_conflict"]
                         for m, r in sorted(self.maneuvers.items())
                         if "imu_conflict" in r["observability"]}
            if conflicts:
                lines.append("  IMU biases: contradicting the campaign's, so estimated from the "
                             "filter's own prior in maneuver(s) " + "; ".join(
                                 f"{m} ({why})" for m, why in conflicts.items())
                             + " (a model error there if far: turbulence taken for still air, "
                             "a glitch, another IMU)")
            for k, out in self.calibration_excluded.items():
                for m, (value, sd, z) in sorted(out.items()):
                    if z is None:
                        lines.append(f"  {k}: maneuver {m}'s estimate {value:.4g} +- {sd:.2g} "
                                     f"not used as the campaign calibration: {LONE_IN_GUSTS}")
                        continue
                    lines.append(f"  {k}: maneuver {m}'s estimate {value:.4g} +- {sd:.2g} "
                                 f"left out of the campaign calibration, with its other "
                                 f"estimates ({z:.1f} sigma from the others': check that "
                                 f"maneuver's {'IMU' if k in IMU_STATES else 'air data'})")
            for ch, lag in sens["lags_s"].items():
                lines.append(f"  {ch}: lags the reconstruction by {lag:.3g} s (median): set "
                             f"metadata sensor_geometry.lag_s.{ch}")
            for c, why in sens["flags"].items():
                lines.append(f"  {c}: {why}")
        for ch, st in self.control_smoothing.items():
            lines.append(f"control {ch}: " + (
                f"smoothed in {st['smoothed']} of {st['runs']} maneuver runs (sensor noise "
                f"{st['noise_std']:.2g}, estimated error after {st['risk_ratio']:.2f} of it)"
                if st["smoothed"] else "left as measured (no noise found, or smoothing would "
                                        "not reduce the error)"))
        lines.append("coefficients: thrust " + {"columns": "subtracted (thrust_* columns)",
                                                "model": "subtracted (thrust model)",
                                                "included": "INCLUDED (no thrust_* columns), "
                                                            "as in the paper"}[self.thrust]
                     + f"; angular accelerations {self.accelerations}")
        lat = self.latitude
        lines.append(f"Earth model at latitude {lat['deg']:.2f} deg ({lat['source']})")
        ref = self.moment_reference
        lines.append("moments about " + (
            ref["source"] if ref.get("point_m") is None else
            "the fixed point ({:.3f}, {:.3f}, {:.3f}) m ({}), not the moving c.g."
            .format(*ref["point_m"], ref["source"])))
        for m, r in sorted(self.maneuvers.items()):
            if r["skipped"]:
                lines.append(f"maneuver {m}: NaN measurement samples skipped {r['skipped']}")
        for m, why in sorted(self.rejected.items()):
            lines.append(f"rejected maneuver {m}: {why}")
        return "\n".join(lines)


_EXTRA_COLUMNS = ("x_cg", "y_cg", "z_cg", "rho", *WIND_STATES, "de", "da", "dr")


def _geometry(meta: Mapping) -> dict:
    """Metadata ``sensor_geometry`` as the plain dict the workers use."""
    geo = sensor_geometry(meta)
    return {"alpha_vane_position_m": geo.alpha_vane.position_m,
            "alpha_vane_scale": geo.alpha_vane.scale,
            "alpha_vane_offset_rad": geo.alpha_vane.offset_rad,
            "beta_vane_position_m": geo.beta_vane.position_m,
            "beta_vane_scale": geo.beta_vane.scale,
            "beta_vane_offset_rad": geo.beta_vane.offset_rad,
            "imu_position_m": geo.imu_position_m, "lag_s": dict(geo.lag_s),
            "given": list(geo.given), "vane_positions_given": list(geo.positions_given)}


def _tasks(df, geometry: dict | None = None) -> list[dict]:
    have = set(present_columns(df))
    cols = ["t", "h", *[c for c in (*INPUT_NAMES, *MEASUREMENT_NAMES, *_EXTRA_COLUMNS)
                        if c in have and c not in ("t", "h")]]
    cols = list(dict.fromkeys(cols))
    man = df["maneuver"].to_numpy()
    order = np.argsort(man, kind="stable")
    bounds = np.flatnonzero(np.diff(man[order])) + 1
    arrays = {c: df[c].to_numpy(dtype=float) for c in cols}
    tasks = []
    for idx in np.split(order, bounds):
        if idx.size == 0:
            continue
        idx = idx[np.argsort(arrays["t"][idx], kind="stable")]
        task = {c: arrays[c][idx] for c in cols}
        task["maneuver"] = int(man[idx[0]])
        task["geometry"] = geometry or {}
        task["rows"] = idx
        tasks.append(task)
    return tasks


class _Workers:
    """The worker processes of one reconstruction, shared by its passes (the campaign
    calibration, the maneuvers, the passes with lags undone): started on first use.

    A pool per pass started and imported the package in every worker each time (about
    1.5 s of CPU per worker, twice per pass).
    """

    def __init__(self, workers: int):
        self.workers = workers
        self._pool = None

    def pool(self) -> ProcessPoolExecutor:
        if self._pool is None:
            self._pool = ProcessPoolExecutor(
                max_workers=self.workers, mp_context=process_context(),
                initializer=ignore_interrupts)
        return self._pool

    def __enter__(self) -> _Workers:
        return self

    def __exit__(self, *exc) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True)


def _smooth_column(values: np.ndarray) -> tuple:
    """One control channel of one maneuver (time order): smoothed values and results."""
    return smooth_by_maneuver(np.zeros(values.size, dtype=np.int8), values)


def _smooth_controls(df, tasks: list, workers: _Workers) -> dict:
    """Smooth the control columns present, per maneuver; channel -> (column aligned with
    ``df``'s rows, maneuver -> list of SmoothingResult)."""
    channels = [c for c in CONTROL_COLUMNS if c in df.columns]
    jobs = [(ch, t["maneuver"], t["rows"]) for ch in channels for t in tasks]
    if not jobs:
        return {}
    columns = {ch: df[ch].to_numpy(dtype=float) for ch in channels}
    payload = [columns[ch][rows] for ch, _, rows in jobs]
    if workers.workers == 1 or len(jobs) <= 1:
        done = [_smooth_column(v) for v in payload]
    else:
        done = list(workers.pool().map(_smooth_column, payload,
                                       chunksize=max(1, len(jobs) // (4 * workers.workers))))
    out = {ch: (columns[ch].copy(), {}) for ch in channels}
    for (ch, m, rows), (values, results) in zip(jobs, done):
        out[ch][0][rows] = values
        out[ch][1][m] = results
    return out


def _run_all(tasks: list, settings: dict, workers: _Workers, progress: bool) -> list:
    from tqdm import tqdm  # optional dependency (the 'aero' extra)

    payload = [{k: v for k, v in t.items() if k != "rows"} for t in tasks]
    results: list = [None] * len(tasks)
    order = sorted(range(len(tasks)), key=lambda i: -len(tasks[i]["t"]))
    with tqdm(total=len(tasks), desc="reconstruct", unit="maneuver", disable=not progress,
              leave=False) as bar:
        if workers.workers == 1 or len(tasks) <= 1:
            for i in order:
                results[i] = reconstruct_maneuver(payload[i], settings)
                bar.update(1)
            return results
        pool = workers.pool()
        futures = {pool.submit(reconstruct_maneuver, payload[i], settings): i for i in order}
        for fut in as_completed(futures):
            results[futures[fut]] = fut.result()
            bar.update(1)
    return results


def _longest_of_each_kind(tasks: list, kinds: Mapping) -> list:
    """``tasks`` in turns over their kinds (``kinds``: maneuver -> type; one kind when
    absent), each kind's longest first: a capped calibration pass then holds some of every
    kind (on a Cessna course cut by excitation, the 14 longest straight maneuvers were all
    stationary measurements, and with no pitch input among them the vane's position came
    out at 10.4 m for 4)."""
    groups: dict = {}
    for t in sorted(tasks, key=lambda t: -len(t["rows"])):
        groups.setdefault(kinds.get(int(t["maneuver"])), []).append(t)
    out = []
    while any(groups.values()):
        for g in groups.values():
            if g:
                out.append(g.pop(0))
    return out


def _campaign_calibration(tasks: list, settings: ReconstructionSettings, workers: _Workers,
                          progress: bool, kinds: Mapping | None = None
                          ) -> tuple[dict, dict, dict, dict, list]:
    """Air-data errors shared by the campaign, from a first pass over the GPS maneuvers
    (over every maneuver with accelerometers when none has GPS: then the vane offsets and
    the IMU biases, :func:`~simplexspline.aero.reconstruction.observability.observability_plan`,
    and in a pass of its own the airspeed bias, :func:`_airspeed_without_gps`).

    Each maneuver's final estimate is a posterior of the same constant under the same
    prior; their combination counts the prior once, and an estimate too far from the
    others' is left out, with every other estimate of that maneuver
    (:func:`~simplexspline.aero.reconstruction.campaign_calibration.combine_campaign`).
    A state no maneuver of the pass estimates (the airspeed bias without GPS, which has a
    pass of its own; a vane the record lacks), or whose combined sigma is above half its
    prior (the campaign barely observes it; without GPS
    above :data:`OFFSET_SHARE_WITHOUT_GPS` of it), is left out: the second pass then holds
    it at zero when the maneuver has no GPS, or estimates it per maneuver.
    Without a heading channel only maneuvers that turn by at least
    :data:`~simplexspline.aero.reconstruction.wind_triangle.MIN_HEADING_CHANGE` are used
    when there are any.

    The same pass estimates the IMU biases (``imu_calibration``): they become each
    maneuver's prior, not held values
    (:func:`~simplexspline.aero.reconstruction.campaign_calibration.campaign_priors`).

    Returns
    -------
    calibration : dict
        State -> (value, sigma).
    excluded : dict
        State -> {maneuver: (value, sigma, z)}: the estimates left out.
    imu : dict
        IMU bias state -> (value, sigma): the prior of a maneuver not in the pass.
    imu_per_maneuver : dict
        Maneuver -> {IMU bias state: (value, sigma)}: the prior of a maneuver in the pass
        (the others' estimates).
    winds : list
        Without a heading channel: the wind that each turn of the pass observes, as
        ``(north, east, maneuver, altitude [m])`` (north and east each ``(value, sigma,
        prior sigma)`` [m/s]); empty without turns or with ``wind_calibration='maneuver'``
        (:func:`_wind_prior`).
    """
    first = [t for t in tasks if any(c in t for c in ("vn_gps", "x_gps"))]
    kept_share = 0.5          # of the prior sigma that a combined estimate may keep
    gps = bool(first)
    if not gps:
        # without GPS anywhere the pass still tells the vane offsets and the IMU biases
        # (observability: the campaign's rotations), from the maneuvers with accelerometers
        first = [t for t in tasks if channels_present(t)["accelerometers"]]
        kept_share = OFFSET_SHARE_WITHOUT_GPS
    if not first:
        return {}, {}, {}, {}, []
    first = sorted(first, key=heading_excursion, reverse=True)
    # without a heading channel a straight maneuver trades its heading against a crosswind
    # and the air-data errors with them (wind_triangle): calibrate on the turns if any,
    # except the angle-of-attack vane, which the straight maneuvers observe as well; those
    # join kind by kind, the longest first (stationary measurements each hold one angle of
    # attack for a minute and together tell the vane's offset from its scale error; the
    # pulses' pitch rates tell its position)
    # (without GPS the wind is held and no heading trades against it: every maneuver)
    turning = [t for t in first if heading_excursion(t) >= MIN_HEADING_CHANGE]
    if gps and turning and not all(channels_present(t)["psi"] for t in first):
        straight = _longest_of_each_kind(
            [t for t in first if heading_excursion(t) < MIN_HEADING_CHANGE], kinds or {})
        first = turning + straight
        turning = {int(t["maneuver"]) for t in turning}
    else:
        turning = {int(t["maneuver"]) for t in first}
    first = first[:settings.calibration_maneuvers]
    s = {**settings.to_dict(), "calibration_pass": True, "smoother": False}
    results = _run_all(first, s, workers, progress)

    def used(r: Mapping, k: str) -> bool:
        return r["ok"] and (r["maneuver"] in turning or k in STRAIGHT_CALIBRATION_STATES)

    def estimates(states) -> dict:
        return {k: [(*r["calibration"][k], r["maneuver"]) for r in results
                    if used(r, k) and k in r["calibration"]] for k in states}

    out, excluded = {}, {}
    if settings.air_data_calibration == "campaign":
        est = estimates(CALIBRATION_STATES)
        combined, excluded = combine_campaign(est)
        distrusted = {m for per in excluded.values() for m in per}
        together = set()      # a vane's constants held together (one joint estimate)
        mine = {r["maneuver"]: r["calibration"] for r in results if r["ok"]}
        for vane in VANE_STATES:
            # the maneuvers that estimate the most of the vane's constants (a maneuver with
            # gusts holds its scale and position: its offset is conditional on them)
            have = [r for r in results if r["ok"] and vane in r.get("joint", {})
                    and r["maneuver"] not in distrusted]
            if not have:
                continue
            group = max((r["joint"][vane][0] for r in have), key=len)
            joint = combine_joint(
                [(*r["joint"][vane][1:], r["maneuver"]) for r in have
                 if r["joint"][vane][0] == group and all(used(r, k) for k in group)],
                FALSE_ALARM / len(CALIBRATION_STATES))
            if joint is None:
                continue
            for i, k in enumerate(group):
                combined[k] = CombinedEstimate(float(joint.value[i]), float(joint.sigma()[i]),
                                               joint.used, {})
            # held together: the offset is the one for the scale error and position found
            # with it (JointEstimate.determined)
            held = joint.determined([est[k][0][2] for k in group])
            together |= {k for k, h in zip(group, held) if h}
            for m, z in joint.excluded.items():
                for k in group:
                    excluded.setdefault(k, {})[m] = (*mine[m][k][:2], z)
        gusty = {r["maneuver"] for r in results if r["ok"] and r.get("gusts", 0.0) > 0}
        lone = lone_in_gusts(combined, gusty, LONE_IN_GUSTS_STATES, est)
        for k, c in combined.items():
            if c is None or (c.sigma > kept_share * est[k][0][2] and k not in together):
                continue              # the campaign does not observe it: left at its prior
            if k in lone:             # one turbulent maneuver alone: nothing to check it
                excluded.setdefault(k, {}).update(lone[k])
                continue
            out[k] = (c.value, c.sigma)
        if not gps:
            airspeed = _airspeed_without_gps(first, out, s, kept_share, workers, progress)
            if airspeed is not None:
                out["btas"], left_out = airspeed
                if left_out:
                    excluded["btas"] = left_out
    imu, imu_per_maneuver = {}, {}
    if settings.imu_calibration == "campaign":
        imu, imu_per_maneuver, imu_excluded = campaign_priors(estimates(IMU_STATES))
        excluded = {**excluded, **imu_excluded}
    winds = [(*r["wind"], r["maneuver"], r["altitude"]) for r in results
             if r["ok"] and r.get("wind")] if settings.wind_calibration == "campaign" else []
    return out, excluded, imu, imu_per_maneuver, winds


def _airspeed_without_gps(tasks: list, offsets: Mapping, s: Mapping, kept_share: float,
                          workers: _Workers, progress: bool) -> tuple | None:
    """The airspeed bias of a campaign without GPS, from a pass with the vane offsets held
    at the campaign's (``offsets``): ``((value, sigma), excluded)``, or None when the
    campaign does not pin it (sigma above ``kept_share`` of the prior), every estimate
    comes from maneuvers with gusts, or no vane offset was found.

    A wrong airspeed turns the velocity through ``omega x V`` by the wrong amount, which the
    vanes see, as they see an offset; estimated in the same pass, the alpha-vane offset
    traded against it (a Cessna campaign: the offset 8 sigma off, 1e-3 rad, with the
    airspeed bias right), so the bias is found given the offsets.
    """
    if not offsets:
        return None
    staged = [{**t, "calibration": dict(offsets)} for t in tasks]
    results = _run_all(staged, {**s, "airspeed_pass": True}, workers, progress)
    est = {"btas": [(*r["calibration"]["btas"], r["maneuver"]) for r in results
                    if r["ok"] and "btas" in r["calibration"]]}
    if not est["btas"]:
        return None
    combined, excluded = combine_campaign(est)
    c = combined.get("btas")
    gusty = {r["maneuver"] for r in results if r["ok"] and r.get("gusts", 0.0) > 0}
    lone = lone_in_gusts(combined, gusty, ("btas",), est)
    if c is None or c.sigma > kept_share * est["btas"][0][2] or "btas" in lone:
        return None
    return (c.value, c.sigma), excluded.get("btas", {})


#: A straight maneuver takes the wind of the campaign's turns flown within this height [m]
#: of its own median altitude (:func:`_wind_prior`): the wind changes with altitude (a few
#: m/s per kilometre is common), and a wind from another altitude with a tight sigma would
#: set a wrong crab angle.
WIND_ALTITUDE_BAND = 300.0


def _wind_prior(task: Mapping, winds: list) -> tuple | None:
    """The wind a straight maneuver without a heading channel starts from: the combination
    of the turns' winds within :data:`WIND_ALTITUDE_BAND` of its altitude
    (:func:`~simplexspline.aero.reconstruction.campaign_calibration.campaign_wind`), or
    None."""
    h = np.asarray(task.get("h", []), dtype=float)
    if not winds or not np.isfinite(h).any():
        return None
    level = float(np.nanmedian(h))
    near = [w[:3] for w in winds if abs(w[3] - level) <= WIND_ALTITUDE_BAND]
    return campaign_wind(near) if near else None


#: Most reconstructions with estimated lags undone: the smoothed states partly follow a
#: late channel, so one estimate finds about 85 % of a lag (0.068 of 0.08 s at 100 Hz);
#: each further pass finds most of the rest, until none is significant (significant_lags).
_LAG_PASSES = 3


def _passes(df, geometry: dict, settings: ReconstructionSettings, workers: _Workers,
            progress: bool) -> tuple[list, dict, dict, dict, list]:
    """The maneuvers' tasks, the campaign calibration, the calibration estimates left out,
    the campaign's IMU biases and the per-maneuver results."""
    tasks = _tasks(df, geometry)
    calibration, excluded, imu = {}, {}, {}
    if "campaign" in (settings.air_data_calibration, settings.imu_calibration,
                      settings.wind_calibration):
        kinds = ({int(m): str(k) for m, k in df.groupby("maneuver")["maneuver_type"]
                  .first().items()} if "maneuver_type" in df.columns else {})
        calibration, excluded, imu, imu_per_maneuver, winds = _campaign_calibration(
            tasks, settings, workers, progress, kinds)
        for task in tasks:
            if settings.air_data_calibration == "campaign":
                task["calibration"] = calibration
            task["imu_prior"] = imu_per_maneuver.get(int(task["maneuver"]), imu)
            wind = _wind_prior(task, winds)
            if wind is not None:
                task["wind_prior"] = wind
    return (tasks, calibration, excluded, imu,
            _run_all(tasks, settings.to_dict(), workers, progress))


#: Test points of :func:`_test_point`: altitude bands [m] and airspeed steps (ratio).
_POINT_ALTITUDE_M, _POINT_SPEED_RATIO = 300.0, 1.05


def _test_point(task: Mapping) -> tuple:
    """The test point a maneuver was flown at: its median altitude in bands of
    ``_POINT_ALTITUDE_M`` and median airspeed in steps of ``_POINT_SPEED_RATIO`` (the
    maneuvers of one test point share an air mass)."""
    h = np.asarray(task.get("h", []), dtype=float)
    v = np.asarray(task.get("tas", []), dtype=float)
    hm = float(np.nanmedian(h)) if np.isfinite(h).any() else 0.0
    vm = float(np.nanmedian(v)) if np.isfinite(v).any() and np.nanmedian(v) > 0 else 1.0
    return (round(hm / _POINT_ALTITUDE_M), round(math.log(vm) / math.log(_POINT_SPEED_RATIO)))


def _vane_scale_in_gusts(tasks: list, results: list, calibration: Mapping,
                         settings: ReconstructionSettings, workers: _Workers,
                         progress: bool) -> dict | None:
    """The angle-of-attack vane's scale error and offset from the maneuvers' means when
    turbulence kept every maneuver from estimating the scale
    (:func:`~simplexspline.aero.reconstruction.campaign_calibration.vane_scale_from_means`):
    one more pass over the maneuvers with gusts and GPS gives each one's mean kinematic
    angle from a filter run without the vane (:func:`_vane_means`). Returns a record
    (``used_as_calibration``: its sigma is at most ``OBSERVED`` (campaign_calibration) of
    the prior's, and it becomes the campaign's ``kalpha`` and ``balpha``), or None (the
    campaign calibrates per maneuver, a maneuver or the campaign estimated the scale, too
    few maneuvers). A scale the sensor geometry gives is undone first and the means find
    the error left, as a filter in calm air does."""
    if settings.air_data_calibration != "campaign" or not settings.estimate_vane_scale \
            or not settings.vane_scale_from_means or "kalpha" in calibration:
        return None
    ok = [r for r in results if r["ok"]]
    if not ok or not all(r["held"].get("kalpha") for r in ok):
        return None                  # some maneuver estimated it itself
    gusty = {int(r["maneuver"]) for r in ok
             if r["held"].get("kalpha") == GUST_HELD_SCALE}
    chosen = [t for t in tasks if int(t["maneuver"]) in gusty]
    if len(chosen) < SCALE_FROM_MEANS_MIN:
        return None
    found = _run_all(chosen, {**settings.to_dict(), "vane_means": True}, workers, progress)
    point = {int(t["maneuver"]): _test_point(t) for t in chosen}
    means = [(*r["vane_means"], int(r["maneuver"]), point[int(r["maneuver"])])
             for r in found if r["ok"] and r.get("vane_means")]
    prior = float(settings.prior["vane_scale"])
    fit = vane_scale_from_means(means, prior=(float(settings.prior["vane_bias"]), prior))
    if fit is None:
        return None
    return {"kalpha": fit.scale, "kalpha_sd": fit.scale_sd, "balpha": fit.offset,
            "balpha_sd": fit.offset_sd, "maneuvers": list(fit.used),
            "excluded": {str(m): round(z, 2) for m, z in fit.excluded.items()},
            "angle_spread_rad": fit.spread,
            "used_as_calibration": bool(fit.scale_sd <= OBSERVED * prior)}


def _without_inconsistent(results: list, settings: ReconstructionSettings) -> list:
    """``results`` with the maneuvers whose IMU biases lie far from every other one's
    (:func:`~simplexspline.aero.reconstruction.diagnosis.inconsistent_imu`) rejected."""
    bad = inconsistent_imu({int(r["maneuver"]): r["biases"] for r in results if r["ok"]},
                           settings.prior)
    return [_reject(int(r["maneuver"]), bad[int(r["maneuver"])])
            if r["ok"] and int(r["maneuver"]) in bad else r for r in results]


def _positions_to_estimate(df, geometry: Mapping) -> bool:
    """Whether a vane present in the table has no position in the sensor geometry."""
    given = set(geometry.get("vane_positions_given", ()))
    return any(vane not in given and col in df.columns and bool(df[col].notna().any())
               for vane, col in (("alpha_vane", "alpha"), ("beta_vane", "beta")))


def reconstruct(df, metadata: Mapping | None = None, *,
                settings: ReconstructionSettings | None = None, workers: int | None = 1,
                progress: bool = False, thrust_model=None) -> Reconstruction:
    """Flight path reconstruction and aerodynamic coefficients of a flight-test campaign.

    Parameters
    ----------
    df : pandas.DataFrame
        Measured flight data in the flight-data schema (not modified).
    metadata : mapping, optional
        Schema metadata; ``df.attrs`` if None.
    settings : ReconstructionSettings, optional
        Noise model and options (defaults suit the simulator's default sensors).
    workers : int or None
        Worker processes (None: number of CPUs). The result does not depend on it.
    progress : bool
        Show a progress bar.
    thrust_model : callable or ThrustModel, optional
        Used when the table has no ``thrust_*`` columns (see
        :func:`~simplexspline.aero.data.coefficients.aerodynamic_coefficients`).

    Returns
    -------
    Reconstruction

    Raises
    ------
    FlightDataError
        The table violates the schema (naming the column), or no maneuver could be
        reconstructed (with every reason).

    Examples
    --------
    >>> rec = reconstruct(df, workers=2)                       # doctest: +SKIP
    >>> print(rec.summary())                                   # doctest: +SKIP
    >>> rec.data[["CX", "CZ", "Cm"]].describe()                # doctest: +SKIP
    """
    settings = ReconstructionSettings() if settings is None else settings
    if not isinstance(settings, ReconstructionSettings):
        raise InputError("settings must be a ReconstructionSettings")
    meta = dict(df.attrs if metadata is None else metadata)
    df = without_metadata(df)
    validate_flight_data(df, meta, nan="ignore")
    if workers is None:
        workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (
            os.cpu_count() or 1)
    if int(workers) != workers or workers < 1:
        raise InputError(f"workers must be a positive integer, got {workers!r}")
    geometry = _geometry(meta)
    latitude, latitude_source = _latitude(settings, meta)
    settings = replace(settings, latitude_deg=latitude)
    # the vanes' positions are estimated in a last pass, after the lags: a filter that
    # estimates the position of a vane whose channel is late takes the lag for a position
    # (a 0.08 s angle-of-attack lag at 150 m/s became a vane 16.5 m ahead, the angle of
    # attack 2.4x worse); the lags are found against a reconstruction at the given
    # positions, with the positions' effects fitted beside them (_lag_estimates)
    positions = settings.estimate_vane_position and _positions_to_estimate(df, geometry)
    final = settings
    if positions:
        settings = replace(settings, estimate_vane_position=False)
    with _Workers(int(workers)) as pool:          # shared by all passes
        tasks, calibration, excluded, imu, results = _passes(df, geometry, settings, pool,
                                                                    progress)
        lags_applied = {ch: float(v) for ch, v in geometry["lag_s"].items() if v}
        t = df["t"].to_numpy(dtype=float)
        dt = float(np.median(np.abs(np.diff(t)))) if t.size > 1 else None
        for _ in range(_LAG_PASSES if settings.estimate_lags and settings.apply_estimated_lags
                       else 0):
            per_maneuver = [r["lags"] for r in results if r["ok"]]
            found = significant_lags(per_maneuver, dt)
            # undo the estimated lag on top of the one undone (a channel cannot lead)
            total = {ch: lags_applied.get(ch, 0.0) + lag for ch, lag in found.items()}
            total = {ch: v for ch, v in total.items() if 0.0 < v <= 2.0}
            if not total:
                break
            # one channel per pass, the most significant: a late channel distorts the
            # reconstruction and the others then look late too (a 0.08 s angle-of-attack lag
            # made the airspeed look 0.11-0.17 s late in two of six single-maneuver tests)
            first = max(total, key=lambda ch: np.median([abs(lags[ch][0]) / lags[ch][1]
                                                         for lags in per_maneuver if ch in lags]))
            total = {first: total[first]}
            lags_applied.update(total)
            geometry = {**geometry, "lag_s": {**geometry["lag_s"], **total}}
            tasks, calibration, excluded, imu, results = _passes(df, geometry, settings, pool,
                                                                    progress)
        # a lag left in a channel (not applied, or still significant) would go into the
        # position: then the positions stay where the geometry puts them, and the lags
        # reported are those found against it
        if positions and not significant_lags([r["lags"] for r in results if r["ok"]], dt):
            settings = final
            tasks, calibration, excluded, imu, results = _passes(df, geometry, settings, pool,
                                                                    progress)
        elif positions:
            for r in results:
                for k in POSITION_STATES:
                    if r["ok"] and r["held"].get(k) == POSITION_NOT_REQUESTED:
                        r["held"][k] = POSITION_AFTER_LAGS
        results = _without_inconsistent(results, settings)
        # turbulence everywhere: the vane's scale from the maneuvers' means, then held
        vane_scale = _vane_scale_in_gusts(tasks, results, calibration, settings, pool,
                                          progress)
        if vane_scale is not None and vane_scale["used_as_calibration"]:
            calibration = {**calibration, "kalpha": (vane_scale["kalpha"],
                                                     vane_scale["kalpha_sd"]),
                           "balpha": (vane_scale["balpha"], vane_scale["balpha_sd"])}
            for task in tasks:
                task["calibration"] = calibration
            results = _without_inconsistent(_run_all(tasks, settings.to_dict(), pool,
                                                     progress), settings)
        smoothed = _smooth_controls(df, tasks, pool) if settings.smooth_controls else {}
    accepted, rejected, rows, parts = {}, {}, [], []
    for task, res in zip(tasks, results):
        m = task["maneuver"]
        if not res["ok"]:
            rejected[m] = res["reason"]
            continue
        accepted[m] = {k: res[k] for k in ("biases", "innovations", "iterations", "skipped",
                                           "held", "weak", "observability", "lags", "gusts")}
        rows.append(task["rows"])
        parts.append(res["states"])
    if not accepted:
        why = "; ".join(f"maneuver {m}: {r}" for m, r in sorted(rejected.items()))
        raise FlightDataError(f"no maneuver could be reconstructed ({why})")
    idx = np.sort(np.concatenate(rows))
    out = df.iloc[idx].copy()
    pos = np.empty(len(df), dtype=np.int64)
    pos[idx] = np.arange(idx.size)
    for name in dict.fromkeys(k for st in parts for k in st):
        col = np.full(idx.size, np.nan)
        for r, st in zip(rows, parts):
            if name in st:
                col[pos[r]] = st[name]
        out[name] = col
    smoothing = {}
    for ch, (col, per_maneuver) in smoothed.items():
        out[ch] = col[idx]
        runs = [r for m, rs in per_maneuver.items() if m in accepted for r in rs]
        done = [r for r in runs if r.gamma > 0]
        smoothing[ch] = {"runs": len(runs), "smoothed": len(done),
                         "noise_std": float(np.median([r.noise_std for r in done]))
                         if done else 0.0,
                         "risk_ratio": float(np.median([r.risk_ratio for r in done]))
                         if done else 1.0}
    coef, thrust = aerodynamic_coefficients(
        out, meta, accelerations=settings.accelerations,
        half_window=settings.diff_half_window, degree=settings.diff_degree,
        thrust_model=thrust_model)
    have = set(present_columns(df))
    thrust_source = ("columns" if all(c in have for c in THRUST_COLUMNS)
                     else "model" if thrust else "included")
    measured_acc = settings.accelerations == "measured" or (
        settings.accelerations == "auto" and all(c in df.columns
                                                 for c in ("pdot", "qdot", "rdot")))
    for c in coef.columns:
        out[c] = coef[c].to_numpy()
    unused = [c for c in MEASUREMENT_NAMES if c not in df.columns]
    rec = Reconstruction(data=out, maneuvers=accepted, rejected=rejected,
                         thrust_subtracted=thrust,
                         accelerations="measured" if measured_acc else "differentiated",
                         unused_channels=unused, settings=settings, thrust=thrust_source,
                         lags_applied=lags_applied,
                         moment_reference=dict(coef.attrs["moment_reference"]),
                         latitude={"deg": latitude, "source": latitude_source},
                         control_smoothing=smoothing, calibration=calibration,
                         calibration_excluded=excluded, imu_calibration=imu)
    sensors = rec.sensors()
    meta["reconstruction"] = jsonable({
        "method": "iterated extended Kalman filter + RTS smoother (docs/reconstruction.md)",
        "settings": settings.to_dict(),
        "thrust_subtracted": thrust, "thrust": thrust_source,
        "accelerations": rec.accelerations,
        "unused_channels": unused, "sensors": sensors,
        "sensor_geometry_given": geometry["given"],
        "lags_applied_s": lags_applied,
        "moment_reference": rec.moment_reference,
        "latitude": rec.latitude,
        "control_smoothing": smoothing,
        "air_data_calibration": calibration,
        "air_data_calibration_excluded": excluded,
        "vane_scale_from_means": vane_scale,
        "imu_calibration": imu,
        "maneuvers": {m: {k: r[k] for k in ("biases", "iterations", "innovations", "skipped",
                                            "held", "weak", "observability", "lags", "gusts")}
                      for m, r in accepted.items()},
        "rejected": rejected,
    })
    out.attrs = meta
    return rec
