"""Model structure selection: validation splits and scores, search moves, the greedy search.

:mod:`~simplexspline.aero.selection.validation` (splits by maneuver, RMS, relative RMS, R^2,
residual analysis), :mod:`~simplexspline.aero.selection.moves` (a structure's neighbours),
:mod:`~simplexspline.aero.selection.fold_equations` (the folds' normal equations shared by
the candidates) and :mod:`~simplexspline.aero.selection.search` (fit, cross-validate,
search).
"""

from simplexspline.aero.selection.search import (
    PLAIN_FIT,
    SearchCache,
    SelectionSettings,
    Trial,
    choose_prior_degree,
    cv_score,
    fit_structure,
    select_structure,
)

__all__ = [
    "PLAIN_FIT",
    "SearchCache",
    "SelectionSettings",
    "Trial",
    "choose_prior_degree",
    "cv_score",
    "fit_structure",
    "select_structure",
]
