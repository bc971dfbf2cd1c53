"""Normal solver against closed-form solutions (Hertz, flat punch, tilted sphere).

The discrete model (rigid punches of radius s/2 at the nodes, Eq. 10) converges
to the continuum at first order in s/a: the contact boundary is resolved to
about one spacing. Tolerances below are set from that: a few per cent at
a/s = 16, about half that at a/s = 32, and the error must decrease.
"""
from __future__ import annotations

import numpy as np
import pytest

from roughcontact.materials import Interface, Material
from roughcontact.normal import ActiveSetSolver, NormalProblem, solve_closures
from roughcontact.references import flat_punch, hertz
from roughcontact.surfaces import Topography, disc

from conftest import sphere_heights

STEEL_LIKE = Interface(Material(200e9, 0.3))     # on a rigid flat
RADIUS = 0.01                                    # sphere radius R (m)


def hertz_errors(comm, a_over_s: int):
    """RMS relative errors of P, a, p0 for a sphere pressed to a ≈ a_over_s · s.

    The area-equivalent radius counts lattice nodes inside a circle, which
    fluctuates with the circle's radius (Gauss's circle problem); errors are
    therefore averaged over four approaches spanning one spacing of a.
    """
    a0 = 50e-6
    s = a0 / a_over_s
    n = int(2.8 * a_over_s) | 1                  # odd: the apex sits on a node
    topo = Topography(sphere_heights(n, s, RADIUS), s)
    problem = NormalProblem(topo, STEEL_LIKE, comm)
    radii = a0 + s * np.array([0.0, 0.25, 0.5, 0.75])
    results = solve_closures(problem, radii**2 / RADIUS)
    problem.destroy()
    e_star = STEEL_LIKE.contact_modulus
    errors = {"load": [], "radius": [], "peak": []}
    for a, res in zip(radii, results):
        assert res.residual < 1e-8
        delta = a**2 / RADIUS
        errors["load"].append(res.load / hertz.load(delta, RADIUS, e_star) - 1.0)
        errors["radius"].append(np.sqrt(res.contact_area / np.pi) / a - 1.0)
        errors["peak"].append(res.pressure.max() / hertz.peak_pressure(delta, RADIUS, e_star) - 1.0)
    return {k: float(np.sqrt(np.mean(np.square(v)))) for k, v in errors.items()}


def test_hertz_sphere_converges_with_refinement(comm):
    err16 = hertz_errors(comm, 16)
    err32 = hertz_errors(comm, 32)
    # the discretisation error is first order in s/a: measured 0.35–0.5 % at a/s = 16 and half that at 32;
    # bounds keep a factor 2 of margin
    for key in ("load", "radius", "peak"):
        assert err16[key] < 0.01, err16
        assert err32[key] < 0.005, err32
        assert err32[key] < err16[key], (key, err16, err32)


def test_flat_punch_stiffness(comm):
    """Rigid flat circular punch: P/δ = 2 a E* within 1 %, a from the footprint area."""
    s = 1e-6
    n = 65
    footprint = disc((n, n), s, diameter=60 * s)
    topo = Topography(np.zeros((n, n)), s, footprint)
    problem = NormalProblem(topo, STEEL_LIKE, comm)
    delta = 1e-8
    with ActiveSetSolver(problem) as solver:
        res = solver.solve_closure(delta)
    problem.destroy()
    a_eff = np.sqrt(topo.nominal_area / np.pi)
    assert res.full_contact and not res.no_contact
    stiffness = res.load / delta
    assert stiffness == pytest.approx(flat_punch.stiffness(a_eff, STEEL_LIKE.contact_modulus), rel=0.01)


def test_off_centre_load_finds_rotation(comm):
    """A load off the apex tilts the sphere: θy = −x0/R, θx = −y0/R, G_P on the load point."""
    a_over_s, s = 12, 4e-6
    n = 61
    topo = Topography(sphere_heights(n, s, RADIUS), s)
    problem = NormalProblem(topo, STEEL_LIKE, comm)
    x0, y0 = 6 * s, -4 * s
    load = hertz.load((a_over_s * s) ** 2 / RADIUS, RADIUS, STEEL_LIKE.contact_modulus)
    with ActiveSetSolver(problem) as solver:
        res = solver.solve_load(load, moments=(load * y0, load * x0))
    problem.destroy()
    xc, yc = res.reference_point
    assert res.load == pytest.approx(load, rel=1e-8)     # load_tol
    # the centroid of pressure is the imposed load point (equilibrium, to solver tolerance)
    assert res.centroid[0] - xc == pytest.approx(x0, abs=1e-6 * s)
    assert res.centroid[1] - yc == pytest.approx(y0, abs=1e-6 * s)
    # a tilted paraboloid is the same paraboloid moved by R θ: the rotation is geometric,
    # up to the grid's resolution of the contact centre (a fraction of s)
    assert res.rotation[1] * RADIUS == pytest.approx(-x0, abs=0.2 * s)
    assert res.rotation[0] * RADIUS == pytest.approx(-y0, abs=0.2 * s)
