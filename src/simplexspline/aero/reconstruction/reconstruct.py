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
import multiprocessing
import os
from collections.abc import Mapping
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field

import numpy as np

from simplexspline._workers import ignore_interrupts
from simplexspline._files import jsonable
from simplexspline.aero.data.coefficients import aerodynamic_coefficients
from simplexspline.aero.data.flight_data import validate_flight_data
from simplexspline.aero.data.whiteness import whiteness_band
from simplexspline.aero.reconstruction.iekf import (
    FilterNoise, IteratedUpdate, StateEstimate, rts_smooth, run_filter,
)
from simplexspline.aero.reconstruction.kinematics import (
    BIAS_STATES, INPUT_NAMES, MEASUREMENT_NAMES, NX, STATE_NAMES, EarthModel,
)
from simplexspline.aero.variables import DEG
from simplexspline.errors import FlightDataError, InputError

__all__ = ["ReconstructionSettings", "Reconstruction", "reconstruct", "reconstruct_maneuver",
           "innovation_statistics"]

#: Channels a maneuver cannot be reconstructed without (at least one valid sample each).
ESSENTIAL_MEASUREMENTS = ("tas", "alpha", "beta", "phi", "theta", "psi")


def _default_input_noise() -> dict:
    return {"ax": 0.01, "ay": 0.01, "az": 0.01, "p": 0.01 * DEG, "q": 0.01 * DEG,
            "r": 0.01 * DEG}


def _default_measurement_noise() -> dict:
    return {"x_gps": 2.0, "y_gps": 2.0, "z_gps": 4.0, "vn_gps": 0.05, "ve_gps": 0.05,
            "vd_gps": 0.1, "tas": 0.1, "alpha": 0.1 * DEG, "beta": 0.1 * DEG,
            "phi": 0.05 * DEG, "theta": 0.05 * DEG, "psi": 0.1 * DEG}


def _default_prior() -> dict:
    return {"position": 5.0, "velocity": 1.0, "attitude": 0.01, "accel_bias": 0.1,
            "gyro_bias": 2e-3, "vane_bias": 0.02, "tas_bias": 2.0}


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
        ``tas_bias`` [m/s]. Biases start at zero.
    velocity_model_noise : float
        Extra process noise on u, v, w [m/s^2 per step, 1 sigma] for model errors
        (discretisation of the simulator's integrator, about 0.03 m/s^2).
    tol : float
        Stopping criterion of the iterated measurement update: the state change the next
        iteration would make (estimated with the current gain), in units of the state's
        predicted standard deviation, must be below ``tol`` for every state.
    max_iter : int
        Maximum iterations (gain computations) per measurement update.
    smoother : bool
        Run the RTS backward smoother (recommended); otherwise the filtered states are used.
    latitude_deg : float
        Geodetic latitude of the flights [deg] (gravity, Earth rate); the simulator's 52.
    earth_rotation : bool
        Model Earth rate, Coriolis and transport rate.
    min_duration_s : float
        Shorter maneuvers are rejected.
    accelerations : {'auto', 'measured', 'differentiate'}
        Source of pdot, qdot, rdot for the moment coefficients ('auto': the columns when
        present, else smoothed differentiation of the reconstructed rates).
    diff_half_window, diff_degree : int
        Smoothed-differentiation settings (:mod:`simplexspline.aero.data.differentiation`).
    """

    input_noise: dict = field(default_factory=_default_input_noise)
    measurement_noise: dict = field(default_factory=_default_measurement_noise)
    prior: dict = field(default_factory=_default_prior)
    velocity_model_noise: float = 0.03
    tol: float = 1e-3
    max_iter: int = 10
    smoother: bool = True
    latitude_deg: float = 52.0
    earth_rotation: bool = True
    min_duration_s: float = 2.0
    accelerations: str = "auto"
    diff_half_window: int = 8
    diff_degree: int = 4

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
                and self.velocity_model_noise >= 0):
            raise InputError("need tol > 0, max_iter >= 1, min_duration_s >= 0 and "
                             "velocity_model_noise >= 0")
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
        spec = np.fft.rfft(d, 2 * n)                  # autocorrelation by FFT (no BLAS)
        acov = np.fft.irfft(spec.real ** 2 + spec.imag ** 2, 2 * n)[:max_lag + 1]
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
    u = np.column_stack([np.asarray(task[c], dtype=float) for c in INPUT_NAMES])
    for j, c in enumerate(INPUT_NAMES):
        if not np.isfinite(u[:, j]).all():
            t0, k = _nan_burst(u[:, j], t)
            return _reject(man, f"NaN gap in IMU input {c!r} at t = {t0:.2f} s ({k} samples): "
                                "the inputs of the kinematic model must be complete")
    # trapezoidal specific force over each step (JSBSim's translational integration);
    # the body rates enter at the start of the step (explicit Euler, as JSBSim)
    u[:-1, :3] = 0.5 * (u[:-1, :3] + u[1:, :3])
    z = np.full((n, len(MEASUREMENT_NAMES)), np.nan)
    for j, c in enumerate(MEASUREMENT_NAMES):
        if c in task:
            z[:, j] = task[c]
    for c in ESSENTIAL_MEASUREMENTS:
        if not np.isfinite(z[:, MEASUREMENT_NAMES.index(c)]).any():
            return _reject(man, f"channel {c!r} has no valid sample in this maneuver")
    skipped = {c: int((~np.isfinite(z[:, j])).sum()) for j, c in enumerate(MEASUREMENT_NAMES)
               if c in task and not np.isfinite(z[:, j]).all()}
    h = np.asarray(task["h"], dtype=float)
    h = np.where(np.isfinite(h), h, np.nanmedian(h) if np.isfinite(h).any() else 0.0)
    earth = EarthModel(math.radians(s["latitude_deg"]), s["earth_rotation"])
    g = np.asarray(earth.gravity(h), dtype=float)

    q_model = np.zeros(NX)
    q_model[3:6] = (s["velocity_model_noise"] * dt) ** 2
    q_model[6:9] = (1e-6 * dt) ** 2
    q_model[9:] = 1e-16          # numerical floor on the (constant) biases
    noise = FilterNoise(input_std=np.array([s["input_noise"][c] for c in INPUT_NAMES]),
                        process_var=q_model,
                        measurement_std=np.array([s["measurement_noise"][c]
                                                  for c in MEASUREMENT_NAMES]))
    with np.errstate(over="raise", invalid="raise", divide="raise"):
        out = run_filter(initial_state(z, s["prior"]), u, z, dt, g, earth, noise,
                         IteratedUpdate(tol=s["tol"], max_iter=s["max_iter"]))
    innov = out["innov"]
    stats = innovation_statistics(innov, out["innov_var"])
    worst = max((abs(v["mean"]) + v["std"] for v in stats.values()), default=0.0)
    if not np.isfinite(out["x_filt"]).all() or worst > 50:
        return _reject(man, f"filter diverged (normalised innovations up to {worst:.3g} "
                            "sigma): check the units and signs of the channels")
    if s["smoother"]:
        xs, _ = rts_smooth(out)
    else:
        xs = out["x_filt"]
    Pend = out["P_filt"][-1]
    biases = {}
    for name, ch in BIAS_STATES.items():
        i = STATE_NAMES.index(name)
        biases[ch] = (float(xs[0, i]), float(math.sqrt(Pend[i, i])))
    uu, vv, ww = xs[:, 3], xs[:, 4], xs[:, 5]
    V = np.sqrt(uu * uu + vv * vv + ww * ww)
    states = {
        "alpha": np.arctan2(ww, uu), "beta": np.arcsin(vv / V), "tas": V,
        "phi": xs[:, 6], "theta": xs[:, 7],
        "psi": (xs[:, 8] + math.pi) % (2 * math.pi) - math.pi,
    }
    for j, c in enumerate(INPUT_NAMES):
        states[c] = np.asarray(task[c], dtype=float) - xs[:, 9 + j]
    return {"maneuver": man, "ok": True, "states": states, "biases": biases,
            "innovations": stats, "skipped": skipped,
            "iterations": (float(out["iterations"].mean()), int(out["iterations"].max()))}


def _first_valid(z: np.ndarray, j: int) -> float:
    col = z[:, j]
    ok = np.flatnonzero(np.isfinite(col))
    return float(col[ok[0]]) if ok.size else math.nan


def initial_state(z: np.ndarray, prior: Mapping) -> StateEstimate:
    """Initial state from the first valid air-data, attitude and GPS samples.

    Parameters
    ----------
    z : (n, 12) ndarray
        Measurements of one maneuver (NaN where missing).
    prior : mapping
        Initial standard deviations (:attr:`ReconstructionSettings.prior`).

    Returns
    -------
    StateEstimate
        Biases start at zero; the covariance is diagonal.
    """
    m = {c: _first_valid(z, j) for j, c in enumerate(MEASUREMENT_NAMES)}
    V, a, b = m["tas"], m["alpha"], m["beta"]
    x0 = np.zeros(NX)
    x0[0:3] = [0.0 if not math.isfinite(m[c]) else m[c] for c in ("x_gps", "y_gps", "z_gps")]
    x0[3:6] = [V * math.cos(a) * math.cos(b), V * math.sin(b), V * math.sin(a) * math.cos(b)]
    x0[6:9] = [m["phi"], m["theta"], m["psi"]]
    sd = np.empty(NX)
    sd[0:3] = prior["position"]
    sd[3:6] = prior["velocity"]
    sd[6:9] = prior["attitude"]
    sd[9:12] = prior["accel_bias"]
    sd[12:15] = prior["gyro_bias"]
    sd[15:17] = prior["vane_bias"]
    sd[17] = prior["tas_bias"]
    return StateEstimate(x0, np.diag(sd ** 2))


# ----------------------------------------------------------------------------- campaign

@dataclass
class Reconstruction:
    """The result of :func:`reconstruct`.

    Attributes
    ----------
    data : pandas.DataFrame
        The accepted maneuvers in the flight-data schema with reconstructed ``alpha, beta,
        tas, phi, theta, psi``, bias-corrected ``ax, ay, az, p, q, r``, the ``pdot, qdot,
        rdot`` used, and the added columns ``CX, CY, CZ, Cl, Cm, Cn, phat, qhat, rhat``;
        every other column (surfaces, ``true_*``, ...) is kept. Metadata in ``data.attrs``
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
    """

    data: object
    maneuvers: dict
    rejected: dict
    thrust_subtracted: bool
    accelerations: str
    unused_channels: list
    settings: ReconstructionSettings

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
            for ch in BIAS_STATES.values():
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
        lines.append("coefficients: thrust " + ("subtracted (thrust_* columns)"
                                                if self.thrust_subtracted else
                                                "INCLUDED (no thrust_* columns), as in the "
                                                "paper")
                     + f"; angular accelerations {self.accelerations}")
        for m, r in sorted(self.maneuvers.items()):
            if r["skipped"]:
                lines.append(f"maneuver {m}: NaN measurement samples skipped {r['skipped']}")
        for m, why in sorted(self.rejected.items()):
            lines.append(f"rejected maneuver {m}: {why}")
        return "\n".join(lines)


def _tasks(df) -> list[dict]:
    cols = ["t", "h", *INPUT_NAMES, *[c for c in MEASUREMENT_NAMES if c in df.columns]]
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
        task["rows"] = idx
        tasks.append(task)
    return tasks


def _run_all(tasks: list, settings: dict, workers: int, progress: bool) -> list:
    from tqdm import tqdm  # optional dependency (the 'aero' extra)

    payload = [{k: v for k, v in t.items() if k != "rows"} for t in tasks]
    results: list = [None] * len(tasks)
    order = sorted(range(len(tasks)), key=lambda i: -len(tasks[i]["t"]))
    with tqdm(total=len(tasks), desc="reconstruct", unit="maneuver", disable=not progress,
              leave=False) as bar:
        if workers == 1 or len(tasks) <= 1:
            for i in order:
                results[i] = reconstruct_maneuver(payload[i], settings)
                bar.update(1)
            return results
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=workers, mp_context=ctx,
                                 initializer=ignore_interrupts) as pool:
            futures = {pool.submit(reconstruct_maneuver, payload[i], settings): i
                       for i in order}
            for fut in as_completed(futures):
                results[futures[fut]] = fut.result()
                bar.update(1)
    return results


def reconstruct(df, metadata: Mapping | None = None, *,
                settings: ReconstructionSettings | None = None, workers: int | None = 1,
                progress: bool = False) -> Reconstruction:
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
    validate_flight_data(df, meta, nan="ignore")
    if workers is None:
        workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (
            os.cpu_count() or 1)
    if int(workers) != workers or workers < 1:
        raise InputError(f"workers must be a positive integer, got {workers!r}")
    tasks = _tasks(df)
    results = _run_all(tasks, settings.to_dict(), int(workers), progress)
    accepted, rejected, rows, parts = {}, {}, [], []
    for task, res in zip(tasks, results):
        m = task["maneuver"]
        if not res["ok"]:
            rejected[m] = res["reason"]
            continue
        accepted[m] = {k: res[k] for k in ("biases", "innovations", "iterations", "skipped")}
        rows.append(task["rows"])
        parts.append(res["states"])
    if not accepted:
        why = "; ".join(f"maneuver {m}: {r}" for m, r in sorted(rejected.items()))
        raise FlightDataError(f"no maneuver could be reconstructed ({why})")
    idx = np.sort(np.concatenate(rows))
    out = df.iloc[idx].copy()
    pos = np.empty(len(df), dtype=np.int64)
    pos[idx] = np.arange(idx.size)
    for name in parts[0]:
        col = np.empty(idx.size)
        for r, st in zip(rows, parts):
            col[pos[r]] = st[name]
        out[name] = col
    coef, thrust = aerodynamic_coefficients(
        out, meta, accelerations=settings.accelerations,
        half_window=settings.diff_half_window, degree=settings.diff_degree)
    measured_acc = settings.accelerations == "measured" or (
        settings.accelerations == "auto" and all(c in df.columns
                                                 for c in ("pdot", "qdot", "rdot")))
    for c in coef.columns:
        out[c] = coef[c].to_numpy()
    unused = [c for c in MEASUREMENT_NAMES if c not in df.columns]
    rec = Reconstruction(data=out, maneuvers=accepted, rejected=rejected,
                         thrust_subtracted=thrust,
                         accelerations="measured" if measured_acc else "differentiated",
                         unused_channels=unused, settings=settings)
    meta["reconstruction"] = jsonable({
        "method": "iterated extended Kalman filter + RTS smoother (docs/reconstruction.md)",
        "settings": settings.to_dict(),
        "thrust_subtracted": thrust, "accelerations": rec.accelerations,
        "unused_channels": unused,
        "maneuvers": {m: {"biases": r["biases"], "iterations": r["iterations"],
                          "innovations": r["innovations"], "skipped": r["skipped"]}
                      for m, r in accepted.items()},
        "rejected": rejected,
    })
    out.attrs = meta
    return rec
