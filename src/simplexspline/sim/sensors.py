"""Sensor models of a flight-test instrumentation system.

Each measured channel is ``measured(t) = sensed(t - lag) + bias + noise(t)`` with a constant
bias, zero-mean Gaussian white noise (independent per sample and channel) and an optional
pure time lag (linear interpolation; the first value is held before the maneuver starts).
``sensed`` is the true value at the c.g. except for the vanes and the accelerometers, which
may sit elsewhere (sensor geometry, as metadata ``sensor_geometry`` of the flight-data
schema describes it): a vane reads ``scale * (flow angle of the local air velocity
V + omega x r) + offset``, the accelerometers the specific force at their position,
``a_cg + omegadot x r + omega x (omega x r)``. ``r`` is the sensor's position from the
c.g.: sensors are fixed to the airframe, their positions are measured from the
sensor-geometry reference point (in the simulated campaigns the c.g. with full fuel), and
fuel burn moves the c.g. (columns ``x_cg, y_cg, z_cg``) against them.
The defaults are of the order of a flight-test instrumentation package with a
navigation-grade IMU, vanes on a nose boom and a GPS receiver; they are listed in
``docs/flight-data-schema.md`` and written into every campaign's metadata.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from simplexspline.aero.data.flight_data import LAG_CHANNELS, sensor_geometry
from simplexspline.aero.variables import DEG
from simplexspline.errors import FlightDataError, InputError

__all__ = ["SensorModel", "MEASURED_CHANNELS", "DEFAULT_NOISE_STD", "DEFAULT_BIAS"]


#: Channels the sensor model corrupts, with their units.
MEASURED_CHANNELS: dict[str, str] = {
    "alpha": "rad", "beta": "rad", "tas": "m/s", "mach": "-", "h": "m", "rho": "kg/m^3",
    "p": "rad/s", "q": "rad/s", "r": "rad/s",
    "phi": "rad", "theta": "rad", "psi": "rad",
    "ax": "m/s^2", "ay": "m/s^2", "az": "m/s^2",
    "pdot": "rad/s^2", "qdot": "rad/s^2", "rdot": "rad/s^2",
    "de": "rad", "da": "rad", "dr": "rad",
    "x_gps": "m", "y_gps": "m", "z_gps": "m",
    "vn_gps": "m/s", "ve_gps": "m/s", "vd_gps": "m/s",
}

#: Default white-noise standard deviations (1 sigma, per 100 Hz sample).
DEFAULT_NOISE_STD: dict[str, float] = {
    "alpha": 0.1 * DEG, "beta": 0.1 * DEG, "tas": 0.1, "mach": 3e-4, "h": 0.5,
    "rho": 5e-4,
    "p": 0.01 * DEG, "q": 0.01 * DEG, "r": 0.01 * DEG,
    "phi": 0.05 * DEG, "theta": 0.05 * DEG, "psi": 0.1 * DEG,
    "ax": 0.01, "ay": 0.01, "az": 0.01,
    "pdot": 0.005, "qdot": 0.005, "rdot": 0.005,
    "de": 0.02 * DEG, "da": 0.02 * DEG, "dr": 0.02 * DEG,
    "x_gps": 2.0, "y_gps": 2.0, "z_gps": 4.0,
    "vn_gps": 0.05, "ve_gps": 0.05, "vd_gps": 0.1,
}

#: Default constant biases (what a flight-path reconstruction has to estimate).
DEFAULT_BIAS: dict[str, float] = {
    "alpha": 0.2 * DEG, "beta": -0.1 * DEG, "tas": 0.5,
    "p": 0.02 * DEG, "q": -0.015 * DEG, "r": 0.01 * DEG,
    "ax": 0.02, "ay": -0.015, "az": 0.03,
}


def _complete(values: Mapping[str, float] | None, defaults: Mapping[str, float],
              what: str) -> dict[str, float]:
    out = {ch: float(defaults.get(ch, 0.0)) for ch in MEASURED_CHANNELS}
    for ch, v in (values or {}).items():
        if ch not in MEASURED_CHANNELS:
            raise InputError(
                f"sensor {what} given for unknown channel {ch!r}: "
                f"channels are {sorted(MEASURED_CHANNELS)}"
            )
        v = float(v)
        if not math.isfinite(v) or (what != "bias" and v < 0):
            raise InputError(f"sensor {what} of {ch!r} must be a finite"
                             f"{'' if what == 'bias' else ' non-negative'} number, got {v}")
        out[ch] = v
    return out


@dataclass(frozen=True)
class SensorModel:
    """Noise, bias and time lag per measured channel.

    Parameters
    ----------
    noise_std : mapping of str to float, optional
        White-noise standard deviation per channel (SI units, rad). Channels not given keep
        the defaults (:data:`DEFAULT_NOISE_STD`).
    bias : mapping of str to float, optional
        Constant bias per channel; defaults :data:`DEFAULT_BIAS` (others zero).
    lag_s : mapping of str to float, optional
        Pure time lag per channel [s]; default zero everywhere.
    alpha_vane, beta_vane : mapping, optional
        Vane geometry and calibration as in metadata ``sensor_geometry`` of the flight-data
        schema: ``position_m`` (x forward, y right, z down from the reference point) [m],
        ``scale`` [-] and ``offset_rad`` [rad]; default at the reference point, calibrated.
        The known ``offset_rad`` is recorded in the metadata; ``bias`` stays unknown.
    imu_position_m : (3,) sequence of float, optional
        Accelerometer position from the reference point [m] (default at it).
    at_cg : bool
        The sensors follow the c.g. (an idealisation: the positions are from the moving
        c.g.; a campaign then writes no c.g. columns, and the moments stay about the c.g.).
        Default False: the sensors are fixed to the airframe and their positions are from
        the sensor-geometry reference point, the c.g. with full fuel in a simulated campaign.

    Examples
    --------
    >>> SensorModel.ideal().noise_std["ax"]
    0.0
    >>> SensorModel(noise_std={"ax": 0.05}).noise_std["ay"]  # others keep the defaults
    0.01
    """

    noise_std: Mapping[str, float] = field(default=None)
    bias: Mapping[str, float] = field(default=None)
    lag_s: Mapping[str, float] = field(default=None)
    alpha_vane: Mapping | None = None
    beta_vane: Mapping | None = None
    imu_position_m: tuple | None = None
    at_cg: bool = False

    def __post_init__(self):
        object.__setattr__(self, "noise_std", _complete(self.noise_std, DEFAULT_NOISE_STD,
                                                        "noise_std"))
        object.__setattr__(self, "bias", _complete(self.bias, DEFAULT_BIAS, "bias"))
        object.__setattr__(self, "lag_s", _complete(self.lag_s, {}, "lag_s"))
        geometry = {k: v for k, v in (("alpha_vane", self.alpha_vane),
                                      ("beta_vane", self.beta_vane),
                                      ("imu", None if self.imu_position_m is None
                                       else {"position_m": self.imu_position_m}))
                    if v is not None}
        try:  # the schema's own check of the same entries (one copy of the rules)
            geo = sensor_geometry({"sensor_geometry": geometry})
        except FlightDataError as exc:
            raise InputError(f"SensorModel: {exc}") from None
        for name in ("alpha_vane", "beta_vane"):
            vane = getattr(geo, name)
            object.__setattr__(self, name, {"position_m": list(vane.position_m),
                                            "scale": vane.scale,
                                            "offset_rad": vane.offset_rad})
        object.__setattr__(self, "imu_position_m", tuple(geo.imu_position_m))

    @classmethod
    def ideal(cls) -> SensorModel:
        """Perfect sensors at the c.g.: no noise, no bias, no lag (measured == true)."""
        zero = {ch: 0.0 for ch in MEASURED_CHANNELS}
        return cls(noise_std=zero, bias=zero, lag_s=zero, at_cg=True)

    @classmethod
    def real_like(cls) -> SensorModel:
        """Default noise and biases plus the geometry of a real installation: vanes on a
        nose boom 4 m ahead of the reference point (the full-fuel c.g.) with 3-4 % scale
        errors and known offsets, the IMU 0.6 m ahead of and 0.2 m below it, air-data lags (vanes 50 ms, airspeed 0.1 s,
        altitude 0.2 s)."""
        boom = [4.0, 0.0, -0.4]
        return cls(alpha_vane={"position_m": boom, "scale": 1.04, "offset_rad": 0.5 * DEG},
                   beta_vane={"position_m": boom, "scale": 0.97, "offset_rad": -0.3 * DEG},
                   imu_position_m=(0.6, 0.05, 0.2),
                   lag_s={"alpha": 0.05, "beta": 0.05, "tas": 0.1, "mach": 0.1, "h": 0.2})

    def scaled(self, noise: float = 1.0, bias: float = 1.0) -> SensorModel:
        """A copy with all noise levels and biases multiplied by the given factors."""
        return SensorModel(
            noise_std={k: noise * v for k, v in self.noise_std.items()},
            bias={k: bias * v for k, v in self.bias.items()},
            lag_s=dict(self.lag_s), alpha_vane=self.alpha_vane, beta_vane=self.beta_vane,
            imu_position_m=self.imu_position_m, at_cg=self.at_cg,
        )

    @property
    def has_geometry(self) -> bool:
        """True when a vane or the IMU is away from the c.g. or a vane is not calibrated."""
        return (any(self.imu_position_m)
                or any(any(v["position_m"]) or v["scale"] != 1.0 or v["offset_rad"]
                       for v in (self.alpha_vane, self.beta_vane)))

    @property
    def is_ideal(self) -> bool:
        """True when the measured channels equal the true ones exactly."""
        return not (self.has_geometry
                    or any(any(d.values()) for d in (self.noise_std, self.bias, self.lag_s)))

    def sensor_geometry(self) -> dict | None:
        """Metadata ``sensor_geometry`` (flight-data schema) of this model, or None when the
        sensors sit at the c.g., calibrated, without lags."""
        lags = {ch: v for ch, v in self.lag_s.items() if v and ch in LAG_CHANNELS}
        if not (self.has_geometry or lags):
            return None
        return {"alpha_vane": dict(self.alpha_vane), "beta_vane": dict(self.beta_vane),
                "imu": {"position_m": list(self.imu_position_m)}, "lag_s": lags}

    def to_dict(self) -> dict:
        """Plain-data form (for metadata and worker processes)."""
        return {"noise_std": dict(self.noise_std), "bias": dict(self.bias),
                "lag_s": dict(self.lag_s), "alpha_vane": dict(self.alpha_vane),
                "beta_vane": dict(self.beta_vane), "imu_position_m": list(self.imu_position_m),
                "at_cg": self.at_cg}

    @classmethod
    def from_dict(cls, d: Mapping) -> SensorModel:
        return cls(noise_std=d.get("noise_std"), bias=d.get("bias"), lag_s=d.get("lag_s"),
                   alpha_vane=d.get("alpha_vane"), beta_vane=d.get("beta_vane"),
                   imu_position_m=d.get("imu_position_m"), at_cg=bool(d.get("at_cg", False)))

    def sensed(self, true: Mapping[str, np.ndarray],
               cg: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """What vanes and accelerometers away from the c.g. see, before lag, bias and noise.

        Parameters
        ----------
        true : mapping of str to (n,) ndarray
            True ``alpha``, ``beta`` [rad], ``tas`` [m/s], ``p, q, r`` [rad/s],
            ``pdot, qdot, rdot`` [rad/s^2] and ``ax, ay, az`` [m/s^2] at the c.g.
        cg : (n, 3) ndarray, optional
            The c.g. from the sensor-geometry reference point, body axes [m] (the sensor
            positions are measured from that point; fuel burn moves the c.g. against
            them). Default: the sensors' positions are from the c.g.

        Returns
        -------
        dict of str to (n,) ndarray
            ``alpha``, ``beta`` (vane readings) and ``ax``, ``ay``, ``az`` (at the IMU).
        """
        a, b, V = (np.asarray(true[k], dtype=float) for k in ("alpha", "beta", "tas"))
        p, q, r = (np.asarray(true[k], dtype=float) for k in ("p", "q", "r"))
        u, v, w = V * np.cos(a) * np.cos(b), V * np.sin(b), V * np.sin(a) * np.cos(b)
        cg = np.zeros((1, 3)) if cg is None else np.asarray(cg, dtype=float).reshape(-1, 3)

        def arm(position):  # the sensor's position from the c.g., per sample
            d = np.asarray(position, dtype=float) - cg
            return d[:, 0], d[:, 1], d[:, 2], bool(np.any(d))

        out = {}
        for name, vane in (("alpha", self.alpha_vane), ("beta", self.beta_vane)):
            x, y, z, away = arm(vane["position_m"])
            if away:
                ul, vl, wl = u + q * z - r * y, v + r * x - p * z, w + p * y - q * x
                angle = (np.arctan2(wl, ul) if name == "alpha"
                         else np.arcsin(vl / np.sqrt(ul * ul + vl * vl + wl * wl)))
            else:  # at the c.g.: the true angle, exactly
                angle = a if name == "alpha" else b
            out[name] = (angle if vane["scale"] == 1.0 and not vane["offset_rad"]
                         else vane["scale"] * angle + vane["offset_rad"])
        x, y, z, _ = arm(self.imu_position_m)
        pd_, qd, rd = (np.asarray(true[k], dtype=float) for k in ("pdot", "qdot", "rdot"))
        cx, cy, cz = q * z - r * y, r * x - p * z, p * y - q * x  # omega x r
        out["ax"] = np.asarray(true["ax"], dtype=float) + qd * z - rd * y + q * cz - r * cy
        out["ay"] = np.asarray(true["ay"], dtype=float) + rd * x - pd_ * z + r * cx - p * cz
        out["az"] = np.asarray(true["az"], dtype=float) + pd_ * y - qd * x + p * cy - q * cx
        return out

    def apply(self, true: Mapping[str, np.ndarray], t: np.ndarray,
              rng: np.random.Generator,
              cg: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """Measured channels from true ones.

        Parameters
        ----------
        true : mapping of str to (n,) ndarray
            True values of every channel in :data:`MEASURED_CHANNELS`.
        t : (n,) ndarray
            Sample times [s], increasing.
        rng : numpy.random.Generator
            Noise stream; one standard-normal vector is drawn per channel, in the order of
            :data:`MEASURED_CHANNELS`, whatever the settings (so changing one channel's
            noise does not change another's).
        cg : (n, 3) ndarray, optional
            The c.g. from the sensor-geometry reference point [m] (see :meth:`sensed`).

        Returns
        -------
        dict of str to (n,) ndarray
        """
        out = {}
        n = len(t)
        moved = cg is not None and bool(np.any(cg))
        sensed = self.sensed(true, cg) if self.has_geometry or moved else {}
        for ch in MEASURED_CHANNELS:
            x = np.asarray(sensed.get(ch, true[ch]), dtype=float)
            white = rng.standard_normal(n)
            lag = self.lag_s[ch]
            sigma, bias = self.noise_std[ch], self.bias[ch]
            if not (lag > 0 or sigma or bias):
                out[ch] = x.copy()
                continue
            if lag > 0:
                x = np.interp(t - lag, t, np.unwrap(x) if ch == "psi" else x)
            x = x + bias + sigma * white
            if ch == "psi":
                x = (x + math.pi) % (2 * math.pi) - math.pi
            out[ch] = x
        return out
