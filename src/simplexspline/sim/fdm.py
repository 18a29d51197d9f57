"""The JSBSim boundary: create a model, trim it, read and write properties.

Only this module (and :mod:`simplexspline.sim.units`) knows JSBSim's property names and
its ft/lbf/slug units. JSBSim prints banners and warnings from C++ and some aircraft files
write CSV output into the working directory: :func:`quiet_scratch` redirects both.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
import tempfile
from collections.abc import Iterator

from simplexspline.errors import InputError, SimulationError
from simplexspline.sim.aircraft import AircraftProfile
from simplexspline.sim.units import FT, KT

__all__ = ["ENGINE_RECORD", "IDX", "LATITUDE_DEG", "LONGITUDE_DEG", "load_jsbsim",
           "quiet_scratch", "create_fdm", "trim_fdm", "set_wind", "RECORD", "Recorder"]

#: Properties read after every ``run()`` (one 100 Hz sample), in JSBSim units. After
#: ``run()`` JSBSim's state, forces, moments and accelerations all refer to the same
#: instant (Propagate runs first in the model order, the force models after it).
#: Body rates are the inertial ones (what gyros measure; they and ``p/q/ridot`` satisfy
#: the rigid-body moment equations exactly).
RECORD: tuple[str, ...] = (
    "aero/alpha-rad", "aero/beta-rad", "velocities/vt-fps", "velocities/mach",
    "atmosphere/pressure-altitude", "atmosphere/rho-slugs_ft3", "aero/qbar-psf",
    "velocities/pi-rad_sec", "velocities/qi-rad_sec", "velocities/ri-rad_sec",
    "attitude/phi-rad", "attitude/theta-rad", "attitude/psi-rad",
    "forces/fbx-total-lbs", "forces/fby-total-lbs", "forces/fbz-total-lbs",
    "forces/fbx-aero-lbs", "forces/fby-aero-lbs", "forces/fbz-aero-lbs",
    "moments/l-aero-lbsft", "moments/m-aero-lbsft", "moments/n-aero-lbsft",
    "forces/fbx-prop-lbs", "forces/fby-prop-lbs", "forces/fbz-prop-lbs",
    "moments/l-prop-lbsft", "moments/m-prop-lbsft", "moments/n-prop-lbsft",
    "accelerations/pidot-rad_sec2", "accelerations/qidot-rad_sec2",
    "accelerations/ridot-rad_sec2",
    "inertia/mass-slugs", "inertia/ixx-slugs_ft2", "inertia/iyy-slugs_ft2",
    "inertia/izz-slugs_ft2", "inertia/ixz-slugs_ft2",
    "position/lat-geod-rad", "position/long-gc-rad", "position/h-sl-ft",
    "velocities/v-north-fps", "velocities/v-east-fps", "velocities/v-down-fps",
    "atmosphere/total-wind-north-fps", "atmosphere/total-wind-east-fps",
    "atmosphere/total-wind-down-fps",
    # the c.g. in JSBSim's structural frame (x aft, y right, z up) [in]: fuel burn moves it
    "inertia/cg-x-in", "inertia/cg-y-in", "inertia/cg-z-in",
    # body rates relative to the air mass, which the aerodynamics see (in turbulence they
    # differ from the inertial rates by the rotational gusts, which no gyro measures)
    "velocities/p-aero-rad_sec", "velocities/q-aero-rad_sec", "velocities/r-aero-rad_sec",
    # the static pressure, from which an altimeter's pressure altitude follows: JSBSim's
    # own pressure-altitude is the geometric altitude of the standard day, 7.7 m above the
    # ISA's (geopotential) at 7 km, and the ISA pressure of it is 0.11 % low (0.3 % at 11 km)
    "atmosphere/P-psf",
)
#: Where the simulated flights start (geodetic latitude, longitude [deg]); written into the
#: metadata as ``latitude_deg`` for the reconstruction's Earth model.
LATITUDE_DEG, LONGITUDE_DEG = 52.0, 4.4

#: JSBSim models switched off after the trim because they contribute exactly nothing here
#: (outputs stay bit-identical; a step gets about 40 % cheaper): ground reactions are zero
#: airborne with the gear up (kept data stay above ``Envelope.h_min``), and there is no
#: socket input, no output, no buoyancy and no external force.
IDLE_MODELS = ("FGGroundReactions", "FGInput", "FGOutput", "FGBuoyantForces",
               "FGExternalReactions")
#: Engine quantities recorded after :data:`RECORD`, aggregated over the profile's engines
#: (one per throttle): the total fuel flow (``propulsion/engine[i]/fuel-flow-rate-pps``
#: summed) [lb/s] and the mean fan speed (``propulsion/engine[i]/n1``) [%], NaN for engines
#: without one (pistons). What a real installation's engine channels show.
ENGINE_RECORD: tuple[str, ...] = ("engines/fuel-flow-pps", "engines/n1-pct")
#: Index of each recorded quantity in a sample.
IDX = {name: i for i, name in enumerate(RECORD + ENGINE_RECORD)}


def load_jsbsim():
    """Import jsbsim, or explain how to install it."""
    try:
        import jsbsim  # optional dependency (the 'sim' extra)
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise SimulationError(
            "the flight simulator needs JSBSim: pip install 'simplexspline[sim]'"
        ) from exc
    return jsbsim


@contextlib.contextmanager
def quiet_scratch(directory: str | None = None) -> Iterator[str]:
    """Run JSBSim calls in a scratch directory with its console output silenced.

    Parameters
    ----------
    directory : str, optional
        Scratch directory to use; a temporary one is created (and removed) if None.

    Notes
    -----
    Changes the process's working directory and file descriptors 1 and 2 for the duration
    of the block: not thread-safe (the simulator runs maneuvers in processes, not threads).
    """
    with contextlib.ExitStack() as stack:
        if directory is None:
            directory = stack.enter_context(tempfile.TemporaryDirectory(prefix="ssim-"))
        old_cwd = os.getcwd()
        for stream in (sys.stdout, sys.stderr):  # nothing buffered may end up in /dev/null
            if stream is not None:
                stream.flush()
        saved = [os.dup(1), os.dup(2)]
        devnull = os.open(os.devnull, os.O_WRONLY)
        try:
            os.chdir(directory)
            os.dup2(devnull, 1)
            os.dup2(devnull, 2)
            # JSBSim's Python module also routes some C++ output through sys.stdout
            with open(os.devnull, "w") as sink, contextlib.redirect_stdout(sink), \
                    contextlib.redirect_stderr(sink):
                yield directory
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in (*saved, devnull):
                os.close(fd)
            os.chdir(old_cwd)


def create_fdm(profile: AircraftProfile, fuel_fraction: float = 1.0):
    """A fresh ``FGFDMExec`` with ``profile``'s model loaded, dt = 0.01 s, output off.

    Call inside :func:`quiet_scratch`.
    """
    jsbsim = load_jsbsim()
    fdm = jsbsim.FGFDMExec(None)
    fdm.set_debug_level(0)
    if not fdm.load_model(profile.model):
        raise SimulationError(f"JSBSim could not load aircraft model {profile.model!r}")
    fdm.disable_output()
    fdm.set_dt(0.01)
    for tank in profile.tanks:
        fdm[tank] = fdm[tank] * float(fuel_fraction)
    pm = fdm.get_property_manager()
    for name, value in profile.loading:
        if not pm.hasNode(name):
            raise InputError(f"{profile.name}: loading property {name!r} does not exist in "
                                  f"model {profile.model!r}; fix the aircraft profile")
        fdm[name] = float(value)
    return fdm


def trim_fdm(profile: AircraftProfile, h_m: float, tas_mps: float, psi_rad: float = 0.0,
             fuel_fraction: float = 1.0):
    """Create and trim a model in straight and level flight; return the FDM.

    The FCS is switched off after the trim, so the surface positions (and throttles) are
    from then on written by the caller; so are the :data:`IDLE_MODELS`.

    Parameters
    ----------
    profile : AircraftProfile
    h_m : float
        Geometric altitude above mean sea level [m].
    tas_mps : float
        True airspeed [m/s].
    psi_rad : float
        Initial heading [rad].
    fuel_fraction : float
        Fraction of the model's initial fuel load.

    Raises
    ------
    SimulationError
        If JSBSim cannot trim the aircraft at this condition.
    """
    fdm = create_fdm(profile, fuel_fraction)
    fdm["ic/h-sl-ft"] = h_m / FT
    fdm["ic/vt-kts"] = tas_mps / KT
    fdm["ic/gamma-deg"] = 0.0
    fdm["ic/psi-true-deg"] = math.degrees(psi_rad) % 360.0
    fdm["ic/lat-geod-deg"] = LATITUDE_DEG
    fdm["ic/long-gc-deg"] = LONGITUDE_DEG
    fdm.run_ic()
    fdm["propulsion/set-running"] = -1
    fdm["gear/gear-cmd-norm"] = 0.0
    fdm["gear/gear-pos-norm"] = 0.0
    try:
        fdm.do_trim(1)
    except Exception as exc:  # JSBSim raises its own TrimFailureError (a RuntimeError)
        raise SimulationError(
            f"{profile.name}: trim failed at h = {h_m:.0f} m, TAS = {tas_mps:.1f} m/s "
            f"({type(exc).__name__}); choose another flight condition"
        ) from None
    fdm["simulation/models/FGFCS/enabled"] = 0
    for model in IDLE_MODELS:
        fdm[f"simulation/models/{model}/enabled"] = 0
    return fdm


def set_wind(fdm, ned_mps, severity: int = 0, seed: int = 1) -> None:
    """Put a trimmed model into a steady wind (plus turbulence) without losing the trim.

    JSBSim's trim leaves the wind at zero, and a wind set afterwards changes the airspeed
    by the wind. Here the model is re-initialised at the trimmed position, attitude and
    Earth-relative velocity *air velocity + wind*, then the wind is set and the derivatives
    recomputed without integrating: the air-relative state (airspeed, alpha, beta), hence
    forces and moments, are those of the trim (run_ic itself zeroes the wind).

    Parameters
    ----------
    fdm : jsbsim.FGFDMExec
        Trimmed (FCS off, as :func:`trim_fdm` leaves it), before its first ``run()``.
    ned_mps : (3,) sequence of float
        Steady wind towards north, east, down [m/s].
    severity : int
        MIL-F-8785C turbulence probability-of-exceedance index (0: no turbulence).
    seed : int
        JSBSim random seed of the turbulence.
    """
    wind = [float(w) / FT for w in ned_mps]
    for name in ("phi", "theta"):
        fdm[f"ic/{name}-rad"] = fdm[f"attitude/{name}-rad"]
    fdm["ic/psi-true-rad"] = fdm["attitude/psi-rad"]
    fdm["ic/lat-geod-deg"] = fdm["position/lat-geod-deg"]
    fdm["ic/long-gc-deg"] = fdm["position/long-gc-deg"]
    fdm["ic/h-sl-ft"] = fdm["position/h-sl-ft"]
    ground = [fdm[f"velocities/v-{d}-fps"] + w for d, w in zip(("north", "east", "down"), wind)]
    fdm["ic/vn-fps"], fdm["ic/ve-fps"], fdm["ic/vd-fps"] = ground
    fdm["ic/p-rad_sec"] = fdm["ic/q-rad_sec"] = fdm["ic/r-rad_sec"] = 0.0
    fdm.run_ic()
    for d, w in zip(("north", "east", "down"), wind):
        fdm[f"atmosphere/wind-{d}-fps"] = w
    if severity:
        fdm["simulation/randomseed"] = int(seed)
        fdm["atmosphere/turb-type"] = 3  # MIL-F-8785C (Dryden form)
        fdm["atmosphere/turbulence/milspec/severity"] = int(severity)
        fdm["atmosphere/turbulence/milspec/windspeed_at_20ft_AGL-fps"] = math.hypot(*wind[:2])
    # run_ic left derivatives computed in still air (a sideslip of wind/V): recompute them in
    # the wind without integrating, or the first step would integrate that sideslip's moments
    fdm.suspend_integration()
    fdm.run()
    fdm.resume_integration()


class Recorder:
    """Fast access to the recorded and written properties of one FDM.

    Holds property-node handles (about 0.15 us per read instead of a name lookup).
    """

    def __init__(self, fdm, profile: AircraftProfile):
        pm = fdm.get_property_manager()

        def node(name):
            if not pm.hasNode(name):
                raise SimulationError(
                    f"{profile.name}: JSBSim property {name!r} does not exist in model "
                    f"{profile.model!r}; fix the aircraft profile"
                )
            return pm.get_node(name)

        self._read = [node(n).get_double_value for n in RECORD]
        self.surface_writers = [
            [(node(p).set_double_value, float(g)) for p, g in s.writes] for s in profile.surfaces
        ]
        self.surface_reads = [node(s.writes[0][0]).get_double_value for s in profile.surfaces]
        self.throttle_nodes = [node(p) for p in profile.throttles]
        self.schedule_writers = [
            (node(p).set_double_value, dflt, rules) for p, dflt, rules in profile.schedules
        ]
        self.flap_read = (node(profile.flap_property).get_double_value
                          if profile.flap_property else None)
        engines = [f"propulsion/engine[{i}]" for i in range(len(profile.throttles))]
        fuel = [node(f"{e}/fuel-flow-rate-pps").get_double_value for e in engines]
        fans = [pm.get_node(f"{e}/n1").get_double_value for e in engines
                if pm.hasNode(f"{e}/n1")]
        nan = float("nan")

        def engine_values() -> tuple[float, float]:
            return (sum(f() for f in fuel),
                    sum(f() for f in fans) / len(fans) if fans else nan)

        self._engines = engine_values
        reads = self._read
        self.sample = lambda: [*(f() for f in reads), *engine_values()]

    def sample(self) -> list[float]:  # replaced per instance by a closure (faster)
        """Current values of :data:`RECORD` and :data:`ENGINE_RECORD`, in JSBSim units."""
        return [*(f() for f in self._read), *self._engines()]
