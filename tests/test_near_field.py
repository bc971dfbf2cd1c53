"""The near field of a few forces against the Eq. 10 kernel summed densely with numpy.

H c at node i is Σ_j c_j K(|Δi|, |Δj|), with K the table of Eq. 10
(``punch_kernel`` on the whole grid). The near field is the part of the sum
with |Δi| ≤ R and |Δj| ≤ R; the rest, the far field, is at most
K(R + 1, 0) Σ c at every node, because the kernel falls with the distance and
every node outside the window is at least R + 1 spacings away. Sums of a few
terms agree to round-off (1e-12 of the largest); the product in double
precision to 1e-10 of its largest value (FFT round-off).
"""
from __future__ import annotations

import numpy as np
import pytest

from roughcontact.materials import Interface, Material
from roughcontact.operators import near_field as near_field_module
from roughcontact.operators.flexibility import Flexibility
from roughcontact.operators.kernel import punch_kernel
from roughcontact.operators.near_field import NearField, PendingFarField, _union
from roughcontact.surfaces import Topography, disc

ROCK = Interface(Material(20e9, 0.2), Material(20e9, 0.2))
SPACING = 1e-4
SHAPE = (38, 45)                     # rows split over ranks; windows cross the split


@pytest.fixture
def flexibility(comm):
    flex = Flexibility(Topography(np.zeros(SHAPE), SPACING), ROCK, comm, kind="fft")
    yield flex
    flex.destroy()


def dense_field(flexibility, forces: np.ndarray, radius: int | None = None) -> np.ndarray:
    """Σ_j c_j K(|Δi|, |Δj|) over the whole grid by numpy, ``forces`` on the whole grid; with
    ``radius``, only the terms with |Δi| ≤ radius and |Δj| ≤ radius."""
    table = punch_kernel(SHAPE, flexibility.spacing, flexibility.compliance)
    rows, columns = np.indices(SHAPE)
    field = np.zeros(SHAPE)
    for i, j in zip(*np.nonzero(forces)):
        di, dj = np.abs(rows - i), np.abs(columns - j)
        term = forces[i, j] * table[di, dj]
        if radius is not None:
            term[(di > radius) | (dj > radius)] = 0.0
        field += term
    return field


def spread_forces(seed: int, count: int) -> np.ndarray:
    """``count`` positive forces on random nodes of the whole grid, the same on every rank."""
    forces = np.zeros(SHAPE)
    rng = np.random.default_rng(seed)
    forces.reshape(-1)[rng.choice(forces.size, count, replace=False)] = rng.uniform(0.5, 2.0, count)
    # two forces either side of the middle row, where two ranks split the grid
    forces[SHAPE[0] // 2 - 1, 3] = 1.5
    forces[SHAPE[0] // 2, SHAPE[1] - 2] = 0.7
    return forces


def mine(flexibility, whole: np.ndarray) -> np.ndarray:
    r0, r1 = flexibility.layout.rows
    return whole[r0:r1].reshape(-1)


@pytest.mark.parametrize("radius", [3, 32])
def test_near_field_is_the_kernel_sum_within_the_window(flexibility, radius):
    """add() gives the windowed sum of every rank's forces on this rank's rows, to round-off."""
    near = NearField(flexibility, radius)
    forces = spread_forces(seed=1, count=12)
    local = mine(flexibility, forces)
    nodes = np.flatnonzero(local)
    out = np.zeros(local.size)
    near.add(out, nodes, local[nodes])
    expected = mine(flexibility, dense_field(flexibility, forces, radius))
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12 * expected.max())


@pytest.mark.parametrize("radius", [3, 8])
def test_far_field_is_within_the_bound(flexibility, radius):
    """H c less its near field is ≥ 0 and ≤ K(R + 1, 0) Σ c at every node, and the bound is
    K(R + 1, 0) = A/(2πa) arcsin(a / ((R + 1) s)) from the closed form of Eq. 10."""
    near = NearField(flexibility, radius)
    a = SPACING / 2
    assert near.far_bound == pytest.approx(flexibility.compliance / (2 * np.pi * a)
                                           * np.arcsin(a / ((radius + 1) * SPACING)), rel=1e-14)
    forces = spread_forces(seed=2, count=9)
    local = mine(flexibility, forces)
    nodes = np.flatnonzero(local)
    far = flexibility.product(local)
    near.add(far, nodes, local[nodes], -1.0)
    scale = near.far_bound * forces.sum()
    round_off = 1e-10 * flexibility.product(local).max()
    assert far.min() >= -round_off
    assert far.max() <= scale + round_off
    one = np.zeros(SHAPE)                                  # one force: the bound is reached R + 1 away
    one[SHAPE[0] // 2, SHAPE[1] // 2] = 1.0
    field = dense_field(flexibility, one) - dense_field(flexibility, one, radius)
    assert field.max() == pytest.approx(near.far_bound, rel=1e-12)


@pytest.mark.parametrize("union_mask", [near_field_module.UNION_MASK, 10 ** 9])
def test_settling_the_deferred_forces_completes_the_displacement(flexibility, union_mask, monkeypatch):
    """H p with the near fields of two deferred cuts, rescaled once, plus what settle() returns
    with a third cut equals H of all the forces (double-precision products, 1e-10); the product's
    nodes merged by np.unique (these sets are small) and through a mask (UNION_MASK raised)."""
    monkeypatch.setattr(near_field_module, "UNION_MASK", union_mask)
    near = NearField(flexibility, 4)
    pending = PendingFarField(near)
    base = mine(flexibility, spread_forces(seed=3, count=40))
    displacement = flexibility.product(base)
    total = base.copy()
    clipped = np.zeros(base.size)
    for seed in (4, 5):
        cut = mine(flexibility, spread_forces(seed=seed, count=3))
        nodes = np.flatnonzero(cut)
        pending.defer(displacement, nodes, cut[nodes], float(flexibility.comm.allreduce(cut.sum())),
                      int(flexibility.comm.allreduce(nodes.size)))
        total += cut
    displacement *= 0.9                                    # the load restored: forces and fields scaled
    total *= 0.9
    pending.rescale(0.9)
    last = mine(flexibility, spread_forces(seed=6, count=2))
    nodes = np.flatnonzero(last)
    clipped[nodes] = last[nodes]
    displacement += pending.settle(clipped, nodes, lambda values, every: flexibility.product_at(values[every], every))
    total += last
    expected = flexibility.product(total)
    np.testing.assert_allclose(displacement, expected, rtol=0, atol=1e-10 * expected.max())
    assert pending.count == 0 and pending.mass == 0.0 and not pending.entries
    clipped[nodes] = 0.0
    assert not clipped.any()                               # the deferred forces left it again


@pytest.mark.parametrize("count", [0, 5, 300, 5000])
def test_the_merged_nodes_are_the_sorted_union(count):
    """_union is the set union, sorted, once each (against numpy's union1d), on both sides of
    UNION_MASK: sets overlapping each other, repeating indices, unsorted, or empty."""
    rng = np.random.default_rng(count)
    size = 4096
    sets = [rng.integers(0, size, count), np.sort(rng.choice(size, count // 2, replace=False)),
            np.zeros(0, dtype=np.intp), rng.integers(0, size, count // 3)]
    expected = np.zeros(0, dtype=np.intp)
    for indices in sets:
        expected = np.union1d(expected, indices)
    merged = _union(sets, size)
    np.testing.assert_array_equal(merged, expected)
    assert merged.dtype == np.intp


def test_the_bound_counts_every_deferred_force(flexibility):
    near = NearField(flexibility, 4)
    pending = PendingFarField(near)
    local = mine(flexibility, spread_forces(seed=7, count=5))
    nodes = np.flatnonzero(local)
    mass = float(flexibility.comm.allreduce(local.sum()))
    pending.defer(np.zeros(local.size), nodes, local[nodes], mass, int(flexibility.comm.allreduce(nodes.size)))
    assert pending.bound() == pytest.approx(near.far_bound * mass, rel=1e-15)
    assert pending.bound(2.0) == pytest.approx(near.far_bound * (mass + 2.0), rel=1e-15)
    pending.rescale(0.5)
    assert pending.bound() == pytest.approx(near.far_bound * 0.5 * mass, rel=1e-15)


def test_near_field_only_where_the_vectors_are_the_whole_half_space_grid(comm):
    """A periodic operator (its kernel wraps) or a footprint short of the grid has none."""
    whole = Flexibility(Topography(np.zeros((16, 16)), SPACING), ROCK, comm, kind="fft")
    periodic = Flexibility(Topography(np.zeros((16, 16)), SPACING), ROCK, comm, kind="fft-periodic")
    masked = Flexibility(Topography(np.zeros((16, 16)), SPACING, disc((16, 16), SPACING, 7 * SPACING)),
                         ROCK, comm, kind="fft")
    assert isinstance(whole.near_field, NearField)
    assert periodic.near_field is None and masked.near_field is None
    for flex in (whole, periodic, masked):
        flex.destroy()
