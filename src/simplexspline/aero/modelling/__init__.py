"""Aerodynamic model structures and models: notation, structures, presets, priors, the model."""
