"""The Newton on the rigid motion (normal/rigid_motion.py) with inexact evaluations, on a model
whose answer is known in closed form: a bed of linear springs (Winkler), every node loaded.

With p = k w(r), w = C r − gap0 and C = [1, −y, −x], the loads Cᵀp = L are linear in r:
r = (CᵀC)⁻¹ (L/k + Cᵀ gap0). The evaluations find δz from Σp = P (the CG's inner
component) and may be "inexact": an evaluation resolved for a load residual above
``LOOSE`` returns forces whose moments point against the true ones (−0.1 of them), with
the gap and the complementarity slack such forces have. That is the case the Newton's
retry exists for: a step from such a state climbs Φ, so no step length is accepted, and
only resolving the state again rescues the iteration.
"""
from __future__ import annotations

import numpy as np
import pytest

from roughcontact.errors import ConvergenceError
from roughcontact.normal.result import ContactState
from roughcontact.normal.rigid_motion import (
    CONFIRM_SHARE,
    FINEST_SHARE,
    InexactResolution,
    _newton_step,
    newton_on_motion,
)

K = 2.0            # spring stiffness: H = I / K
P = 10.0           # imposed load
LOOSE = 0.05       # evaluations resolved for a residual above it are off
LOAD_TOL = 1e-10


class Springs:
    """What newton_on_motion reads of a problem, for a 9 × 9 bed of springs on one rank."""

    def __init__(self):
        i, j = np.meshgrid(np.arange(9.0) - 4.0, np.arange(9.0) - 4.0, indexing="ij")
        self.x, self.y = i.ravel(), j.ravel()
        self.columns = np.column_stack([np.ones(self.x.size), -self.y, -self.x])
        self.gap0 = 0.005 * self.x - 0.004 * self.y + 0.001 * np.cos(3.0 * self.x + self.y)
        self.extent = 4.0
        self.height_range = float(np.ptp(self.gap0))

    def interpenetration(self, rigid):
        return self.columns @ rigid - self.gap0

    def moments(self, values):
        return np.array([values.sum(), values @ self.y, values @ self.x])

    @staticmethod
    def allsum(values):
        return np.asarray(values, dtype=float)

    def exact(self, loads):
        """The rigid motion whose spring forces carry ``loads`` (the closed form above)."""
        c = self.columns
        return np.linalg.solve(c.T @ c, loads / K + c.T @ self.gap0)


def spring_state(bed: Springs, rigid: np.ndarray, off: np.ndarray | float = 0.0, slack: float = 0.0):
    """(state, rigid) at the rotation of ``rigid``, δz found from Σp = P: the springs' forces with
    their moments moved by ``off`` (Σp unchanged: the rotations' columns sum to zero on the
    centred bed), the gap and complementarity slack such forces have, plus ``slack``."""
    outer = bed.columns[:, 1:]
    rigid = rigid.copy()
    rigid[0] = 0.0
    rigid[0] = (P / K - bed.interpenetration(rigid).sum()) / bed.x.size
    w = bed.interpenetration(rigid)
    forces = K * w + outer @ np.linalg.solve(outer.T @ outer, off * np.ones(2))
    state = ContactState(forces, np.ones(forces.size, bool), np.zeros(forces.size), 1, 1, 0.0, (),
                         float(forces @ (forces / K - w)) + slack)
    return state, rigid


def evaluations(bed: Springs, loads: np.ndarray, log: list, loose: float):
    """evaluate(r, needed) for the Newton: δz from Σp = P at the imposed rotation, forces off
    when resolved for a residual above ``loose``; ``log`` gets (needed, rotation) of each call."""
    outer = bed.columns[:, 1:]

    def evaluate(rigid, needed):
        log.append((needed, rigid[1:].copy()))
        state, rigid = spring_state(bed, rigid)
        if needed > loose:                               # the moments pointing against the true ones
            state, rigid = spring_state(bed, rigid, -1.1 * (outer.T @ state.pressure - loads[1:]))
        assert state.pressure.min() > 0.0 and abs(state.pressure.sum() - P) < 1e-12
        return state, rigid

    return evaluate


def newton(bed: Springs, loads: np.ndarray, log: list, resolution, loose: float = LOOSE):
    # the Hessian over the rotations of Φ minimised over δz, exact on every node: k C_θᵀ (I − 1 1ᵀ/n) C_θ
    # (the Schur complement over δz of k CᵀC), the rotations' columns centred
    centred = bed.columns[:, 1:] - bed.columns[:, 1:].mean(axis=0)
    stiffness = lambda active: (K * centred.T @ centred, 0)               # noqa: E731
    return newton_on_motion(bed, np.zeros(3), [0, 1, 2], [1, 2], loads, evaluations(bed, loads, log, loose),
                            stiffness, load_tol=LOAD_TOL, max_newton=20, resolution=resolution)


def test_a_state_resolved_too_loosely_is_resolved_again_when_no_step_is_accepted():
    """The first evaluation (resolved for nothing yet) is off; the line search halves to 1e-6 and
    finds neither a decrease of Φ nor a halved residual; the state is then resolved for its own
    residual, and the Newton reaches the closed form. The state returned was confirmed at
    load_tol."""
    bed, log = Springs(), []
    loads = np.array([P, 0.0, 0.0])
    state, rigid = newton(bed, loads, log, resolution=lambda needed: needed)
    first = log[0][1]
    retried = [k for k, (needed, rotation) in enumerate(log[1:], 1)
               if np.array_equal(rotation, first) and needed < np.inf]
    assert retried, "no evaluation resolved the first state again"
    assert log[-1][0] == LOAD_TOL                  # the returned state: confirmed for load_tol
    np.testing.assert_allclose(rigid, bed.exact(loads), rtol=1e-9)
    np.testing.assert_allclose(bed.columns.T @ state.pressure, loads, rtol=0, atol=LOAD_TOL * P * bed.extent)


def test_exact_evaluations_are_not_repeated():
    """Without a resolution (exact evaluations, the active set) nothing is evaluated twice:
    the same model made exact converges with no evaluation at a rotation already seen."""
    bed, log = Springs(), []
    loads = np.array([P, 0.0, 0.0])
    _, rigid = newton(bed, loads, log, resolution=None, loose=np.inf)
    rotations = [tuple(rotation) for _, rotation in log]
    assert len(set(rotations)) == len(rotations)
    np.testing.assert_allclose(rigid, bed.exact(loads), rtol=1e-9)


def test_without_resolving_again_the_search_gives_up():
    """The same inexact model, but the Newton told its evaluations are exact: it cannot know
    the state is off and raises the line search's error, which is what the retry prevents."""
    bed, log = Springs(), []
    with pytest.raises(ConvergenceError, match="no decrease"):
        newton(bed, np.array([P, 0.0, 0.0]), log, resolution=None)


def jittered(bed: Springs, loads: np.ndarray, rule: InexactResolution, log: list):
    """evaluate(r, needed) for the Newton whose states' moments are off by JITTER × the inner
    tolerance ``rule(needed)`` (× P × extent), along the true moments: an inner solve stopped at
    tolerance t leaves the moments off by about t (by up to 2.8 t in the CG's measured states,
    CONFIRM_SHARE), and here no rotation brings them nearer than that. Σp stays P; ``log`` gets
    each evaluation's inner tolerance."""
    outer = bed.columns[:, 1:]

    def evaluate(rigid, needed):
        tol = rule(needed)
        log.append(tol)
        state, rigid = spring_state(bed, rigid)
        true = outer.T @ state.pressure - loads[1:]
        return spring_state(bed, rigid, JITTER * tol * P * bed.extent * true / max(np.abs(true).max(), 1e-300))

    return evaluate


#: how far off the states' moments are, in units of the inner tolerance: at the first floor
#: (CONFIRM_SHARE × load_tol) by 5 load_tol, at the finest (FINEST_SHARE) by 0.05 load_tol
JITTER = 50.0


def test_states_scattered_above_load_tol_at_the_floor_are_resolved_below_it():
    """Where the states resolved at the floor have moments off by more than load_tol, the steps
    from them stop halving the load residual; the floor is lowered and the state resolved again,
    and the Newton meets load_tol on the closed form's rotation. The rule's floor: share ×
    load_tol, 0.1 first, then 1e-3, then no lower."""
    assert CONFIRM_SHARE == 0.1 and FINEST_SHARE == 1e-3
    bed, log = Springs(), []
    loads = np.array([P, 0.0, 0.0])
    rule = InexactResolution(tol=1e-6, load_tol=LOAD_TOL, first=1e-6)
    assert rule(np.inf) == 1e-6 and rule(1.0) == 1e-6 and rule(1e-13) == pytest.approx(0.1 * LOAD_TOL)
    centred = bed.columns[:, 1:] - bed.columns[:, 1:].mean(axis=0)
    stiffness = lambda active: (K * centred.T @ centred, 0)               # noqa: E731
    state, rigid = newton_on_motion(bed, np.zeros(3), [0, 1, 2], [1, 2], loads, jittered(bed, loads, rule, log),
                                    stiffness, load_tol=LOAD_TOL, max_newton=20, resolution=rule,
                                    tighten=rule.tighten)
    assert rule.share == pytest.approx(FINEST_SHARE) and not rule.tighten()
    assert min(log) == pytest.approx(FINEST_SHARE * LOAD_TOL)
    moments = bed.columns.T @ state.pressure - loads
    assert np.abs(moments).max() <= LOAD_TOL * P * bed.extent
    # the rotation: the closed form's, to what moments within load_tol leave of it (K ≈ 1.1e3 here
    # against P × extent = 40: about 4e-12 rad, 1e-9 of the rotation)
    np.testing.assert_allclose(rigid[1:], bed.exact(loads)[1:], rtol=1e-8)


def test_a_state_at_the_floor_the_search_cannot_improve_is_resolved_below_it():
    """The other way the floor shows: a state resolved at the floor from which no step length
    is accepted. Here every state resolved at the first floor has moments off by 5 load_tol, and
    all but the first a complementarity slack that puts its Φ far above the first's, so the line
    search halves to 1e-6 without a decrease; the floor is lowered, the first state resolved
    again (a retry at the same rotation), and the Newton meets load_tol on the closed form's
    rotation."""
    bed, log = Springs(), []
    loads = np.array([P, 0.0, 0.0])
    rule = InexactResolution(tol=1e-6, load_tol=LOAD_TOL, first=1e-6)
    floor = CONFIRM_SHARE * LOAD_TOL
    outer = bed.columns[:, 1:]
    first = []                                     # the rotation of the first state at the floor

    def evaluate(rigid, needed):
        tol = rule(needed)
        log.append((tol, rigid[1:].copy()))
        if tol != pytest.approx(floor):
            return spring_state(bed, rigid)
        if not first:
            first.append(rigid[1:].copy())
        # Φ = … − ½ slack: every state at the floor but the first far above the first's
        slack = 0.0 if np.array_equal(rigid[1:], first[0]) else -1e3 * P * bed.extent
        return spring_state(bed, rigid, JITTER * tol * P * bed.extent, slack)

    centred = outer - outer.mean(axis=0)
    stiffness = lambda active: (K * centred.T @ centred, 0)               # noqa: E731
    state, rigid = newton_on_motion(bed, np.zeros(3), [0, 1, 2], [1, 2], loads, evaluate, stiffness,
                                    load_tol=LOAD_TOL, max_newton=20, resolution=rule, tighten=rule.tighten)
    assert rule.share == pytest.approx(FINEST_SHARE)
    retried = [k for k, (tol, rotation) in enumerate(log)
               if tol == pytest.approx(FINEST_SHARE * LOAD_TOL) and np.array_equal(rotation, first[0])]
    assert retried, "the first state at the floor was not resolved again below it"
    np.testing.assert_allclose(bed.columns.T @ state.pressure - loads, 0.0, atol=LOAD_TOL * P * bed.extent)
    np.testing.assert_allclose(rigid[1:], bed.exact(loads)[1:], rtol=1e-8)


def test_without_lowering_the_floor_scattered_states_stop_the_newton():
    """The same scattered states with the floor held at CONFIRM_SHARE: every state's moments are
    off by 5 load_tol, the Newton cannot meet load_tol and raises after max_newton steps, which is
    what lowering the floor prevents."""
    bed, log = Springs(), []
    loads = np.array([P, 0.0, 0.0])
    rule = InexactResolution(tol=1e-6, load_tol=LOAD_TOL, first=1e-6)
    centred = bed.columns[:, 1:] - bed.columns[:, 1:].mean(axis=0)
    stiffness = lambda active: (K * centred.T @ centred, 0)               # noqa: E731
    with pytest.raises(ConvergenceError, match="without meeting load_tol"):
        newton_on_motion(bed, np.zeros(3), [0, 1, 2], [1, 2], loads, jittered(bed, loads, rule, log),
                         stiffness, load_tol=LOAD_TOL, max_newton=20, resolution=rule)


@pytest.mark.parametrize("along", [1e-3, 0.0, 0.75, 1.5, -1.5, 3.0])
def test_a_direction_the_set_does_not_stiffen_is_followed_only_beyond_negligible(along):
    """Hessian diag(0, 2) in u = dr / units: the Newton step −g/2 along the second direction;
    along the first, where Φ is linear, the descent direction at the whole radius only where the
    residual there, F₁ in the loads' own units, is above ``negligible``: at 1e-3 of it (round-off
    along a rotation two supports do not fix), zero or 0.75 of it, none; at 1.5 of it, followed.
    The residual measured in u instead (F₁ × units: 1.5 of it at 0.75) or divided twice (F₁ /
    units: 0.75 of it at 1.5) decides otherwise, and so does the second load's bound, 1e-4 of
    the first's, taken for the first's."""
    units = np.array([2.0, 0.5])
    negligible = np.array([1e-8, 1e-12])
    force = np.array([along * negligible[0], 0.3])
    step = _newton_step(np.diag([0.0, 2.0]) / np.outer(units, units), force, units, 0.5, negligible)
    assert step[1] / units[1] == pytest.approx(-force[1] * units[1] / 2.0, rel=1e-12)
    expected = -0.5 * np.sign(along) if abs(along) > 1.0 else 0.0
    assert step[0] / units[0] == expected
