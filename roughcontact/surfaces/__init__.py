"""Surfaces: the composite topography Δh that enters the contact solvers."""
from .footprint import disc, rectangle
from .fourier import fourier_surface
from .midpoint import midpoint_surface
from .statistics import RadialPSD, StructureFunction, radial_psd, rms_height, rms_slope, structure_function
from .topography import Topography

__all__ = ["Topography", "disc", "rectangle", "midpoint_surface", "fourier_surface",
           "rms_height", "rms_slope", "radial_psd", "structure_function", "RadialPSD", "StructureFunction"]
