"""The holes of a contact set (components of its outside that touch no edge of the grid) and the
edge charge the preconditioner takes back on them (roughcontact/operators/holes.py)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from roughcontact.errors import InputError
from roughcontact.materials import Interface, Material
from roughcontact.normal import CGSettings
from roughcontact.operators import holes as holes_module
from roughcontact.operators.flexibility import Flexibility
from roughcontact.operators.holes import DUST, HOLE_BLOCK, HOLE_SPAN, HoleCharge, block_side, enclosed
from roughcontact.surfaces import Topography
from roughcontact.surfaces.rows import split

ROCK = Interface(Material(20e9, 0.2), Material(20e9, 0.2))
SPACING = 1e-4

#: '#' in the set, '.' outside: a hole of 2 × 2 (rows 1-2), a notch open to the left edge (row 4),
#: a hole three rows tall (rows 6-8), a channel open to the bottom edge (rows 9-11, column 6), a
#: hole of two nodes that touches it only diagonally (rows 7-8, column 7: 4-neighbours keep it a
#: hole) and a hole of one node (row 10). The random sets below cross the slab boundaries
PICTURE = """
##########
##..######
##..######
##########
...#######
##########
####.#####
####.##.##
####.##.##
######.###
####.#.###
######.###
"""
EXPECTED_HOLES = {(1, 2), (1, 3), (2, 2), (2, 3), (6, 4), (7, 4), (8, 4), (7, 7), (8, 7), (10, 4)}


def test_holes_are_the_outside_components_that_touch_no_edge_on_any_rank_count(comm):
    """The labelling by slabs, merged over the ranks, gives the holes of the picture (by hand)."""
    rows = [line for line in PICTURE.strip().splitlines()]
    outside = np.array([[c == "." for c in line] for line in rows])
    r0, r1 = split(outside.shape[0], comm.Get_size())[comm.Get_rank()]
    holes = enclosed(outside[r0:r1], comm, r0, outside.shape[0])
    expected = np.zeros_like(outside)
    for node in EXPECTED_HOLES:
        expected[node] = True
    np.testing.assert_array_equal(holes, expected[r0:r1])


def whole_grid_holes(outside: np.ndarray) -> np.ndarray:
    """The holes of an outside given on the whole grid, by scipy's labelling of the whole grid:
    its components (4-neighbours) that touch no edge."""
    labels, _ = ndimage.label(outside)
    open_labels = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    return outside & ~np.isin(labels, open_labels)


@pytest.mark.parametrize("seed", [1, 2])
def test_holes_of_a_random_set_match_a_whole_grid_labelling(comm, seed):
    """On a random near-full set of 37 × 29 (many components, some across every slab boundary)
    the merged labelling equals scipy's on the whole grid, edge-touching components removed."""
    outside = np.random.default_rng(seed).random((37, 29)) < 0.45
    expected = whole_grid_holes(outside)
    r0, r1 = split(outside.shape[0], comm.Get_size())[comm.Get_rank()]
    np.testing.assert_array_equal(enclosed(outside[r0:r1], comm, r0, outside.shape[0]), expected[r0:r1])
    assert comm.allreduce(int(expected[r0:r1].sum())) > 0


def dense_of(apply, size: int) -> np.ndarray:
    """The matrix of a linear map on R^size, column by column."""
    return np.column_stack([apply(unit) for unit in np.eye(size)])


def whole_grid_rims(inside: np.ndarray) -> np.ndarray:
    """The rims of the holes of a set given on the whole grid, by scipy on the whole grid: within
    one node (a square) of a hole and not of the open outside or of the frame."""
    outside = ~inside
    holes = whole_grid_holes(outside)
    framed = np.pad(outside & ~holes, 1, constant_values=True)
    near_open = ndimage.binary_dilation(framed, np.ones((3, 3), bool))[1:-1, 1:-1]
    return ndimage.binary_dilation(holes, np.ones((3, 3), bool)) & ~near_open


def whole_grid_weights(inside: np.ndarray, block: int) -> tuple[np.ndarray, bool]:
    """(the share of r each node of the grid takes back, whether the outside is a dust of holes),
    by scipy on the whole grid and loops over the blocks: where the holes hold at least DUST of
    the whole outside, γ_b (the block's outside in holes) on every node of a block with γ_b ≥ DUST,
    1 on the rims of the others; else 1 on the rims alone."""
    outside = ~inside
    holes = whole_grid_holes(outside)
    weights = whole_grid_rims(inside).astype(float)
    dust = outside.sum() > 0 and holes.sum() >= DUST * outside.sum()
    if dust:
        for i in range(0, inside.shape[0], block):
            for j in range(0, inside.shape[1], block):
                square = (slice(i, i + block), slice(j, j + block))
                if outside[square].sum() and holes[square].sum() >= DUST * outside[square].sum():
                    weights[square] = holes[square].sum() / outside[square].sum()
    return weights, bool(dust)


@pytest.mark.parametrize("density", [0.6, 0.9])
def test_the_rims_of_holes_match_a_whole_grid_reference_on_any_rank_count(comm, density):
    """The rims the charge is taken on (RIM = 1), found by slabs with their neighbours' edge rows,
    equal scipy's dilations on the whole grid (the frame counted as open outside)."""
    n, m = 31, 26
    inside = np.random.default_rng(7).random((n, m)) < density
    flex = Flexibility(Topography(np.zeros((n, m)), SPACING), ROCK, comm, kind="fft")
    try:
        r0, r1 = flex.layout.rows
        members = inside.reshape(-1)[r0 * m + flex.layout.positions]
        holes = HoleCharge(flex.layout, comm, share=0.8)
        holes.relabel(members)
        expected = whole_grid_rims(inside)
        np.testing.assert_array_equal(holes.rim.reshape(r1 - r0, m), expected[r0:r1])
        assert expected.any()
    finally:
        flex.destroy()


def constant_gap_loss(inside: np.ndarray, comm):
    """The hole charge (share 0.8, blocks of 8) of the set ``inside`` (a mask of the whole grid)
    on this rank's nodes, with random edge weights e in [1, 2): (z = 0 less the charge for g = 1
    on S, e, the set's nodes as flat indices of the grid, the charge)."""
    n, m = inside.shape
    flex = Flexibility(Topography(np.zeros((n, m)), SPACING), ROCK, comm, kind="fft")
    try:
        r0, _ = flex.layout.rows
        on_slab = r0 * m + flex.layout.positions
        members = inside.reshape(-1)[on_slab]
        nodes = np.flatnonzero(members)
        edge = 1.0 + np.random.default_rng(r0).random(nodes.size)
        holes = HoleCharge(flex.layout, comm, share=0.8, block=8)
        holes.relabel(members)
        holes.update(nodes, edge)
        z = np.zeros(nodes.size)
        holes.subtract(np.ones(nodes.size), z)
        return z, edge, on_slab[nodes], holes
    finally:
        flex.destroy()


@pytest.mark.parametrize("hole", [False, True])
def test_a_constant_gap_loses_the_charge_on_the_rims_on_any_rank_count(comm, hole):
    """For g = 1 on S each block's term takes back r_b (r_bᵀ 1) / (1ᵀ r_b) = r_b: z loses exactly
    r = e (1 − share) / share on the rims (scipy's, on the whole grid) and nothing elsewhere
    (round-off of one division and one product, 1e-14). The set's outside is a strip open to the
    left edge, with or without a hole of 2 × 2 in the first rows: ranks without rims, or no rims
    at all, take part in the charge's sums with nothing of their own."""
    inside = np.ones((24, 20), dtype=bool)
    inside[:, :3] = False
    if hole:
        inside[2:4, 10:12] = False
    z, edge, on_grid, holes = constant_gap_loss(inside, comm)
    rims = whole_grid_rims(inside).reshape(-1)[on_grid]
    np.testing.assert_allclose(z, -np.where(rims, edge * 0.25, 0.0), rtol=1e-14, atol=0.0)
    assert holes.active == hole
    assert comm.allreduce(int(rims.sum())) == (12 if hole else 0)    # the 4 × 4 square less the hole


@pytest.mark.parametrize("chunk", [1, 3, 1024])
def test_a_dust_of_holes_loses_the_charge_on_its_blocks_on_any_rank_count(comm, chunk, monkeypatch):
    """Near full contact (holes 30 of the 54 nodes outside, ≥ DUST) a constant gap loses
    r^h = γ_b r on every node of the blocks whose outside is mostly holes (γ_b = 1 here) and r on
    the rims of the others (the blocks along the open strip, γ_b = 1/3), by
    :func:`whole_grid_weights` (round-off of one division and one product, 1e-14); on any rank
    count, with blocks that straddle the slabs' boundaries, and with the charge spread over the
    nodes a run, three runs or all runs at a time (RUNS_CHUNK: the last chunk short)."""
    monkeypatch.setattr(holes_module, "RUNS_CHUNK", chunk)
    inside = np.ones((24, 20), dtype=bool)
    inside[:, 0] = False                                 # open: it touches the frame
    inside[2::4, 2::4] = False                           # 30 single-node holes
    z, edge, on_grid, holes = constant_gap_loss(inside, comm)
    weights, dust = whole_grid_weights(inside, 8)
    assert dust and holes.dust is not None
    assert set(np.unique(weights)) == {0.0, 1.0} and (weights[:, 8:] == 1.0).all()
    np.testing.assert_allclose(z, -edge * 0.25 * weights.reshape(-1)[on_grid], rtol=1e-14, atol=0.0)


@pytest.mark.parametrize("density", [0.6, 0.9])
def test_the_hole_charge_keeps_the_preconditioner_positive_definite(density):
    """M' = M − Σ_b r^h_b r^h_bᵀ / (1ᵀ r^h_b) on a random set of 24² with blocks of 8: symmetric;
    bounded below by M − diag(r) (Cauchy–Schwarz, the module's argument, with r^h ≤ r) and
    positive definite; and the block-constant field loses exactly 1ᵀ r^h_b, r^h the charge
    r = e (1 − share) / share in the shares of :func:`whole_grid_weights` (both sets are a dust of
    holes: 40 % and 10 % of the nodes outside, most of it enclosed). Tolerances: round-off of dense sums of ~600 terms (1e-12 relative to C⁻¹'s
    diagonal)."""
    from mpi4py import MPI

    n = 24
    flex = Flexibility(Topography(np.zeros((n, n)), SPACING), ROCK, MPI.COMM_SELF, kind="fft")
    try:
        pc = flex.preconditioner
        members = np.random.default_rng(3).random(n * n) < density
        nodes = np.flatnonzero(members)
        edge = pc.edge_weights(nodes)
        holes = HoleCharge(flex.layout, MPI.COMM_SELF, share=0.8, block=8)
        holes.relabel(members)
        holes.update(nodes, edge)
        weights, dust = whole_grid_weights(members.reshape(n, n), 8)
        weights = weights.reshape(-1)[nodes]
        assert holes.active and dust == (holes.dust is not None)

        def corrected(g):
            z = flex.precondition_nodes(g, nodes, edge=edge)
            holes.subtract(g, z)
            return z

        plain = dense_of(lambda g: flex.precondition_nodes(g, nodes, edge=edge), nodes.size)
        taken = dense_of(corrected, nodes.size)
        scale = pc.inverse_diagonal
        assert np.abs(taken - taken.T).max() <= 1e-12 * scale
        charge = edge * 0.25                                        # r = e (1 − 0.8) / 0.8
        floor = np.linalg.eigvalsh(0.5 * (plain + plain.T) - np.diag(charge))[0]
        lowest = np.linalg.eigvalsh(0.5 * (taken + taken.T))[0]
        assert lowest >= floor - 1e-12 * scale
        assert lowest > 0.0
        rows, columns = np.divmod(nodes, n)
        blocks = (rows // 8) * 3 + columns // 8
        for b in range(9):
            field = (blocks == b).astype(float)
            lost = field @ (plain - taken) @ field
            assert abs(lost - (charge * weights)[blocks == b].sum()) <= 1e-12 * scale * field.sum()
    finally:
        flex.destroy()


def test_hole_block_is_checked():
    with pytest.raises(InputError, match="hole_block"):
        CGSettings(hole_block=-1)
    with pytest.raises(InputError, match="hole_block"):
        CGSettings(hole_block=2.5)
    with pytest.raises(InputError, match="hole_block"):
        CGSettings(hole_block=True)
    assert CGSettings().hole_block is None and CGSettings(hole_block=0).hole_block == 0


def test_the_blocks_follow_the_grid_above_2048():
    # the sides measured and documented (block_side): 64 up to 2048², 128 at 4096², the longer side
    assert (HOLE_BLOCK, HOLE_SPAN) == (64, 32)
    assert block_side((1024, 1024)) == block_side((2048, 2048)) == block_side((17, 4)) == 64
    assert block_side((4096, 4096)) == block_side((129, 4096)) == 128
    assert block_side((8192, 3000)) == 256
