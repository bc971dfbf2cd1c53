"""Flexibility operators of the elastic half-space: the Eq. 10 kernel and its PETSc matrices.

- :mod:`.kernel`: the circular-punch influence coefficients (Eq. 10), numpy only;
- :mod:`.dense`: the explicit matrix H as a row-distributed PETSc MATDENSE;
- :mod:`.memory`: bytes each operator needs per rank, checked before anything is built.
"""
from .memory import operator_memory

__all__ = ["operator_memory"]
