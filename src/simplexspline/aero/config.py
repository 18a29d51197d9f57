"""Identification settings from a TOML file and model structures from text.

A config file (all tables and keys optional)::

    [identify]
    coefficients = ["CX", "CY", "CZ", "Cl", "Cm", "Cn"]
    preset = "auto"            # starting structures: 'auto' | 'paper' | 'varying' | 'f16'

    validation_fraction = 0.25
    seed = 0
    select = true              # automatic structure selection from the structures below
    reconstruct = "auto"       # 'auto' | 'always' | 'never'
    thin_factor = 2.0
    derivative_folds = 5       # jackknife folds of the derivatives' standard errors (0: none)
    matched_regressors = false # moment regressors smoothed as the differentiated accelerations

    [selection]
    candidates = ["alpha", "beta", "mach", "phat", "qhat", "rhat", "de", "da", "dr",
                  "alphadot_hat", "betadot_hat", "flap", "gear", "speedbrake", "dte", "mass",
                  "tc", "tc_ff", "tc_n1"]
    max_rounds = 12
    folds = 3
    min_improvement = 0.01
    asymmetry_improvement = 0.1  # a term that breaks the mirror symmetry (thrust in Cl)
    max_degree = 5
    max_resolution = 6
    max_variables = 5
    max_schedule = 3           # scheduling variables of a varying-coefficient structure
    screen = 3                 # 'add multiplier', 'schedule on', 'add kink' moves per round
    combine = 3                # other improving moves tried on top of a round's best
    max_coefficients = 12000
    max_samples = 60000
    min_points = 10
    moves = ["degree", "resolution", "variables", "kinks"]
    prior = "auto"             # coarse-model prior: 'auto' (varying structures) | 'coarse'
    prior_weight = 0.01
    smoothing = "gcv"          # optional smoothness penalty: 'gcv' | 'auto' | a weight

    [models.CZ]                # starting (or fixed, with select = false) structure
    variables = ["alpha", "de", "mach", "qhat"]
    degree = 3
    continuity = 1
    resolution = [3, 1, 1, 1]  # grid cells per variable (an integer applies to all)

    [models.Cl]                # varying coefficient: Cl = sum_k m_k s_k(alpha, beta, mach)
    variables = ["alpha", "beta", "mach"]
    multipliers = ["1", "phat", "rhat", "da", "dr"]
    knots = { alpha = [-0.0873, 0.0, 0.0873, 0.1745], mach = [0.6, 0.8] }
    degree = 2
    continuity = 0

Structures on the command line use the label format printed in tables, e.g.
``"CZ(alpha:3, de, mach) S^1_3"`` (``:k`` = k grid cells), or the short form
``"CZ=alpha,de,mach"`` (S^1_3, one cell per variable).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import fields, replace
from pathlib import Path

from simplexspline.aero.identify import IdentificationSettings
from simplexspline.aero.selection.search import SelectionSettings
from simplexspline.aero.modelling.notation import parse_knots
from simplexspline.aero.modelling.structure import Structure, structures_from_config
from simplexspline.aero.variables import COEFFICIENTS
from simplexspline.errors import InputError

__all__ = ["load_config", "parse_structure", "settings_from_config"]

_LABEL = re.compile(r"^\s*(?P<coef>\w+)\s*\((?P<vars>[^)]*)\)\s*(?:S\^(?P<r>-?\d+)_(?P<d>\d+))?"
                    r"(?P<cellwise>\s+cellwise)?\s*$")
_SHORT = re.compile(r"^\s*(?P<coef>\w+)\s*=\s*(?P<vars>.+?)\s*$")


def parse_structure(text: str) -> Structure:
    """A structure from ``'CZ(alpha:3, de, mach) S^1_3'`` or ``'CZ=alpha,de,mach'``.

    Varying-coefficient structures list their multipliers after ``|`` and breakpoints
    after ``@``: ``'Cl(alpha@-10:25:5deg, beta:2, mach@0.6/0.8 | 1, phat, rhat, da, dr)
    S^0_2'`` (see :func:`~simplexspline.aero.modelling.structure.parse_knots`).
    """
    m = _LABEL.match(text) or _SHORT.match(text)
    if not m:
        raise InputError(f"cannot read the model structure {text!r}; write e.g. "
                         "'CZ(alpha:3, de, mach) S^1_3' or 'CZ=alpha,de,mach'")
    coef = m.group("coef")
    if coef not in COEFFICIENTS:
        raise InputError(f"unknown coefficient {coef!r} in {text!r}; known: "
                         f"{list(COEFFICIENTS)}")
    var_text, bar, mult_text = m.group("vars").partition("|")
    multipliers = tuple(p.strip() for p in mult_text.split(",") if p.strip()) if bar else ()
    if bar and not multipliers:
        raise InputError(f"no multipliers after '|' in {text!r}: list them, e.g. "
                         "'| 1, da' (1 is the constant term)")
    variables, resolution, knots = [], [], {}
    for part in var_text.split(","):
        part = part.strip()
        if not part:
            continue
        if "@" in part:
            name, _, spec = part.partition("@")
            name = name.strip()
            knots[name] = parse_knots(name, spec)
            variables.append(name)
            resolution.append(1)
            continue
        name, _, cells = part.partition(":")
        variables.append(name.strip())
        try:
            resolution.append(int(cells) if cells else 1)
        except ValueError:
            raise InputError(f"bad grid cell count {cells!r} for {name!r} in {text!r}") \
                from None
    groups = m.groupdict()
    degree = int(groups["d"]) if groups.get("d") else 3
    continuity = int(groups["r"]) if groups.get("r") else min(1, degree - 1)
    return Structure(coef, tuple(variables), degree, continuity, tuple(resolution),
                     multipliers, tuple(knots.items()), bool(groups.get("cellwise")))


def _read_toml(path: Path) -> dict:
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        import tomli as tomllib
    if not path.is_file():
        raise InputError(f"config file {str(path)!r} does not exist")
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"config file {str(path)!r} is not valid TOML: {exc}") from None


def _check_keys(table: Mapping, allowed, where: str) -> None:
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise InputError(f"unknown key(s) {unknown} in [{where}] of the config; allowed: "
                         f"{sorted(allowed)}")


def settings_from_config(config: Mapping,
                         base: IdentificationSettings | None = None) -> IdentificationSettings:
    """Identification settings from a parsed config mapping (see the module docstring)."""
    base = base or IdentificationSettings()
    _check_keys(config, ("identify", "selection", "models"), "top level")
    ident = dict(config.get("identify", {}))
    sel = dict(config.get("selection", {}))
    allowed_ident = [f.name for f in fields(IdentificationSettings)
                     if f.name not in ("structures", "selection")]
    _check_keys(ident, allowed_ident, "identify")
    _check_keys(sel, [f.name for f in fields(SelectionSettings)], "selection")
    for key in ("candidates", "moves"):
        if key in sel:
            sel[key] = tuple(sel[key])
    if "coefficients" in ident:
        ident["coefficients"] = tuple(ident["coefficients"])
    try:
        selection = replace(base.selection, **sel)
    except TypeError as exc:
        raise InputError(f"[selection]: {exc}") from None
    structures = dict(base.structures or {})
    if "models" in config:
        structures.update(structures_from_config(config["models"], base=structures))
    return replace(base, **ident, selection=selection, structures=structures or None)


def load_config(path, base: IdentificationSettings | None = None) -> IdentificationSettings:
    """Read a TOML config file into :class:`IdentificationSettings`."""
    return settings_from_config(_read_toml(Path(path)), base)
