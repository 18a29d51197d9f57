"""Flight data: the schema and its files, signal differentiation, coefficients (Eq. 43-48)."""
