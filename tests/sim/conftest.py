"""Small simulated campaigns shared by the simulator tests (seconds, not minutes)."""

from __future__ import annotations

import pytest

from simplexspline.sim import Campaign, ConditionGrid, FlightProtocol, SensorModel

#: A campaign with every maneuver family and all three pulse axes, kept short.
SMALL = {
    "f16": ConditionGrid(altitudes_m=[3000.0, 7000.0], airspeeds_mps=[160.0, 220.0]),
    "global5000": ConditionGrid(altitudes_m=[3000.0, 8000.0], airspeeds_mps=[170.0, 220.0]),
    "c172p": ConditionGrid(altitudes_m=[800.0, 2000.0], airspeeds_mps=[42.0, 55.0]),
    "A4": ConditionGrid(altitudes_m=[3000.0, 8000.0], airspeeds_mps=[160.0, 220.0]),
    "737": ConditionGrid(altitudes_m=[3000.0, 8000.0], airspeeds_mps=[180.0, 230.0]),
    "T37": ConditionGrid(altitudes_m=[2000.0, 5000.0], airspeeds_mps=[100.0, 135.0]),
}
MIX = {"3211": 3, "doublet": 1, "sum-of-sines": 2}


def small_campaign(aircraft: str, *, seed: int = 7, sensors: SensorModel | None = None,
                   maneuvers: int = 6, grid: ConditionGrid | None = None,
                   maneuvers_per_condition: int | None = None, envelope=None, wind=None,
                   **protocol) -> Campaign:
    """A short campaign; ``protocol`` overrides the :class:`FlightProtocol` settings."""
    return Campaign(aircraft, maneuvers=maneuvers,
                    maneuvers_per_condition=maneuvers_per_condition, seed=seed,
                    grid=SMALL[aircraft] if grid is None else grid,
                    protocol=FlightProtocol(**{"mix": MIX, "sos_duration_s": (15.0, 20.0),
                                               **protocol}),
                    sensors=SensorModel.ideal() if sensors is None else sensors,
                    envelope=envelope, wind=wind)


@pytest.fixture(scope="session")
def f16_ideal():
    """Six f16 maneuvers, perfect sensors, run in this process."""
    return small_campaign("f16").run(workers=1, progress=False)


@pytest.fixture(scope="session")
def global5000_ideal():
    """Six global5000 maneuvers, perfect sensors, run in this process."""
    return small_campaign("global5000").run(workers=1, progress=False)


@pytest.fixture(scope="session")
def c172p_ideal():
    """Six c172p (light piston) maneuvers, perfect sensors, run in this process."""
    return small_campaign("c172p").run(workers=1, progress=False)


@pytest.fixture(scope="session")
def a4_ideal():
    """Six A4 (subsonic attack jet) maneuvers, perfect sensors, run in this process."""
    return small_campaign("A4").run(workers=1, progress=False)


@pytest.fixture(scope="session")
def b737_ideal():
    """Six 737 (twin-jet transport) maneuvers, perfect sensors, run in this process."""
    return small_campaign("737").run(workers=1, progress=False)


@pytest.fixture(scope="session")
def t37_ideal():
    """Six T37 (straight-wing twin-jet trainer) maneuvers, perfect sensors, in this process."""
    return small_campaign("T37").run(workers=1, progress=False)


@pytest.fixture(scope="session", params=["f16", "global5000", "c172p", "A4", "737", "T37"])
def ideal(request):
    """Each bundled aircraft's small ideal campaign (built on first use)."""
    return request.getfixturevalue({"f16": "f16_ideal", "global5000": "global5000_ideal",
                                    "c172p": "c172p_ideal", "A4": "a4_ideal",
                                    "737": "b737_ideal", "T37": "t37_ideal"}[request.param])
