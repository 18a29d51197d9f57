"""Aircraft profiles: registry, plain-data round trip, configuration errors."""

from __future__ import annotations

import pytest

from simplexspline.errors import InputError, SimulationError
from simplexspline.sim import (
    AircraftProfile,
    Campaign,
    ConditionGrid,
    FlightProtocol,
    SensorModel,
    available_aircraft,
    get_aircraft,
    register_aircraft,
)


@pytest.mark.parametrize("name", ["f16", "global5000", "c172p", "A4", "737", "T37"])
def test_profile_round_trips_as_plain_data(name):
    prof = get_aircraft(name)
    assert AircraftProfile.from_dict(prof.to_dict()) == prof
    assert get_aircraft(prof) is prof


def test_register_a_modified_profile():
    prof = get_aircraft("f16").replace(name="f16-test", fuel_fraction=(1.0, 1.0))
    register_aircraft(prof)
    assert "f16-test" in available_aircraft()
    assert get_aircraft("f16-test").fuel_fraction == (1.0, 1.0)
    with pytest.raises(InputError, match="expects an AircraftProfile"):
        register_aircraft({"name": "x"})


def test_a_profile_naming_a_missing_property_fails_clearly():
    prof = get_aircraft("f16").replace(name="f16-broken", flap_property="fcs/no-such-flap")
    campaign = Campaign(prof, grid=ConditionGrid([3000.0], [170.0]), maneuvers=1,
                        protocol=FlightProtocol(mix={"doublet": 1}), sensors=SensorModel.ideal())
    with pytest.raises(SimulationError, match="property 'fcs/no-such-flap' does not exist"):
        campaign.run(workers=1, progress=False)


def test_a_profile_loading_a_missing_property_fails_clearly():
    prof = get_aircraft("c172p").replace(name="c172p-broken",
                                         loading=(("inertia/no-such", 0.0),))
    campaign = Campaign(prof, grid=ConditionGrid([1000.0], [45.0]), maneuvers=1,
                        protocol=FlightProtocol(mix={"doublet": 1}), sensors=SensorModel.ideal())
    with pytest.raises(InputError, match="loading property 'inertia/no-such' does not"):
        campaign.run(workers=1, progress=False)
