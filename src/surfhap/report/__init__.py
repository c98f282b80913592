"""Figures (matplotlib object API) and HTML reports built from result objects."""
