"""Simulated flight-test campaigns on JSBSim (optional extra ``simplexspline[sim]``).

Describe a campaign (aircraft, number of maneuvers, seed, the altitude x airspeed
:class:`ConditionGrid`, the maneuver mix and flying of the :class:`FlightProtocol`, sensors),
run it, get one table per campaign in the flight-data schema
(``docs/flight-data-schema.md``)::

    from simplexspline.sim import Campaign
    df = Campaign("f16", maneuvers=250, seed=0).run()      # ~1e6 samples at 100 Hz
    from simplexspline.aero.data.flight_data import write_flight_data
    write_flight_data(df, "campaign.parquet")

Maneuvers follow Section IV of de Visser, Mulder and Chu (AIAA 2010-7950): automatic
3211 pulse trains and doublets on elevator, aileron or rudder, and ~100 s multi-axis
random-phase sum-of-sines disturbances while a pilot model holds straight and level.
"""

from __future__ import annotations

from simplexspline.sim.aircraft import (
    SURFACE_SIGN_CONVENTIONS,
    AircraftProfile,
    Envelope,
    Surface,
    available_aircraft,
    get_aircraft,
    register_aircraft,
)
from simplexspline.sim.campaign_table import envelope_coverage
from simplexspline.sim.campaign import (
    DEFAULT_MIX,
    Campaign,
    ConditionGrid,
    FlightProtocol,
    simulate_campaign,
)
from simplexspline.sim.maneuvers import EXCITATION_DESIGNS, MANEUVER_FAMILIES, MANEUVER_TYPES
from simplexspline.sim.pilot import PilotStyle
from simplexspline.sim.record_export import write_channel_record
from simplexspline.sim.wind import TURBULENCE_SEVERITY, Wind
from simplexspline.sim.sensors import (
    DEFAULT_BIAS,
    DEFAULT_NOISE_STD,
    MEASURED_CHANNELS,
    SensorModel,
)

__all__ = [
    "Campaign",
    "ConditionGrid",
    "FlightProtocol",
    "PilotStyle",
    "simulate_campaign",
    "write_channel_record",
    "SensorModel",
    "Wind",
    "TURBULENCE_SEVERITY",
    "Envelope",
    "AircraftProfile",
    "Surface",
    "get_aircraft",
    "register_aircraft",
    "available_aircraft",
    "envelope_coverage",
    "DEFAULT_MIX",
    "DEFAULT_NOISE_STD",
    "DEFAULT_BIAS",
    "MEASURED_CHANNELS",
    "MANEUVER_FAMILIES",
    "MANEUVER_TYPES",
    "EXCITATION_DESIGNS",
    "SURFACE_SIGN_CONVENTIONS",
]
