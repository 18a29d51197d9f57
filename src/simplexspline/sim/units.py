"""Unit conversions at the JSBSim boundary (JSBSim works in ft, lbf, slug, slug ft^2).

Everything inside simplexspline is SI with angles in radians; these constants are applied
exactly once, where values leave or enter JSBSim.
"""

from __future__ import annotations

#: metres per foot (exact).
FT = 0.3048
#: newtons per pound-force (exact).
LBF = 4.4482216152605
#: kilograms per slug.
SLUG = 14.593902937206364
#: kg m^2 per slug ft^2.
SLUG_FT2 = 1.3558179483314004
#: N m per lbf ft.
LBF_FT = LBF * FT
#: kg/m^3 per slug/ft^3.
SLUG_FT3 = SLUG / FT**3
#: Pa per lbf/ft^2.
PSF = LBF / FT**2
#: metres per inch (exact).
IN = 0.0254
#: m/s per knot (exact).
KT = 1852.0 / 3600.0
#: kilograms per pound (mass, exact).
LB = 0.45359237
#: standard gravity [m/s^2] (used only to express load factors).
G0 = 9.80665
