"""Surfaces: the composite topography Δh that enters the contact solvers."""
from .footprint import disc, rectangle
from .midpoint import midpoint_surface
from .topography import Topography

__all__ = ["Topography", "disc", "rectangle", "midpoint_surface"]
