"""The mapping file's errors name the line; ISA, air data and mass properties are right."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from simplexspline.aero.data import atmosphere
from simplexspline.aero.data.mapping import read_mapping
from simplexspline.aero.data.mass_properties import (
    inertias_from_radii,
    inertias_from_table,
    mass_from_fuel,
)
from simplexspline.aero.data.record_import import import_record
from simplexspline.aero.data.units import conversion, quantity
from simplexspline.errors import FlightDataError, InputError

DATA = Path(__file__).resolve().parents[1] / "data" / "citation_like"
MAPPING = DATA / "mapping.toml"


def _mapping(tmp_path, old: str, new: str) -> Path:
    text = MAPPING.read_text()
    assert old in text
    text = text.replace(old, new).replace('path = "."', f'path = "{DATA}"').replace(
        'list = "maneuvers.csv"', f'list = "{DATA / "maneuvers.csv"}"')
    path = tmp_path / "mapping.toml"
    path.write_text(text)
    return path


def _line(path: Path, fragment: str) -> int:
    return next(i for i, ln in enumerate(path.read_text().splitlines(), 1) if fragment in ln)


def test_the_shipped_mapping_reads():
    m = read_mapping(MAPPING)
    assert m.aircraft.S == pytest.approx(322.9 * 0.3048 ** 2)
    assert m.aircraft.ramp_mass == pytest.approx(14000 * 0.45359237)
    assert m.channels["az"].sign == -1.0 and m.channels["q"].unit == "deg/s"
    assert m.record.format == "channels" and m.segments.method == "list"


def test_unknown_unit_names_the_line(tmp_path):
    p = _mapping(tmp_path, 'unit = "deg/s" }\nr', 'unit = "degrees per sekond" }\nr')
    line = _line(p, "degrees per sekond")
    with pytest.raises(InputError, match=rf"mapping.toml line {line} \(channels.q.unit\): "
                                         r"unknown unit 'degrees per sekond'"):
        read_mapping(p)


def test_unit_of_the_wrong_dimension_names_column_and_line(tmp_path):
    p = _mapping(tmp_path, 'source = "hp", unit = "ft"', 'source = "hp", unit = "knot"')
    line = _line(p, 'source = "hp"')
    with pytest.raises(InputError, match=rf"line {line} \(channels.h.unit\): unit 'knot' is a "
                                         r".*column 'h' is stored in 'm'"):
        read_mapping(p)


def test_unknown_column_names_the_line_and_lists_the_known_ones(tmp_path):
    p = _mapping(tmp_path, "wow = {", "weight_on_wheels = {")
    line = _line(p, "weight_on_wheels")
    with pytest.raises(InputError, match=rf"line {line} \(channels.weight_on_wheels\): unknown "
                                         r"column 'weight_on_wheels'.*'wow'"):
        read_mapping(p)


def test_unknown_source_channel_names_file_and_mapping_line(tmp_path):
    p = _mapping(tmp_path, 'source = "pitch_rate"', 'source = "pitch_rat"')
    line = _line(p, "pitch_rat")
    with pytest.raises(FlightDataError, match=rf"channel 'pitch_rat' \(.*mapping.toml line "
                                              rf"{line}\): file .*pitch_rat.txt' does not exist"):
        import_record(p)


def test_aircraft_values_need_units(tmp_path):
    p = _mapping(tmp_path, 'b = "52.2 ft"', "b = 15.9")
    with pytest.raises(InputError, match=r"line \d+ \(aircraft.b\): 15.9 has no unit"):
        read_mapping(p)
    p = _mapping(tmp_path, 'S = "322.9 ft^2"', 'S = "322.9 ft"')
    with pytest.raises(InputError, match=r"aircraft.S\): '322.9 ft' is a \[length\] but a "
                                         r"\[length\] \*\* 2"):
        read_mapping(p)


def test_a_sign_other_than_plus_or_minus_one_is_refused(tmp_path):
    p = _mapping(tmp_path, 'unit = "g0", sign = -1', 'unit = "g0", sign = -9.81')
    with pytest.raises(InputError, match=r"channels.az.sign\): must be 1 or -1, got -9.81"):
        read_mapping(p)


def test_unknown_keys_and_tables_are_refused(tmp_path):
    p = _mapping(tmp_path, 'rate_hz = 10', 'rate_hz = 10\nsample_rate = 10')
    with pytest.raises(InputError, match=r"\(record.sample_rate\): unknown key 'sample_rate'"):
        read_mapping(p)
    p = _mapping(tmp_path, "[segments]", "[segmentation]")
    with pytest.raises(InputError, match=r"unknown table \[segmentation\]"):
        read_mapping(p)


def test_metadata_passes_through_and_may_not_override_the_aircraft(tmp_path):
    p = _mapping(tmp_path, "[segments]", "[metadata]\nsensor_geometry = { lag_s = { alpha = "
                 "0.05 } }\nflight = \"FT-042\"\n\n[segments]")
    result = import_record(p)
    assert result.metadata["sensor_geometry"] == {"lag_s": {"alpha": 0.05}}
    assert result.metadata["flight"] == "FT-042"
    p = _mapping(tmp_path, "[segments]", "[metadata]\nS = 30\n\n[segments]")
    with pytest.raises(InputError, match=r"\(metadata.S\): set by the import from \[aircraft\]"):
        read_mapping(p)


def test_altitude_in_feet_labelled_metres_is_caught(tmp_path):
    p = _mapping(tmp_path, 'source = "hp", unit = "ft"', 'source = "hp", unit = "m"')
    result = import_record(p)        # 4900 'm' is a possible altitude: the ISA accepts it ...
    assert result.data["h"].max() > 4500
    p = _mapping(tmp_path, 'source = "hp", unit = "ft"', 'source = "hp", unit = "cm"')
    # ... but the wrong unit shows in the derived air data: Mach from IAS at 49 m altitude
    assert import_record(p).data["mach"].max() < 0.4


def test_degrees_labelled_radians_are_flagged(tmp_path):
    p = _mapping(tmp_path, 'source = "roll_angle", unit = "deg"',
                 'source = "roll_angle", unit = "rad"')
    with pytest.raises(FlightDataError, match=r"column 'phi' has value .* impossible in "
                                              r"radians"):
        from simplexspline.aero.data.flight_data import validate_flight_data

        validate_flight_data(import_record(p).data, nan="ignore")
    p = _mapping(tmp_path, 'source = "pitch_rate", unit = "deg/s"',
                 'source = "pitch_rate", unit = "rad/s"')
    warned = [c for c in import_record(p).sanity.problems if c.name == "units q"]
    assert warned and "looks like deg/s" in warned[0].message


def test_isa_against_standard_tables():
    # ICAO standard atmosphere: 5000 m: 54019.9 Pa, 255.65 K, 0.73612 kg/m^3;
    # 15000 m: 12044.6 Pa, 216.65 K, 0.19367 kg/m^3
    assert atmosphere.isa_pressure(5000.0) == pytest.approx(54019.9, rel=1e-5)
    assert atmosphere.isa_temperature(5000.0) == pytest.approx(255.65)
    assert atmosphere.isa_density(5000.0) == pytest.approx(0.73612, rel=1e-4)
    assert atmosphere.isa_pressure(15000.0) == pytest.approx(12044.6, rel=1e-4)
    assert atmosphere.isa_density(15000.0) == pytest.approx(0.19367, rel=1e-4)
    with pytest.raises(InputError, match=r"pressure altitude 32808 m is outside the ISA "
                                         r"model .*feet given as metres"):
        atmosphere.isa_pressure(32808.0)


def test_cas_equals_tas_at_sea_level_and_the_pitot_relation_inverts():
    p0 = atmosphere.isa_pressure(0.0)
    m = atmosphere.mach_from_cas(150.0, p0)
    assert m * atmosphere.speed_of_sound(288.15) == pytest.approx(150.0, rel=1e-12)
    # slow flight is incompressible: CAS = EAS = TAS sqrt(rho/rho0), M = EAS sqrt(p0/p) / a0
    p = atmosphere.isa_pressure(10000.0)
    m = atmosphere.mach_from_cas(10.0, p)
    assert m == pytest.approx(10.0 / 340.294 * np.sqrt(atmosphere.P0 / p), rel=1e-3)
    t = atmosphere.static_temperature_from_total(250.0 * (1 + 0.2 * 0.6 ** 2), 0.6)
    assert t == pytest.approx(250.0)


def test_mass_and_inertias():
    m = mass_from_fuel(7000.0, [0.0, 500.0, np.nan])
    assert m[:2].tolist() == [7000.0, 6500.0] and np.isnan(m[2])
    with pytest.raises(InputError, match="more than the ramp mass"):
        mass_from_fuel(1000.0, [1500.0])
    i = inertias_from_radii(np.array([1000.0]), {"x": 2.0, "y": 3.0, "z": 4.0, "xz": -0.5})
    assert (i["Ixx"][0], i["Iyy"][0], i["Izz"][0], i["Ixz"][0]) == (4000, 9000, 16000, -250)
    table = {"mass": [5000.0, 7000.0], "Ixx": [1e4, 2e4], "Iyy": [3e4, 3e4],
             "Izz": [4e4, 6e4]}
    i = inertias_from_table(np.array([6000.0, 6500.0]), table)
    assert i["Ixx"].tolist() == [1.5e4, 1.75e4] and i["Izz"].tolist() == [5e4, 5.5e4]
    assert i["Ixz"].tolist() == [0.0, 0.0]
    with pytest.raises(InputError, match=r"leaves the inertia table \(5000 .. 7000 kg\)"):
        inertias_from_table(np.array([7100.0]), table)


def test_inertia_table_in_the_mapping(tmp_path):
    table = ('[aircraft.inertia_table]\nmass_unit = "lb"\ninertia_unit = "slug*ft^2"\n'
             "mass = [12000, 14500]\nIxx = [30000, 34000]\nIyy = [44000, 47000]\n"
             "Izz = [70000, 76000]\nIxz = [1000, 1100]\n\n[channels]")
    p = _mapping(tmp_path, 'radii_of_gyration = { x = "2.6 m", y = "3.1 m", z = "3.9 m" }\n\n'
                 "[channels]", table)
    result = import_record(p)
    mass_lb = result.data["mass"] / 0.45359237
    expect = np.interp(mass_lb, [12000, 14500], [30000, 34000]) * 1.3558179483314004
    assert np.allclose(result.data["Ixx"], expect, rtol=1e-9)
    assert "inertia table interpolated in mass" in result.derived["Ixx, Iyy, Izz, Ixz"]


def test_units_via_pint():
    assert conversion("g0", "m/s^2")(1.0) == pytest.approx(9.80665)
    assert conversion("degC", "K")(np.array([-56.5]))[0] == pytest.approx(216.65)
    assert quantity("14000 lb", "kg") == pytest.approx(6350.29318)
    assert quantity("1 slug*ft^2", "kg*m^2") == pytest.approx(1.3558179483314004)


@pytest.mark.parametrize(("unit", "target", "value"), [
    ("g", "m/s^2", 9.80665), ("[g]", "m/s^2", 9.80665), ("G", "m/s^2", 9.80665),
    ("[deg]", "rad", np.pi / 180), ("(deg/s)", "rad/s", np.pi / 180),
    ("deg C", "K", 274.15), ("[deg C]", "K", 274.15), ("C", "K", 274.15),
    ("F", "K", 255.92777777777778), ("fpm", "m/s", 0.00508), ("pph", "kg/s", 0.45359237 / 3600),
    ("[lbs/hr]", "kg/s", 0.45359237 / 3600), ("[kts]", "m/s", 1852 / 3600),
    ("[mach]", "dimensionless", 1.0), ("[-]", "dimensionless", 1.0)])
def test_flight_test_spellings_of_units(unit, target, value):
    """Channel lists write units in brackets, 'g' for the standard gravity and 'deg C'."""
    assert conversion(unit, target)(1.0) == pytest.approx(value)


def test_g_is_a_gram_where_a_mass_is_meant():
    """The standard-gravity reading of 'g' holds for accelerations only."""
    assert conversion("g", "kg")(1000.0) == pytest.approx(1.0)
    with pytest.raises(InputError, match=r"unit 'C' is a .*current"):
        conversion("C", "m/s^2")


def test_a_required_channel_without_data_is_named(tmp_path):
    p = _mapping(tmp_path, 'source = "pitch_rate"', 'source = "heading"')
    line = _line(p, 'q = { source = "heading"')
    with pytest.raises(FlightDataError, match=rf"required channel\(s\) \['q'\] are mapped but "
                                              rf"hold no data \(.*mapping.toml line {line}\)"):
        import_record(p)


def test_missing_ramp_mass_and_inertias_say_what_to_give(tmp_path):
    p = _mapping(tmp_path, 'ramp_mass = "14000 lb"\n', "")
    with pytest.raises(InputError, match=r"no mass: map a 'mass' channel or give \[aircraft\] "
                                         r"ramp_mass"):
        import_record(p)
    p = _mapping(tmp_path, 'radii_of_gyration = { x = "2.6 m", y = "3.1 m", z = "3.9 m" }\n', "")
    with pytest.raises(InputError, match=r"no inertias: give \[aircraft\] radii_of_gyration or "
                                         r"inertia_table"):
        import_record(p)
