"""Generators of checked-in artefacts: the uncoupled model's error table and the analysis figures.

Run from the repository root, e.g. ``python -m tools.chart_uncoupled_error --table
roughcontact/tangential/uncoupled_error_table.py``.
"""
