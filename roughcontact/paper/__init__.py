"""The founding paper reproduced: its figures from the studies of ``studies/paper/``, its claims tested.

Borri-Brunetto, Chiaia & Ciavarella (2001). ``roughcontact paper`` (or
``scripts/reproduce-paper``) runs the studies (:mod:`.registry`), draws
``fig01.png`` … ``fig14.png`` (:mod:`.figures`) and writes every claim as a
number with its 95 % interval over seeds and a verdict (:mod:`.claims`);
docs/paper.md reads them. This package sits above the farm: it only combines
what the lower packages measure.
"""
from .claims import CLAIMS, evaluate
from .registry import FIGURES, STUDIES

__all__ = ["CLAIMS", "FIGURES", "STUDIES", "evaluate"]
