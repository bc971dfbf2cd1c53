"""The box partition shared by box counting, renormalisation and the multifractal spectrum.

Nodes are the paper's atoms of surface (§3.1): node (i, j) is the square
cell [i s, (i + 1) s) × [j s, (j + 1) s). A box of k nodes a side
(ε = k s) covers k × k cells. With box sizes in powers of a base b
(k = 1, b, b², …) the boxes of every size tile a square *analysis window*
exactly when its side is a power of b. Two windows (``window``):

- ``"origin"`` (default): the largest square of b^m nodes at the grid's
  origin; nodes beyond it (e.g. the last row and column of a 2^n + 1
  midpoint grid) are left out and counted in ``window_nodes``. Boxes that
  stick out of the domain, which bias counts at large sizes, never occur.
- ``"cover"``: the smallest square of b^m nodes holding the whole grid, the
  grid at its origin and zeros (no contact, no force) beyond it. For a
  footprint that is not the square grid (the lens of a shifted core, §3.4)
  every contact node counts; boxes outside the footprint hold nothing and
  add nothing to N(ε) or to the moments of f(α).

The default fitted range is k = 1 … side / b²: the two largest sizes (one
box, and b² boxes) are left out because their counts saturate at the number
of boxes whatever the set.
"""
from __future__ import annotations

import numpy as np

from ..checks import check_choice, check_integer
from ..errors import InputError


def window_side(shape: tuple[int, ...], base: int = 2) -> int:
    """Side b^m of the analysis window: the largest power of ``base`` not above the shortest side."""
    base = check_integer("base", base, 2)
    shortest = min(shape)
    if shortest < base:
        raise InputError("shape", f"a grid of {shape} nodes holds no box larger than one node for base {base}")
    side = 1
    while side * base <= shortest:
        side *= base
    return side


#: the analysis windows (see the module's notes)
WINDOWS = ("origin", "cover")


def crop(values: np.ndarray, base: int = 2, window: str = "origin") -> np.ndarray:
    """The analysis window of ``values`` (any number of dimensions): ``"origin"`` or ``"cover"``."""
    values = np.asarray(values)
    check_choice("window", window, WINDOWS)
    if window == "origin":
        side = window_side(values.shape, base)
        return values[(slice(0, side),) * values.ndim]
    base = check_integer("base", base, 2)
    side = base
    while side < max(values.shape):
        side *= base
    return np.pad(values, [(0, side - n) for n in values.shape])


def box_nodes(side: int, base: int = 2) -> np.ndarray:
    """Box sides k = 1, b, b², …, side (nodes)."""
    sizes = [1]
    while sizes[-1] < side:
        sizes.append(sizes[-1] * base)
    return np.array(sizes)


def box_sums(window: np.ndarray, k: int) -> np.ndarray:
    """Sum of ``window`` over each box of k nodes a side (the window's side must be a multiple of k)."""
    side = window.shape[0]
    shape = []
    for _ in range(window.ndim):
        shape += [side // k, k]
    return window.reshape(shape).sum(axis=tuple(range(1, 2 * window.ndim, 2)))


def fitted_boxes(nodes: np.ndarray, box_range: tuple[int, int] | None, base: int) -> np.ndarray:
    """Mask of the box sizes in ``box_range`` = (smallest, largest) in nodes, at least 3 of them.

    Default: 1 … side / base² (see the module's notes).
    """
    side = int(nodes[-1])
    if box_range is None:
        lo, hi = 1, max(side // base**2, 1)
    else:
        try:
            lo, hi = (check_integer("box_range", k, 1) for k in box_range)
        except (TypeError, ValueError):
            raise InputError("box_range", f"must be a pair (smallest, largest) of box sides in nodes, "
                                          f"got {box_range!r}") from None
        if hi > side:
            raise InputError("box_range", f"a box of {hi} nodes is larger than the analysis window "
                                          f"({side} x {side} nodes)")
        if lo > hi:
            raise InputError("box_range", f"smallest box {lo} exceeds largest {hi}")
    mask = (nodes >= lo) & (nodes <= hi)
    if mask.sum() < 3:
        raise InputError("box_range", f"boxes of {lo} to {hi} nodes give {int(mask.sum())} size(s) in powers "
                                      f"of {base} on a {side}-node window; a slope with an interval needs 3 "
                                      "(use a larger grid or a wider range)")
    return mask


def box_coords(nodes: np.ndarray, spacing: float, fitted: np.ndarray, name: str) -> dict:
    """The ``box_size`` coordinate (m), its size in nodes, and the flag of the fitted sizes."""
    return {
        "coords": {"box_size": ("box_size", nodes * spacing, {"units": "m", "long_name": "box side ε = k s"}),
                   "box_nodes": ("box_size", nodes, {"units": "1", "long_name": "box side k in nodes"})},
        "fitted": {f"{name}_fitted": ("box_size", fitted.astype(np.int8),
                                      {"units": "1", "long_name": f"1 for the box sizes in the fit of {name}"})},
    }
