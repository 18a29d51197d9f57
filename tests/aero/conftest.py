"""Small simulated campaigns shared by the reconstruction and coefficient tests."""

from __future__ import annotations

import pytest

from simplexspline.sim import Campaign, ConditionGrid, FlightProtocol, SensorModel

#: A short f16 campaign with 3211s, a doublet and two (short) sum-of-sines maneuvers.
SMALL = {"grid": ConditionGrid(altitudes_m=[3000.0, 7000.0], airspeeds_mps=[160.0, 220.0]),
         "protocol": FlightProtocol(mix={"3211": 3, "doublet": 1, "sum-of-sines": 2},
                                    sos_duration_s=(15.0, 20.0))}


def small_campaign(*, seed: int = 3, sensors: SensorModel | None = None,
                   maneuvers: int = 6) -> Campaign:
    return Campaign("f16", maneuvers=maneuvers, seed=seed,
                    sensors=SensorModel() if sensors is None else sensors, **SMALL)


@pytest.fixture(scope="session")
def noisy_campaign():
    """Six f16 maneuvers with the default sensor noise and biases (read-only)."""
    return small_campaign().run(workers=1, progress=False)


@pytest.fixture(scope="session")
def ideal_campaign():
    """The same six maneuvers with perfect sensors (read-only)."""
    return small_campaign(sensors=SensorModel.ideal()).run(workers=1, progress=False)


@pytest.fixture(scope="session")
def noisy_reconstruction(noisy_campaign):
    """The default reconstruction of ``noisy_campaign`` (read-only)."""
    from simplexspline.aero import reconstruct

    return reconstruct(noisy_campaign, workers=1)
