"""Flight data: the schema and its files, import of real records, signal differentiation,
coefficients (Eq. 43-48)."""
