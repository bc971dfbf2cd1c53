"""Composite topography Δh of two facing surfaces, and of a shifted fracture (§3.4).

Both surfaces are described in one frame whose z axis points from the lower
body to the upper one: ``h_lower(x)`` is the lower body's surface,
``h_upper(x)`` the upper body's (as it sits before any shift). When the upper
body is displaced tangentially by ``v``, its surface above point x is
``h_upper(x − v)`` and the gap is ``g(x) = d + h_upper(x − v) − h_lower(x)``
for a rigid separation d. The contact problem of two rough elastic bodies
reduces to that of a flat half-space against the composite topography
(paper §2)

.. math::  Δh(x) = h_\\mathrm{lower}(x) − h_\\mathrm{upper}(x − v),

which is larger where the bodies come closer: the largest Δh touches first,
as everywhere in this package.

A fracture has perfectly mated faces, so ``h_upper = h_lower = h`` (§3.4:
"the hypothesis of perfectly corresponding surfaces at the opposite sides of
the fracture"): with no shift Δh ≡ 0, and the shift v of the joint (Fig. 7)
creates the roughness ``Δh(x) = h(x) − h(x − v)``. Δh exists only where both
faces are present, the overlap of the lower footprint and of the shifted
upper one (for a core of diameter D, the lens between two discs whose
centres are |v| apart). The result is cropped to that overlap.

Shifts that are not whole multiples of the spacing are applied by bilinear
interpolation of the upper face (:mod:`.interpolation`).
"""
from __future__ import annotations

import numpy as np

from ..checks import check_vector
from ..errors import InputError
from .interpolation import interpolate_at_indices, snap_to_integers
from .statistics import valid_nodes
from .topography import Topography

#: Relative tolerance on equal spacings of the two faces.
SPACING_RTOL = 1e-9


def composite_topography(lower: Topography, upper: Topography,
                         shift: tuple[float, float] = (0.0, 0.0)) -> Topography:
    """Δh(x) = h_lower(x) − h_upper(x − v) on the overlap of the two footprints.

    Parameters
    ----------
    lower, upper
        Surfaces of the lower and upper bodies in the common frame (z towards
        the upper body), on grids of the same spacing, origins coinciding
        before the shift.
    shift
        Tangential displacement v = (vx, vy) of the upper body (m), any
        direction; e.g. (−v, 0) for a shift to the west with x pointing east.

    Returns
    -------
    Topography
        On the nodes of ``lower`` where both faces are defined, cropped to
        their bounding rectangle. ``metadata["origin"]`` is the position (m)
        of the first node in the frame of ``lower``; ``metadata["shift"]`` is v.

    Raises
    ------
    InputError
        ``shift`` leaves no overlap (a shift larger than the surface), or the
        spacings differ.
    """
    vx, vy = check_vector("shift", shift)
    s = lower.spacing
    if abs(upper.spacing - s) > SPACING_RTOL * s:
        raise InputError("upper", f"spacing {upper.spacing:g} m differs from the lower surface's {s:g} m; "
                         "resample one of them first")
    ranges = []
    for axis, v in ((0, vx), (1, vy)):
        offset = float(snap_to_integers(v / s))
        first = max(0, int(np.ceil(offset)))
        last = min(lower.shape[axis] - 1, int(np.floor(upper.shape[axis] - 1 + offset)))
        if last < first:
            raise InputError("shift", f"v = ({vx:g}, {vy:g}) m moves the upper surface off the lower one "
                             f"along {'xy'[axis]}: there is no overlap")
        ranges.append((first, last, offset))
    (i0, i1, ox), (j0, j1, oy) = ranges
    # the upper face with NaN off its footprint, so the interpolant knows where it ends
    upper_heights = np.where(valid_nodes(upper), upper.heights, np.nan)
    shifted = interpolate_at_indices(upper_heights, np.arange(i0, i1 + 1) - ox, np.arange(j0, j1 + 1) - oy)
    lower_heights = np.where(valid_nodes(lower), lower.heights, np.nan)[i0:i1 + 1, j0:j1 + 1]
    footprint = np.isfinite(shifted) & np.isfinite(lower_heights)
    if not footprint.any():
        raise InputError("shift", f"v = ({vx:g}, {vy:g}) m leaves no overlap between the two footprints")
    rows = np.flatnonzero(footprint.any(axis=1))
    cols = np.flatnonzero(footprint.any(axis=0))
    crop = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
    heights = (lower_heights - shifted)[crop]
    footprint = footprint[crop]
    meta = dict(composite="lower(x) - upper(x - shift)", shift=(vx, vy),
                origin=((i0 + rows[0]) * s, (j0 + cols[0]) * s),
                lower=lower.metadata, upper=upper.metadata)
    return Topography(heights, s, footprint, meta)


def mated_composite(face: Topography, shift: tuple[float, float]) -> Topography:
    """Composite of a fracture face and its perfectly mated counterpart shifted by v.

    ``Δh(x) = h(x) − h(x − v)`` on the overlap region (paper §3.4, Fig. 7).
    Give ``face`` a :func:`~roughcontact.surfaces.footprint.disc` footprint
    for a cylindrical core: the overlap is then the lens of two discs.
    """
    return composite_topography(face, face, shift)
