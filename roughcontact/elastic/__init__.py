"""Elastic half-space operators: Eq. 10 influence coefficients and their PETSc matrix."""
