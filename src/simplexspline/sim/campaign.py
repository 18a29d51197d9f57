"""Flight-test campaigns: a grid of flight conditions, a mix of maneuvers, one table.

A :class:`Campaign` describes the campaign (aircraft, altitude x airspeed grid, number and
mix of maneuvers, sensors, seed); :meth:`Campaign.run` trims every grid point, plans the
maneuvers, flies them in parallel worker processes and returns one
:class:`pandas.DataFrame` in the flight-data schema (``docs/flight-data-schema.md``) with
the schema metadata in ``df.attrs``.

Reproducibility: every random choice of maneuver ``i`` comes from
``numpy.random.SeedSequence(seed, spawn_key=(1, i))`` (design and sensor noise in separate
child streams) and the plan from ``spawn_key=(0,)``, so the output does not depend on the
number of workers or on which worker flew what.
"""

from __future__ import annotations

import math
import os
import sys
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool

import numpy as np

from simplexspline._workers import ignore_interrupts, process_context
from simplexspline.aero.data.atmosphere import isa_temperature, speed_of_sound
from simplexspline.aero.data.flight_data import write_flight_data
from simplexspline.errors import InputError, SimulationError
from simplexspline.sim.aircraft import AircraftProfile, Envelope, get_aircraft
from simplexspline.sim.campaign_table import assemble
from simplexspline.sim.flight import simulate_maneuver, trim_condition
from simplexspline.sim.maneuvers import (AXES, EXCITATION_DESIGNS, MANEUVER_FAMILIES,
                                         design_maneuver)
from simplexspline.sim.pilot import PilotStyle
from simplexspline.sim.wind import Wind
from simplexspline.sim.sensors import SensorModel

__all__ = ["Campaign", "ConditionGrid", "FlightProtocol", "simulate_campaign", "DEFAULT_MIX",
           "isa_speed_of_sound", "split_counts"]

#: Default fractions of maneuver families (about 40 s of flight per maneuver on average).
DEFAULT_MIX: dict[str, float] = {"3211": 0.45, "doublet": 0.2, "sum-of-sines": 0.35}


def isa_speed_of_sound(h_m: float) -> float:
    """Speed of sound [m/s] in the ISA troposphere/lower stratosphere at altitude ``h_m``."""
    return float(speed_of_sound(isa_temperature(h_m)))


def _grid(values, name: str) -> np.ndarray:
    a = np.asarray(values, dtype=float).ravel()
    if a.size == 0 or not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise InputError(f"{name} must be a non-empty sequence of positive finite numbers")
    if np.any(np.diff(np.sort(a)) == 0):
        raise InputError(f"{name} contains duplicates")
    return np.sort(a)


def _half_spacing(grid: np.ndarray) -> np.ndarray:
    """Half the distance to the neighbouring grid values (0 for a single value)."""
    if grid.size == 1:
        return np.zeros(1)
    d = np.diff(grid)
    left = np.r_[d[0], d]
    right = np.r_[d, d[-1]]
    return 0.5 * np.minimum(left, right)


def split_counts(total: int, weights: Sequence[float]) -> list[int]:
    """Split ``total`` into integer counts proportional to ``weights`` (largest remainder)."""
    w = np.asarray(weights, dtype=float)
    exact = total * w / w.sum()
    base = np.floor(exact).astype(int)
    order = np.argsort(-(exact - base), kind="stable")
    base[order[: total - base.sum()]] += 1
    return base.tolist()


@dataclass(frozen=True)
class ConditionGrid:
    """The flight-condition grid of a campaign: altitude x airspeed.

    Parameters
    ----------
    altitudes_m, airspeeds_mps : sequence of float, optional
        Geometric altitude [m] x true airspeed [m/s]; the profile's defaults if None (stored
        sorted). Grid points above the Mach limit or that cannot be trimmed with margin are
        skipped (listed in the metadata's ``conditions``).
    jitter : bool
        Trim each maneuver at a random point within half a grid spacing of its condition,
        so that the campaign covers the envelope between grid points.
    """

    altitudes_m: Sequence[float] | None = None
    airspeeds_mps: Sequence[float] | None = None
    jitter: bool = True

    def __post_init__(self):
        for name in ("altitudes_m", "airspeeds_mps"):
            values = getattr(self, name)
            if values is not None:
                object.__setattr__(self, name, tuple(_grid(values, name).tolist()))

    @classmethod
    def between(cls, aircraft: str | AircraftProfile, jitter: bool = True) -> ConditionGrid:
        """The midpoints of the profile's default grid: conditions not used in development.

        Examples
        --------
        >>> ConditionGrid.between("global5000").airspeeds_mps
        (132.5, 157.5, 182.5, 207.5, 232.5)
        """
        profile = get_aircraft(aircraft)
        mids = []
        for values in (profile.altitudes_m, profile.airspeeds_mps):
            a = np.sort(np.asarray(values, dtype=float))
            mids.append(0.5 * (a[1:] + a[:-1]) if a.size > 1 else a)
        return cls(mids[0].tolist(), mids[1].tolist(), jitter)

    def values(self, profile: AircraftProfile) -> tuple[np.ndarray, np.ndarray]:
        """Sorted altitudes (m,) [m] and airspeeds (k,) [m/s]; the profile's where not given."""
        return (_grid(profile.altitudes_m if self.altitudes_m is None else self.altitudes_m,
                      "altitudes_m"),
                _grid(profile.airspeeds_mps if self.airspeeds_mps is None
                      else self.airspeeds_mps, "airspeeds_mps"))


@dataclass(frozen=True)
class FlightProtocol:
    """Which maneuvers a campaign flies and how: the flight-test protocol.

    Parameters
    ----------
    mix : mapping of str to float, optional
        Relative frequency of the maneuver families '3211', 'doublet' and 'sum-of-sines'
        (default :data:`DEFAULT_MIX`); pulse families rotate over elevator, aileron and
        rudder.
    sos_duration_s : (float, float)
        Range of sum-of-sines signal lengths [s].
    turn_fraction : float
        Fraction of sum-of-sines maneuvers flown in a level turn at a random bank angle
        (load factor and angle of attack above their 1 g values); the others are straight
        and level as in the paper. 0 reproduces the paper's protocol exactly.
    pilot_delay_s : float
        Reaction delay of the pilot model [s] (the ``delay_s`` of ``pilot``; give it in one
        place).
    min_kept_s : float
        A maneuver cut at the envelope earlier than this is dropped entirely [s].
    design : {'paper', 'alternative', 'eigenmotion'}
        Excitation design (:data:`~simplexspline.sim.maneuvers.EXCITATION_DESIGNS`): the
        paper's, which the project was developed on, a different one (other pulse units,
        frequency band and low-peak-factor multisines) to test generalisation, or the
        flight-test course's pulses and doublets with long free responses
        (:meth:`eigenmotion`).
    pilot : PilotStyle, optional
        How the pilot model flies (default ``PilotStyle(delay_s=pilot_delay_s)``).

    Examples
    --------
    >>> FlightProtocol.alternative().design, FlightProtocol.alternative().pilot.delay_s
    ('alternative', 0.35)
    """

    mix: Mapping[str, float] | None = None
    sos_duration_s: tuple[float, float] = (90.0, 110.0)
    turn_fraction: float = 0.5
    pilot_delay_s: float = 0.2
    min_kept_s: float = 3.0
    design: str = "paper"
    pilot: PilotStyle | None = None

    @classmethod
    def alternative(cls, **changes) -> FlightProtocol:
        """3211s and sum-of-sines of the alternative design flown by a relaxed pilot.

        A protocol the identification was not developed on: other pulse units, another
        frequency band and number of sines, phases optimised for a low peak factor, and
        :meth:`PilotStyle.relaxed`; ``changes`` override any field.
        """
        settings = {"mix": {"3211": 0.5, "sum-of-sines": 0.5}, "design": "alternative",
                    "pilot": PilotStyle.relaxed(), **changes}
        if "pilot_delay_s" in changes and "pilot" not in changes:
            settings["pilot"] = replace(settings["pilot"], delay_s=changes["pilot_delay_s"])
        return cls(**settings)

    @classmethod
    def eigenmotion(cls, **changes) -> FlightProtocol:
        """The flight-test course's maneuvers: single pulses and doublets on each axis at
        small amplitudes, each followed by a long free response (phugoid, short period,
        aperiodic roll, Dutch roll), as a training flight records them; ``changes``
        override any field."""
        return cls(**{"mix": {"pulse": 0.5, "doublet": 0.5}, "design": "eigenmotion",
                      **changes})

    def __post_init__(self):
        mix = dict(DEFAULT_MIX if self.mix is None else self.mix)
        for fam, w in mix.items():
            if fam not in MANEUVER_FAMILIES:
                raise InputError(f"unknown maneuver family {fam!r} in mix: choose from "
                                 f"{list(MANEUVER_FAMILIES)}")
            if not (isinstance(w, (int, float)) and math.isfinite(w) and w >= 0):
                raise InputError(f"mix weight of {fam!r} must be a non-negative number")
        if sum(mix.values()) <= 0:
            raise InputError("mix needs at least one positive weight")
        object.__setattr__(self, "mix", mix)
        tf = self.turn_fraction
        if not (isinstance(tf, (int, float)) and 0 <= tf <= 1):
            raise InputError(f"turn_fraction must be a number in [0, 1], got {tf!r}")
        for name in ("pilot_delay_s", "min_kept_s"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and 0 <= v <= 60):
                raise InputError(f"{name} must be a number of seconds in [0, 60], got {v!r}")
        try:
            lo, hi = (float(x) for x in self.sos_duration_s)
        except (TypeError, ValueError):
            lo, hi = math.nan, math.nan
        if not (10.0 <= lo <= hi):
            raise InputError("sos_duration_s must be (low, high) with 10 <= low <= high")
        object.__setattr__(self, "sos_duration_s", (lo, hi))
        if self.design not in EXCITATION_DESIGNS:
            raise InputError(f"unknown excitation design {self.design!r}: choose one of "
                             f"{list(EXCITATION_DESIGNS)}")
        other = [f for f, w in mix.items() if w > 0 and f not in ("pulse", "doublet")]
        if self.design == "eigenmotion" and other:
            raise InputError(f"the eigenmotion design flies pulses and doublets only; the mix "
                             f"gives {other}: use FlightProtocol.eigenmotion() or a mix of "
                             "'pulse' and 'doublet'")
        if self.pilot is None:
            object.__setattr__(self, "pilot", PilotStyle(delay_s=float(self.pilot_delay_s)))
        elif not isinstance(self.pilot, PilotStyle):
            raise InputError("pilot must be a simplexspline.sim.PilotStyle")
        elif self.pilot_delay_s not in (0.2, self.pilot.delay_s):
            raise InputError(f"pilot_delay_s = {self.pilot_delay_s} differs from the pilot's "
                             f"delay_s = {self.pilot.delay_s}: give the delay in one place")
        object.__setattr__(self, "pilot_delay_s", float(self.pilot.delay_s))


class Campaign:
    """A simulated flight-test campaign on a JSBSim aircraft.

    Parameters
    ----------
    aircraft : str or AircraftProfile
        ``'f16'`` (strongly nonlinear), ``'global5000'`` (business jet) or a registered
        profile.
    maneuvers : int
        Total number of maneuvers (spread evenly over the usable conditions). Ignored when
        ``maneuvers_per_condition`` is given.
    maneuvers_per_condition : int, optional
        Number of maneuvers at every usable condition.
    seed : int
        Non-negative seed; the same seed gives identical output.
    grid : ConditionGrid, optional
        Flight conditions (default: the profile's altitude x airspeed grid, jittered).
    protocol : FlightProtocol, optional
        Maneuver mix, sum-of-sines lengths, turns, pilot delay, shortest kept maneuver
        (default: ``FlightProtocol()``).
    sensors : SensorModel, optional
        Noise, biases and lags of the measured channels (default: ``SensorModel()``);
        ``SensorModel.ideal()`` for perfect sensors.
    envelope : Envelope, optional
        Limits of kept data (default: the profile's).
    wind : Wind, optional
        Steady wind and turbulence, drawn per maneuver (default: still air). The trimmed
        air-relative state is kept; the true wind is recorded in ``true_wind_n/e/d``.

    Examples
    --------
    >>> from simplexspline.sim import Campaign, ConditionGrid, FlightProtocol
    >>> df = Campaign("f16", grid=ConditionGrid([3000], [170]), maneuvers=2,
    ...               protocol=FlightProtocol(mix={"doublet": 1}), seed=1
    ...               ).run(workers=1, progress=False)
    >>> df.attrs["schema"], sorted(df["maneuver"].unique().tolist())
    ('simplexspline.flightdata/1', [0, 1])
    """

    def __init__(self, aircraft: str | AircraftProfile = "f16", *, maneuvers: int = 250,
                 maneuvers_per_condition: int | None = None, seed: int = 0,
                 grid: ConditionGrid | None = None, protocol: FlightProtocol | None = None,
                 sensors: SensorModel | None = None, envelope: Envelope | None = None,
                 wind: Wind | None = None):
        self.aircraft = aircraft
        self.maneuvers = maneuvers
        self.maneuvers_per_condition = maneuvers_per_condition
        self.seed = seed
        self.grid = ConditionGrid() if grid is None else grid
        self.protocol = FlightProtocol() if protocol is None else protocol
        self.sensors = sensors
        self.envelope = envelope
        self.wind = wind

    # ------------------------------------------------------------------ validation
    def _settings(self) -> dict:
        profile = get_aircraft(self.aircraft)
        env = self.envelope if self.envelope is not None else profile.envelope
        if not isinstance(env, Envelope):
            raise InputError("envelope must be a simplexspline.sim.Envelope")
        sensors = self.sensors if self.sensors is not None else SensorModel()
        if not isinstance(sensors, SensorModel):
            raise InputError("sensors must be a simplexspline.sim.SensorModel")
        if not isinstance(self.grid, ConditionGrid):
            raise InputError("grid must be a simplexspline.sim.ConditionGrid")
        if not isinstance(self.protocol, FlightProtocol):
            raise InputError("protocol must be a simplexspline.sim.FlightProtocol")
        if self.wind is not None and not isinstance(self.wind, Wind):
            raise InputError("wind must be a simplexspline.sim.Wind or None")
        alts, tas = self.grid.values(profile)
        if self.maneuvers_per_condition is None:
            if int(self.maneuvers) != self.maneuvers or self.maneuvers < 1:
                raise InputError(f"maneuvers must be a positive integer, got {self.maneuvers!r}")
        elif (int(self.maneuvers_per_condition) != self.maneuvers_per_condition
              or self.maneuvers_per_condition < 1):
            raise InputError("maneuvers_per_condition must be a positive integer")
        if not (isinstance(self.seed, (int, np.integer)) and self.seed >= 0):
            raise InputError(f"seed must be a non-negative integer, got {self.seed!r}")
        return {"profile": profile, "envelope": env, "sensors": sensors, "altitudes": alts,
                "airspeeds": tas}

    # ------------------------------------------------------------------ planning
    def _condition_specs(self, st: dict, scratch: str | None) -> list[dict]:
        specs = []
        for i, (h, v) in enumerate((h, v) for h in st["altitudes"] for v in st["airspeeds"]):
            specs.append({"profile": st["profile"].to_dict(), "envelope": st["envelope"].to_dict(),
                          "condition": i, "h_m": float(h), "tas_mps": float(v),
                          "scratch": scratch})
        return specs

    def _static_check(self, st: dict, spec: dict) -> str:
        mach = spec["tas_mps"] / isa_speed_of_sound(spec["h_m"])
        if mach > st["envelope"].mach_max - 0.02:
            return f"Mach {mach:.3f} above the envelope's limit {st['envelope'].mach_max} - 0.02"
        return ""

    def _plan(self, st: dict, conditions: list[dict], scratch: str | None) -> list[dict]:
        usable = [c for c in conditions if c["trimmed"]]
        if not usable:
            raise SimulationError(
                f"{st['profile'].name}: no condition of the altitude x airspeed grid could be "
                "trimmed inside the envelope; see the reasons with Campaign.conditions() and "
                "choose other altitudes_m/airspeeds_mps")
        n = (len(usable) * int(self.maneuvers_per_condition)
             if self.maneuvers_per_condition is not None else int(self.maneuvers))
        rng = np.random.default_rng(np.random.SeedSequence(int(self.seed), spawn_key=(0,)))
        protocol = self.protocol
        fams = list(protocol.mix)
        kinds: list[str] = []
        for fam, k in zip(fams, split_counts(n, [protocol.mix[f] for f in fams])):
            if fam == "sum-of-sines":
                kinds += ["sum-of-sines"] * k
            else:
                kinds += [f"{fam}-{AXES[j % 3]}" for j in range(k)]
        kinds = [kinds[j] for j in rng.permutation(n)]
        cond_of = [usable[j % len(usable)] for j in rng.permutation(n)]
        dh = dict(zip(st["altitudes"].tolist(), _half_spacing(st["altitudes"]).tolist()))
        dv = dict(zip(st["airspeeds"].tolist(), _half_spacing(st["airspeeds"]).tolist()))
        profile, env = st["profile"], st["envelope"]
        specs = []
        for i in range(n):
            c = cond_of[i]
            design_rng = np.random.default_rng(
                np.random.SeedSequence(int(self.seed), spawn_key=(1, i)).spawn(2)[0])
            design = design_maneuver(kinds[i], profile, design_rng, protocol.sos_duration_s,
                                     float(protocol.turn_fraction), protocol.design)
            jh, jv = design_rng.uniform(-1.0, 1.0, 2)
            h, v = c["h_m"], c["tas_mps"]
            if self.grid.jitter:
                h = h + jh * dh[c["h_m"]]
                v = v + jv * dv[c["tas_mps"]]
                v = min(v, (env.mach_max - 0.03) * isa_speed_of_sound(h))
            specs.append({
                "index": i, "condition": c["condition"], "design": design,
                "profile": profile.to_dict(), "envelope": env.to_dict(),
                "sensors": st["sensors"].to_dict(),
                "h_m": float(h), "tas_mps": float(v),
                "h_nominal": c["h_m"], "tas_nominal": c["tas_mps"],
                "psi_rad": float(design_rng.uniform(-math.pi, math.pi)),
                "fuel_fraction": float(design_rng.uniform(*profile.fuel_fraction)),
                "seed": int(self.seed), "min_kept_s": float(protocol.min_kept_s),
                "pilot": protocol.pilot.to_dict(), "scratch": scratch,
                # the sensor-geometry reference point: the c.g. with full fuel (the same
                # at every trimmed condition); x_cg, y_cg, z_cg are measured from it
                "cg_reference_in": list(usable[0]["cg_in"]),
            })
            if self.wind is not None:  # its own stream: still-air campaigns are unchanged
                specs[-1]["wind"] = self.wind.draw(np.random.default_rng(
                    np.random.SeedSequence(int(self.seed), spawn_key=(2, i))))
        return specs

    # ------------------------------------------------------------------ running
    def conditions(self, workers: int | None = None) -> list[dict]:
        """Trim every grid point; return one dict per condition (``trimmed``, ``reason``...)."""
        st = self._settings()
        with tempfile.TemporaryDirectory(prefix="ssim-") as scratch, \
                Executor(workers) as ex:
            return self._trim_all(st, ex, scratch, progress=False)

    def _trim_all(self, st, ex, scratch, progress) -> list[dict]:
        specs = self._condition_specs(st, scratch)
        out: list = [None] * len(specs)
        todo = []
        for i, spec in enumerate(specs):
            reason = self._static_check(st, spec)
            if reason:
                out[i] = {"condition": i, "h_m": spec["h_m"], "tas_mps": spec["tas_mps"],
                          "trimmed": False, "reason": reason}
            else:
                todo.append(i)
        for i, res in ex.map(trim_condition, [specs[i] for i in todo], [1.0] * len(todo),
                             progress=progress, desc="trim"):
            out[todo[i]] = res
        return out

    def plan(self, workers: int | None = None) -> list[dict]:
        """The maneuver plan (trims the grid first): one plain-data spec per maneuver."""
        st = self._settings()
        conditions = self.conditions(workers)
        return self._plan(st, conditions, None)

    def run(self, workers: int | None = None, progress: bool | None = None):
        """Fly the campaign.

        Parameters
        ----------
        workers : int, optional
            Worker processes (default: the number of usable CPUs); 1 runs in this process.
        progress : bool, optional
            Show a tqdm progress bar (default: when stderr is a terminal).

        Returns
        -------
        pandas.DataFrame
            One row per 100 Hz sample in the flight-data schema; ``df.attrs`` holds the
            schema metadata (geometry, sign conventions, units, simulator settings, the
            condition list and the per-maneuver log with ``status`` 'complete', 'cut',
            'dropped' or 'trim-failed').
        """
        st = self._settings()
        if progress is None:
            progress = sys.stderr.isatty()
        with tempfile.TemporaryDirectory(prefix="ssim-") as scratch, \
                Executor(workers) as ex:
            conditions = self._trim_all(st, ex, scratch, progress)
            specs = self._plan(st, conditions, scratch)
            weights = [s["design"]["duration_s"] for s in specs]
            results = [None] * len(specs)
            for i, res in ex.map(simulate_maneuver, specs, weights, progress=progress,
                                 desc=f"{st['profile'].name} maneuvers"):
                results[i] = res
        return assemble(results, conditions, st, self)


class Executor:
    """Serial or process-pool execution of plain-data tasks, longest first, with tqdm."""

    def __init__(self, workers: int | None):
        if workers is None:
            try:
                workers = len(os.sched_getaffinity(0))
            except AttributeError:  # pragma: no cover - not on Linux
                workers = os.cpu_count() or 1
        if int(workers) != workers or workers < 1:
            raise InputError(f"workers must be a positive integer, got {workers!r}")
        self.workers = int(workers)
        self.pool = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)
        return False

    def map(self, func: Callable, specs: list, weights: list, *, progress: bool, desc: str):
        """Yield ``(position, result)`` as tasks finish."""
        from tqdm import tqdm  # optional dependency (the 'sim' extra)

        order = sorted(range(len(specs)), key=lambda i: -weights[i])
        with tqdm(total=len(specs), desc=desc, unit="task", disable=not progress,
                  leave=False) as bar:
            if self.workers == 1 or len(specs) <= 1:
                for i in order:
                    yield i, func(specs[i])
                    bar.update(1)
                return
            if self.pool is None:
                self.pool = ProcessPoolExecutor(
                    max_workers=self.workers, mp_context=process_context(),
                    initializer=ignore_interrupts)
            futures = {self.pool.submit(func, specs[i]): i for i in order}
            try:
                for fut in as_completed(futures):
                    yield futures[fut], fut.result()
                    bar.update(1)
            except BrokenProcessPool as exc:
                raise SimulationError(
                    f"a simulator worker process died ({exc}); run with workers=1 to see "
                    "the error in this process") from None


def simulate_campaign(aircraft: str | AircraftProfile = "f16", *, maneuvers: int = 250,
                      seed: int = 0, output: str | os.PathLike | None = None,
                      workers: int | None = None, progress: bool | None = None, **kwargs):
    """Run a :class:`Campaign` and optionally write it to Parquet/CSV.

    Parameters
    ----------
    aircraft, maneuvers, seed, **kwargs
        Passed to :class:`Campaign`.
    output : path-like, optional
        Write the table with :func:`simplexspline.aero.data.flight_data.write_flight_data`.
    workers, progress
        Passed to :meth:`Campaign.run`.

    Returns
    -------
    pandas.DataFrame
    """
    df = Campaign(aircraft, maneuvers=maneuvers, seed=seed, **kwargs).run(
        workers=workers, progress=progress)
    if output is not None:
        write_flight_data(df, output)
    return df

