"""A topography held by rows: each rank keeps only its own block of grid rows.

A :class:`~.topography.Topography` holds every height on every rank: 9 bytes
per node (the heights and the footprint mask), the largest array a
distributed solve with ``gather=False`` (:mod:`roughcontact.normal.fields`)
still replicates. At 8192² that is 0.6 GB on each rank. A
:class:`TopographyRows` holds rank r's grid rows only — the rows
[start, stop) = :func:`split` (nx, ranks)[r] that the node layout and the
FFT operator give that rank (:mod:`roughcontact.operators.layout`) — and,
for the layout, the number of footprint nodes of every grid row (8 bytes a
row, not a node).

Make one from a whole topography on one rank (:meth:`TopographyRows.scatter`:
the root reads or generates the surface, every rank receives its rows), from
a file of :func:`~.io.write_topography` of which each rank reads its own
rows (:meth:`TopographyRows.read`), or from rows a program made itself
(:meth:`TopographyRows.from_rows`). A
:class:`~roughcontact.normal.NormalProblem` accepts it wherever it accepts a
Topography; its solves with ``gather=False`` then hold nothing of size N
on any rank with the FFT operator (the periodic one makes its Ewald table
whole once at set-up; the dense one, for small grids, gathers the mask). A
tangential solve, which needs the whole surface on every rank, says so in
one line.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from ..checks import require_finite_positive
from ..errors import InputError
from .topography import require_finite_heights


def split(n: int, parts: int) -> list[tuple[int, int]]:
    """``n`` items in ``parts`` contiguous blocks, the first ``n % parts`` one longer."""
    counts = [n // parts + (1 if k < n % parts else 0) for k in range(parts)]
    starts = np.concatenate([[0], np.cumsum(counts)]).astype(int)
    return [(int(starts[k]), int(starts[k + 1])) for k in range(parts)]


@dataclass(frozen=True)
class TopographyRows:
    """This rank's grid rows of a topography on a square grid (see the module).

    Attributes
    ----------
    local_heights
        (stop − start, ny) composite heights Δh of rows [start, stop) in metres.
    spacing
        Grid spacing s (m).
    shape
        (nx, ny) of the whole grid.
    rows
        (start, stop): this rank's grid rows, :func:`split` (nx, ranks)[rank].
    row_counts
        (nx,) footprint nodes of every grid row (the same on every rank).
    local_footprint
        (stop − start, ny) mask of the nominal contact region on these rows.
    metadata
        Free-form provenance, as a Topography's.

    Build it with :meth:`scatter`, :meth:`read` or :meth:`from_rows`
    (collective checks, the same error on every rank), not directly. The
    rows are named ``local_heights`` and ``local_footprint``, not ``heights``
    and ``footprint``: a function of the whole surface (statistics,
    coarsening, writing) handed one by mistake stops at the missing name
    instead of computing on one rank's rows.
    """

    local_heights: np.ndarray
    spacing: float
    shape: tuple[int, int]
    rows: tuple[int, int]
    row_counts: np.ndarray
    local_footprint: np.ndarray
    metadata: dict[str, Any] = field(default_factory=dict)

    #: one rank's rows (a :class:`~.topography.Topography` is whole on every rank)
    by_rows: ClassVar[bool] = True

    @classmethod
    def from_rows(cls, heights, spacing, shape, comm, footprint=None, metadata=None) -> "TopographyRows":
        """This rank's rows (``heights``: rows :func:`split` (nx, ranks)[rank] of a grid of
        ``shape``; ``footprint`` the same rows' mask, default all). Collective: every rank
        checks its rows and all raise the same :class:`~roughcontact.errors.InputError`
        if any rank's are wrong."""
        error, parts, rank = None, None, comm.Get_rank()
        try:
            parts = _checked(heights, spacing, shape, comm, footprint)
        except InputError as exc:
            error = (exc.parameter, f"{str(exc)[len(exc.parameter) + 2:]} (rank {rank})")
        except (TypeError, ValueError) as exc:      # arrays numpy cannot read as numbers: same path
            error = ("heights", f"cannot be read as numbers ({exc}) (rank {rank})")
        _raise_on_every_rank(comm, error)
        heights, spacing, shape, rows, footprint = parts
        heights.setflags(write=False)
        footprint.setflags(write=False)
        row_counts = np.concatenate(comm.allgather(footprint.sum(axis=1, dtype=np.int64)))
        if row_counts.sum() == 0:
            raise InputError("footprint", "is empty: no node belongs to the nominal contact region")
        return cls(heights, spacing, shape, rows, row_counts, footprint, dict(metadata or {}))

    @classmethod
    def scatter(cls, topography, comm, root: int = 0) -> "TopographyRows":
        """Every rank's rows of ``topography``, a :class:`~.topography.Topography` given on rank
        ``root`` (the others pass None): one Scatterv of the heights and one of the mask, so no
        other rank ever holds the whole surface."""
        from .topography import Topography

        rank, size = comm.Get_rank(), comm.Get_size()
        header = None
        if rank == root:
            header = (topography.shape, topography.spacing, dict(topography.metadata)) \
                if isinstance(topography, Topography) else \
                f"must be a Topography on rank {root}, got {type(topography).__name__}"
        header = comm.bcast(header, root=root)
        if isinstance(header, str):                 # every rank raises, none waits in the Scatterv
            raise InputError("topography", header)
        shape, spacing, metadata = header
        blocks = split(shape[0], size)
        start, stop = blocks[rank]
        counts = [(b - a) * shape[1] for a, b in blocks]
        heights = np.empty((stop - start, shape[1]))
        mask = np.empty((stop - start, shape[1]), dtype=np.uint8)
        whole_h = np.ascontiguousarray(topography.heights) if rank == root else None
        whole_m = np.ascontiguousarray(topography.footprint).view(np.uint8) if rank == root else None
        comm.Scatterv([whole_h, counts] if rank == root else None, heights, root=root)
        comm.Scatterv([whole_m, counts] if rank == root else None, mask, root=root)
        return cls.from_rows(heights, spacing, shape, comm, mask.view(bool), metadata)

    @classmethod
    def read(cls, path, comm) -> "TopographyRows":
        """Every rank reads its own rows of a file of :func:`~.io.write_topography` (heights, the
        footprint, the exact spacing and the metadata): no rank reads or holds the whole surface.
        Collective: a file that cannot be read raises the same one-line InputError everywhere.
        Other formats: read on one rank (:func:`~.io.read_topography`) and :meth:`scatter`."""
        import json
        from pathlib import Path

        import h5py

        path = Path(path)
        header, error = None, None
        try:
            with h5py.File(path, "r") as handle:
                heights = handle["heights"]
                if heights.ndim != 2 or "spacing" not in handle.attrs:
                    raise KeyError("a 2-D 'heights' and a 'spacing' attribute")
                shape = tuple(int(v) for v in heights.shape)
                start, stop = split(shape[0], comm.Get_size())[comm.Get_rank()]
                mine = np.asarray(heights[start:stop], dtype=float)
                mask = (np.asarray(handle["footprint"][start:stop]) != 0) if "footprint" in handle \
                    else np.ones(mine.shape, dtype=bool)
                stored = handle.attrs.get("roughcontact_metadata", "{}")
                stored = json.loads(stored.decode() if isinstance(stored, bytes) else stored)
                units = {"length": "m", "height": "m"}
                # read_topography's metadata of the same file, less the file's sha256 (every rank
                # would read all of it): the stored metadata under its own key, not the surface's
                spacing = float(np.ravel(handle.attrs["spacing"])[0])
                # (NaN on the footprint is refused, as read_topography's default missing="reject" does)
                header = (shape, spacing, dict(source=path.name, format="netcdf", reader="roughcontact",
                                               units=units, stored_metadata=stored,
                                               pixel_size=(spacing, spacing), missing_points=0))
        except (OSError, KeyError, ValueError, TypeError, IndexError) as exc:
            error = ("path", f"{path.name}: not a topography file of write_topography ({type(exc).__name__}: {exc})")
        _raise_on_every_rank(comm, error)
        shape, spacing, metadata = header
        return cls.from_rows(mine, spacing, shape, comm, mask, metadata)

    @property
    def footprint_nodes(self) -> int:
        """Nodes of the footprint on the whole grid."""
        return int(self.row_counts.sum())

    @property
    def nominal_area(self) -> float:
        """Apparent area A0 of the footprint, one s² per node (m²)."""
        return self.footprint_nodes * self.spacing**2

    def local_rows(self, rows: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """(heights, footprint) of grid rows ``rows``: this rank's own, the only ones it holds."""
        if tuple(rows) != tuple(self.rows):
            raise InputError("topography", f"holds grid rows {self.rows[0]}:{self.rows[1]}, not "
                                           f"{rows[0]}:{rows[1]}: it was split for another communicator")
        return self.local_heights, self.local_footprint

    def decimated(self, comm) -> "TopographyRows":
        """Every other node in both directions (spacing 2s; nodes (2i, 2j)), held by rows on
        ``comm`` as :func:`split` gives them for the coarse grid: what
        :func:`~.multiresolution.coarsen` (topography, 2, "decimate") gives, without the whole grid."""
        nx, ny = self.shape
        coarse_shape = ((nx + 1) // 2, (ny + 1) // 2)
        start, stop = self.rows
        first = start + (start % 2)                     # the first even grid row held here
        held = ((start + 1) // 2, (stop + 1) // 2)      # the coarse rows made from them
        needed = split(coarse_shape[0], comm.Get_size())[comm.Get_rank()]
        heights = rows_window(np.ascontiguousarray(self.local_heights[first - start::2, ::2]), held, needed, comm)
        mask = rows_window(np.ascontiguousarray(self.local_footprint[first - start::2, ::2]).view(np.uint8),
                           held, needed, comm).view(bool)
        meta = dict(self.metadata)
        meta["coarsening"] = dict(method="decimate", factor=2, origin=(0.0, 0.0),
                                  dropped_nodes=((nx - 1) % 2, (ny - 1) % 2), fine_spacing=self.spacing)
        return TopographyRows.from_rows(heights, 2 * self.spacing, coarse_shape, comm, mask, meta)


def rows_window(held: np.ndarray, rows: tuple[int, int], needed: tuple[int, int], comm) -> np.ndarray:
    """Rows ``needed`` = (start, stop) of a field whose rows are split over ``comm`` in rank order,
    this rank holding ``held`` = rows ``rows``: one Alltoallv, each rank sending each other the
    part of its rows the other needs (any dtype; the result has ``held``'s)."""
    width = held.shape[1]
    everyone_needs = comm.allgather(tuple(needed))
    everyone_holds = comm.allgather(tuple(rows))

    def overlap(a, b) -> tuple[int, int]:
        start, stop = max(a[0], b[0]), min(a[1], b[1])
        return (start, stop) if stop > start else (start, start)

    sends = [overlap(rows, other) for other in everyone_needs]
    receives = [overlap(other, needed) for other in everyone_holds]
    parts = [held[a - rows[0]:b - rows[0]].ravel() for a, b in sends]
    send = np.concatenate(parts) if parts else np.empty(0, held.dtype)
    out = np.empty((needed[1] - needed[0], width), dtype=held.dtype)
    counts = [(b - a) * width for a, b in receives]
    # the holders tile the grid in rank order, so what arrives, in rank order, is the needed rows in order
    comm.Alltoallv([send, [(b - a) * width for a, b in sends]], [out, counts])
    return out


def reached_rows(rows: tuple[int, int], total: int, reach: int) -> tuple[int, int]:
    """The grid rows (start, stop) within ``reach`` of a rank's rows ``rows`` (``total`` in all),
    clipped to the grid; none for a rank without rows."""
    r0, r1 = rows
    return (max(r0 - reach, 0), min(r1 + reach, total)) if r1 > r0 else (r0, r0)


def padded_rows(held: np.ndarray, rows: tuple[int, int], total: int, reach: int, fill, comm) -> np.ndarray:
    """This rank's rows ``rows`` of a field split over ``comm`` by rows (``total`` grid rows in all),
    ``reach`` rows and columns wider on each side: the rows beyond its own from the ranks that hold
    them (:func:`rows_window`), ``fill`` past the grid's edges; ``held``'s dtype (collective)."""
    r0 = rows[0]
    count, width = held.shape
    start, stop = reached_rows(rows, total, reach)
    out = np.full((count + 2 * reach, width + 2 * reach), fill, dtype=held.dtype)
    out[start - r0 + reach:stop - r0 + reach, reach:reach + width] = rows_window(held, rows, (start, stop), comm)
    return out


def gather_into(comm, local: np.ndarray, counts, shape: tuple[int, ...], root: int | None = None):
    """Every rank's ``local`` values (``counts`` of them each, in rank order) received in place into
    one array of ``shape`` on every rank (``root`` None) or on rank ``root`` only (None elsewhere);
    booleans travel as bytes, no pickled copies."""
    local = np.ascontiguousarray(local)
    flag = local.dtype == bool
    send = local.view(np.uint8) if flag else local
    if root is None:
        out = np.empty(shape, dtype=send.dtype)
        comm.Allgatherv(send, [out, counts])
    else:
        out = np.empty(shape, dtype=send.dtype) if comm.Get_rank() == root else None
        comm.Gatherv(send, [out, counts] if out is not None else None, root=root)
        if out is None:
            return None
    return out.view(bool) if flag else out


def _checked(heights, spacing, shape, comm, footprint):
    """The validated parts of one rank's rows (raises InputError on this rank)."""
    try:
        nx, ny = (int(v) for v in shape)
    except (TypeError, ValueError):
        raise InputError("shape", f"must be a pair (nx, ny), got {shape!r}") from None
    if nx < 1 or ny < 1:
        raise InputError("shape", f"must be positive, got {(nx, ny)}")
    spacing = require_finite_positive("spacing", spacing)
    rows = split(nx, comm.Get_size())[comm.Get_rank()]
    heights = np.array(heights, dtype=float)
    expected = (rows[1] - rows[0], ny)
    if heights.shape != expected:
        raise InputError("heights", f"holds shape {heights.shape}; this rank's rows {rows[0]}:{rows[1]} of a "
                                    f"{nx} x {ny} grid are {expected}")
    footprint = np.ones(expected, dtype=bool) if footprint is None else np.array(footprint, dtype=bool)
    if footprint.shape != expected:
        raise InputError("footprint", f"shape {footprint.shape} differs from heights {expected}")
    require_finite_heights(heights, footprint)
    return heights, spacing, (nx, ny), rows, footprint


def _raise_on_every_rank(comm, error: tuple[str, str] | None) -> None:
    """The InputError(parameter, message) of the lowest rank that met one, raised on every rank
    (collective: no rank is left waiting in the next call)."""
    errors = [e for e in comm.allgather(error) if e is not None]
    if errors:
        raise InputError(*errors[0])
