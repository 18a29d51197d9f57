"""Files a spline is written to: versioned model files (JSON or npz) and C99 source.

:mod:`~simplexspline.spline.formats.model_file` (the open model file format: JSON or npz,
no serialised Python objects),
:mod:`~simplexspline.spline.formats.c_export` (dependency-free C99 evaluation code) and
:mod:`~simplexspline.spline.formats.c_templates` (the C evaluation core it fills in).
"""
