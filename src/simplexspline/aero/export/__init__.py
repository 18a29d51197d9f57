"""Export identified aerodynamic models: C code with named physical inputs, lookup tables.

:mod:`~simplexspline.aero.export.c_code` (C99 with physical inputs) and
:mod:`~simplexspline.aero.export.lookup_tables` (CSV / npz tables, JSBSim functions).
"""

from simplexspline.aero.export.c_code import generate_aero_c, load_exportable
from simplexspline.aero.export.lookup_tables import (
    JSBSIM_PROPERTIES,
    TABLE_FORMAT,
    LookupTable,
    lookup_table,
    model_variables,
    parse_grid,
)

__all__ = [
    "JSBSIM_PROPERTIES",
    "TABLE_FORMAT",
    "LookupTable",
    "generate_aero_c",
    "load_exportable",
    "lookup_table",
    "model_variables",
    "parse_grid",
]
