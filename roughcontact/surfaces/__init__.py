"""Surfaces: the composite topography Δh that enters the contact solvers.

Generators (random midpoint displacement, §3.3; Fourier filtering), readers of
measured files (§3.4), composite topographies of facing or shifted mated
surfaces (Fig. 7), multiresolution copies (Fig. 1) and statistics (rms
height and slope, PSD, fractal dimension).
"""
from .composite import composite_topography, mated_composite
from .detrend import detrend
from .footprint import disc, rectangle
from .fourier import fourier_surface
from .fractal_dimension import (
    FractalDimensionEstimate,
    fractal_dimension,
    fractal_dimension_cube_counting,
    fractal_dimension_psd,
    fractal_dimension_variogram,
    fractal_dimensions,
)
from .io import read_topography, write_topography
from .midpoint import midpoint_surface
from .multiresolution import coarsen, multiresolution
from .rows import TopographyRows
from .statistics import RadialPSD, StructureFunction, radial_psd, rms_height, rms_slope, structure_function
from .topography import Topography

__all__ = [
    "Topography", "TopographyRows", "disc", "rectangle",
    "midpoint_surface", "fourier_surface",
    "read_topography", "write_topography", "detrend",
    "composite_topography", "mated_composite",
    "coarsen", "multiresolution",
    "rms_height", "rms_slope", "radial_psd", "structure_function", "RadialPSD", "StructureFunction",
    "fractal_dimension", "fractal_dimensions", "fractal_dimension_psd", "fractal_dimension_variogram",
    "fractal_dimension_cube_counting", "FractalDimensionEstimate",
]
