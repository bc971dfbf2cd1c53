"""Bound-constrained conjugate gradients: the contact set is updated inside the Krylov iteration.

The discrete normal contact problem (Eqs. 7–11) is the quadratic program

    min ½ pᵀ H p − pᵀ w_fixed    subject to   p ≥ 0  (and Σ p = P under load control),

where w_fixed = C_fixed r_fixed − gap0 collects the imposed components of
the rigid motion r = (δz, θx, θy) (Eq. 7). Under load control the approach
δz is the Lagrange multiplier of Σ p = P, and the optimality conditions are
exactly the contact conditions: the deformed gap g = H p − w_fixed − δz is
zero where p > 0 and non-negative where p = 0 (Eqs. 7a/7b).

The iteration is Polonsky & Keer's constrained conjugate gradient with a
preconditioner:

1. on the current contact set S = {p > 0}, δz is the mean of H p − w_fixed
   over S and the gap g the remainder;
2. the free set F is S and the nodes outside it that interpenetrate
   (g < 0), less those that left S earlier in the solve and whose square of
   the grid's checkerboard waits this iteration (``alternate_return``); the
   search direction is the preconditioned gap on F,
   z = M g (M: the Fourier preconditioner of the set with its edge
   correction, :mod:`~roughcontact.operators.preconditioner`, the
   correction's weights made again whenever F changed; once the set has
   settled, on a set of many small islands, the preconditioner applied to
   the set's smooth extension instead, :mod:`~roughcontact.operators.extension`;
   on large grids, once the set has settled, in the balancing form around
   the blocks of the set, :mod:`~roughcontact.operators.balancing`), with its mean over F
   removed so that Σ p stays P, made conjugate to the previous one unless the
   gap is far from orthogonal to the previous z (Powell's test, ``restart``);
3. the step α = gᵀz / dᵀHd (one FFT product per iteration), then
   p ← max(p − α d, 0) on F: interpenetrating nodes are loaded by the same
   preconditioned step as the others (giving each the force that would close
   its own gap alone overloads fronts of entering nodes and makes
   warm-started solves oscillate); H p is updated as H p − α H d + H c,
   with c the forces the cut at zero restored: a second product, on the
   iterations that cut, or only c's near field summed directly while the
   far fields left out stay below a share of the gap's size
   (:mod:`~roughcontact.operators.near_field`, ``CGSettings.defer``). After
   a cut too large to wait, the next H d is held between its transforms
   with dᵀHd read off its spectrum (Parseval); where that step cuts too,
   H (c − α d) is one product and H d's inverse transforms are skipped, as
   on a step that ends in an exact H p (a refresh);
4. the load is restored exactly, p ← p · P/Σp; under displacement control
   (no load to restore) p and H p are rescaled instead by s = pᵀw / pᵀHp,
   the minimum of the energy along p (``CGSettings.energy_scale``), also
   at the start.

On levels of ``CGSettings.primal_dual_from`` nodes or more whose fresh start
(a coarse grid's or the punches') holds a quarter of their nodes in contact
or more (``CGSettings.primal_dual_share``), or whose start is a neighbour's
solution (``CGSettings.primal_dual_warm_share``: any share), the set is
settled first by the primal–dual active set (:mod:`.primal_dual`): held
while the CG solves on it, then moved at once; this iteration goes on from
its forces only where that gives up.

Load control with free rotation (imposed moments) is a Newton iteration on
(θx, θy) around this solve (:mod:`.rigid_motion`, whose Hessian needs two
Krylov solves on the contact set at a constant load): imposing the moments
as two more linear constraints inside the CG loses the support at small
loads, where a handful of nodes must surround the load point. By default
(``CGSettings.rotation_from``: every level) the primal–dual steps find the
rotation with the forces instead, the moments two more constraints of each
held set's solve (:mod:`.primal_dual`), and the Newton runs only where
they give up (a set that cannot carry the moments: most contacts of 3–4
nodes about the load point).

It stops when the residual of the contact conditions,
max(|g| on S, max(−g) off S) / (scale of w), is at most ``tol`` (the same
measure and default as the active-set solver), confirmed on an exactly
recomputed H p, and raises :class:`~roughcontact.errors.ConvergenceError`
when it cannot: the iteration limit, or a loss of positive curvature.

Each iteration can be traced: with the logger ``roughcontact.normal.constrained_cg``
at DEBUG, every step logs a record whose ``cg_step`` attribute holds the
level's node count, the iteration, the residual it started from, the nodes
its free set changed and holds, the returning nodes it held back
(``CGSettings.alternate_return``), the step α and the restarts of the
directions it took (benchmarks/bench_trace.py writes them as JSON). Nothing
is reduced over the ranks for the trace, so ranks may log or not
independently; a solve traced or not takes the same steps.

References: I.A. Polonsky, L.M. Keer, Wear 231 (1999) 206–219;
E.A.H. Vollebregt, J. Comput. Phys. 257 (2014) 333–351 (preconditioning the
contact set with FFTs); J.J. Moré, G. Toraldo, SIAM J. Optim. 1 (1991)
93–113 (the free set of bound-constrained CG).
"""
from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np

from ..errors import ConvergenceError, InputError
from ..operators import passes
from ..operators.balancing import BALANCING_SHARE, BalancingSpace
from ..operators.convolution import dense
from ..operators.extension import SmoothExtension
from ..operators.holes import HoleCharge
from ..operators.preconditioner import EDGE_UPDATES, EdgeWeights
from .cg_settings import CGSettings
from .nested import COARSE_TOL, NestedStart
from .primal_dual import settle
from .problem import NormalProblem
from .result import ContactState
from .rigid_motion import InexactResolution, newton_on_motion
from .solver import NormalSolver

_log = logging.getLogger(__name__)

#: the residual (relative to the scale of w) below which single-precision products can stop it
#: falling: they stalled it at 1e-7 to 8e-7 near full contact (512²), so 1e-5 leaves a factor 10
SINGLE_FLOOR = 1e-5
#: the cut nodes whose far field may wait at once: one in this many nodes of the grid. Each costs
#: two window sums of about 10 µs (9.5-9.9 µs per node in 1024² and 2048² solves), and a 2048²
#: single-precision product about 100 ms: N / 1024 nodes keep the sums below a product's time
DEFER_NODES = 1024
#: the grids (nodes) from which cut forces' far fields may wait: below, a product costs under 4 ms
#: and waiting saved nothing measurable, while on sparse contacts it cost iterations (128², Δ = 2.5,
#: 1e-3 E*, 0.3 % in contact: 31 against 12; 1e-4 E*: 16 against 7)
DEFER_FROM = 512 * 512
#: the inner tolerance of the free rotation's first evaluation, whose load residual is the start's:
#: 1.7e-3 and 4.4e-3 of the scale from the coarse level on the large-grid scene at 2048² and 1024².
#: The moments of a state resolved to r are off by about 0.17 r (measured at 1024²), so 1e-5 keeps
#: that 1e-3 of those residuals, the inexact Newton's rule for the states it steps from; the
#: solver's tol took 22 and 19 CG iterations there, 1e-5 14 and 12, with the same Newton steps
FIRST_TOL = 1e-5


class ConstrainedCGSolver(NormalSolver):
    """Normal contact by bound-constrained, preconditioned conjugate gradients.

    Parameters
    ----------
    problem
        The :class:`NormalProblem` (any operator; FFT operators make each
        iteration O(N log N)).
    settings
        :class:`CGSettings`.
    nested
        Start cold solves from the solution on the grid of spacing 2s
        (:mod:`.nested`), when the grid is fine enough for it to pay off.
    coarse
        This solver is a coarse level of a nested start (set by
        :mod:`.nested`): with the rotation fixed, the products of its forces
        are taken in the working precision (``CGSettings.precision``).
    """

    #: the keyword options :func:`~.factory.make_solver` passes on
    OPTIONS = ("settings", "nested")

    def __init__(self, problem: NormalProblem, settings: CGSettings = CGSettings(), nested: bool = True,
                 coarse: bool = False):
        super().__init__(problem)
        self.method = "cg"
        if not isinstance(settings, CGSettings):
            raise InputError("settings", f"must be a CGSettings, got {type(settings).__name__}")
        self.settings = settings
        # a coarse level of a nested start: its state only starts the next level
        self.coarse = bool(coarse)
        if settings.preconditioner == "fourier":
            problem.flexibility.preconditioner   # built now, collectively, not inside a solve
        # a coarse level only starts the next one, whose discretisation moves the loads of its
        # state by more than COARSE_TOL (1.3e-4 of P at 513² from 257²): its contact conditions
        # and its loads (free rotation) are resolved to COARSE_TOL, not to the fine solve's tolerances
        coarse_settings = replace(settings, tol=max(settings.tol, COARSE_TOL),
                                  load_tol=max(settings.load_tol, COARSE_TOL))
        self.nested = NestedStart(problem, lambda level: ConstrainedCGSolver(level, coarse_settings, coarse=True)) \
            if nested and NestedStart.applies(problem) else None
        self._krylov = None                            # Krylov solves of the Hessian, free rotation
        # their last solutions (nodes of S, X: the forces' response to (θx, θy) at a constant load),
        # the next step's and the next load's start: 24 B per contact node of this rank, kept until
        # the solver is released
        self._basis = None
        self._colours = None                           # the nodes' checkerboard (alternate_return)
        self._fresh = False                            # whether the last start was a coarse grid's or the punches'
        # the balancing coarse space of the solve under way (None: none), which a free rotation's
        # evaluations share: made once per solve, let go when it returns
        self._space: BalancingSpace | None = None

    @property
    def description(self) -> str:
        s = self.settings
        return f"bound-constrained CG, {s.preconditioner} preconditioner (tol={s.tol:g})"

    def _release(self) -> None:
        if self.nested is not None:
            self.nested.destroy()
        if self._krylov is not None:
            self._krylov.destroy()
        self._basis = self._colours = None

    # ---------------------------------------------------------------- solve
    def _solve(self, rigid, free, loads):
        forces, motion = self._start(rigid, free, loads)
        # only from a fresh start: a warm one (a sweep's neighbour) has little left to settle, and
        # W's products would cost what the iterations it saves do
        self._space = self._coarse_space() if self._fresh else None
        try:
            return self._solve_from(rigid, free, loads, forces, motion)
        finally:
            self._space = None

    def _solve_from(self, rigid, free, loads, forces, motion):
        """The solve from the start (``forces``, ``motion``) :meth:`_start` gave."""
        if len(free) <= 1:
            return self._settled(rigid, free, loads, forces, forces_in_double=not self.coarse, owned=True)
        unsettled = 0                                  # the products of primal-dual steps that gave up
        start = self.settings.rotation_from
        if free == [0, 1, 2] and start is not None and self.problem.size >= start:
            # the primal–dual steps find the rotation with the forces, the moments two more
            # constraints of each set's solve: no Newton iteration around the solves. From any
            # start and any share in contact: they replace the Newton's two or more evaluations
            # and Hessians, which pays down to about 6 nodes in contact and on warm starts; on 3-4
            # they mostly give up at once (docs/solvers.md, "On every grid")
            settled = self._primal_dual(rigid, free, loads, forces, forces_in_double=not self.coarse)
            if settled[0] is not None:
                return settled[0]
            forces, unsettled = settled[1], settled[2]
        # free rotation: Newton on (θx, θy), each evaluation a load-controlled solve at fixed θ
        rigid[free] = motion[free]
        state = {"forces": forces}

        # an inexact Newton: each state resolved only as far as the step from it needs, the first
        # to FIRST_TOL. Resolving every evaluation below load_tol, as once, solved the first steps
        # 1000 times tighter than their own residual was wide
        resolution = InexactResolution(self.settings.tol, self.settings.load_tol, FIRST_TOL)

        anchor = {}                                    # the state the Hessian was last taken at

        def evaluate(motion, needed):
            start = state["forces"] if not anchor else self._predicted(anchor["motion"], anchor["forces"], motion)
            if "motion" not in state:                  # the first evaluation: only it may settle first
                result, motion = self._settled(motion, [0], loads, start, tol=resolution(needed))
            else:
                result, motion = self._constrained_cg(motion, [0], loads, start, tol=resolution(needed))
            state.update(forces=result.pressure.copy(), motion=motion.copy())
            return result, motion

        def stiffness(active):
            # taken at the last state evaluated (the Newton's current one), whose forces and rotation
            # are then the start every trial of the step is predicted from
            matrix, its = self._stiffness(active)
            anchor.update(motion=state["motion"], forces=state["forces"])
            return matrix, its

        state, rigid = newton_on_motion(self.problem, rigid, free, [1, 2], loads, evaluate, stiffness,
                                        load_tol=self.settings.load_tol, max_newton=self.settings.max_newton,
                                        resolution=resolution, tighten=resolution.tighten)
        return state._replace(linear=state.linear + unsettled), rigid

    def _settled(self, rigid, free, loads, forces, tol: float | None = None, forces_in_double: bool = True,
                 owned: bool = False):
        """:meth:`_constrained_cg` (the same arguments, δz imposed or found from P), after the
        primal–dual active set where :meth:`_settles_first` says (its exact products in the working
        precision too where ``forces_in_double`` is False); the CG then goes on only where that
        gave up, and the products of both count."""
        settled = None
        if self._settles_first(forces):
            if not owned:
                forces = forces.copy()
            settled = self._primal_dual(rigid, free, loads, forces, tol, forces_in_double)
            if settled[0] is not None:
                return settled[0]
            forces, owned = settled[1], True
        state, rigid = self._constrained_cg(rigid, free, loads, forces, tol=tol, forces_in_double=forces_in_double,
                                            owned=owned)
        if settled is not None:                        # the products the primal-dual steps took count too
            state = state._replace(linear=state.linear + settled[2])
        return state, rigid

    def _settles_first(self, forces: np.ndarray) -> bool:
        """Whether this solve settles its set by the primal–dual active set first: a level of
        ``CGSettings.primal_dual_from`` nodes or more whose start holds at least
        ``CGSettings.primal_dual_share`` of them in contact, fresh, or ``primal_dual_warm_share``,
        warm (the same answer on every rank)."""
        settings, pb = self.settings, self.problem
        share = settings.primal_dual_share if self._fresh else settings.primal_dual_warm_share
        return (settings.primal_dual_from is not None and pb.size >= settings.primal_dual_from
                and float(pb.allsum(np.count_nonzero(forces > 0.0))) >= share * pb.size)

    def _primal_dual(self, rigid, free, loads, forces, tol: float | None = None, forces_in_double: bool = True):
        """The primal–dual active set (:mod:`.primal_dual`) from the start ``forces`` (changed in
        place), the components ``free`` of the rigid motion found with the forces (the approach,
        or under load control with the rotation free all three), to ``tol`` (None: the settings'):
        ((state, rigid), None, products) where it met the tolerance, else (None, its forces
        clipped at zero for the constrained CG, or with the rotation free the Newton on θ, to go
        on from, the products it took)."""
        pb, settings = self.problem, self.settings
        rigid, w, load = self._imposed(rigid, free, loads)
        edges, holes = self._set_corrections()
        # on a held set the hole charge is taken from its first step, and so is the extension
        extension = self._extension() if holes is not None else None
        held = None                                    # the extension on the set held now (None: none)

        moments = free == [0, 1, 2]                    # the rotation found with the forces

        def direction(g, nodes, edge, single):
            # with the moments the steps project the whole rigid fit out, the mean with it
            return self._direction(g, nodes, single, edge, load is not None and not moments, holes,
                                   extension=held)

        def weights(nodes, members, single):
            # called once for each set the steps hold: the extension is chosen there too, and on a
            # set that takes it the edge weights and the charge are not made (_skip_corrections)
            nonlocal held
            held = extension if extension is not None and extension.chosen(nodes) else None
            if held is not None:
                return _skip_corrections(holes)
            return self._edge_weights(edges, nodes, members, single, self._corrected, holes)

        trace = None
        if _log.isEnabledFor(logging.DEBUG):
            def trace(step, residual, changed, size, alpha, restart):
                _log_step(pb.size, step, residual, changed, size, 0, alpha,
                          ["primal-dual"] + ([restart] if restart else []))
        settled = settle(pb, forces, w, load, settings.tol if tol is None else tol, settings.precision == "mixed",
                         direction, weights, trace, forces_in_double,
                         loads=loads if moments else None, start_only=self.coarse,
                         max_products=settings.max_iterations)
        if not settled.converged:
            _log.debug("n %d primal-dual active set gave up after %d passes and %d products; the %s goes on "
                       "from its forces", pb.size, len(settled.history), settled.products,
                       "Newton on the rotation" if moments else "constrained CG")
            return None, settled.forces, settled.products
        rigid[free] = settled.motion[free]
        state = self._state(settled.forces, settled.gap, settled.products, settled.history[-1], settled.history)
        return (state._replace(outer=len(settled.history)), rigid), None, settled.products

    def _imposed(self, rigid, free, loads):
        """(r with the free components zeroed, w_fixed = C r − gap0 or None where that is −gap0,
        P or None): what a solve with the components ``free`` found from ``loads`` imposes."""
        rigid = rigid.copy()
        rigid[free] = 0.0
        return rigid, (self.problem.interpenetration(rigid) if rigid.any() else None), \
            (loads[0] if free else None)

    def _predicted(self, motion0: np.ndarray, forces0: np.ndarray, motion: np.ndarray) -> np.ndarray:
        """The start of an evaluation at ``motion``: the forces of the state (motion0, forces0)
        moved along the Hessian's solutions on its contact set S, p0 + X Δθ (X the forces'
        response to the rotations at a constant load, :meth:`_stiffness`; exact while S holds,
        the CG corrects the rest), clipped at zero. The trials of a Newton step started from the
        last evaluation took 10-13 % more linear iterations (257² and 1025² sweeps)."""
        if self._basis is None:
            return forces0
        nodes, basis = self._basis
        forces = forces0.copy()
        forces[nodes] += basis @ (np.asarray(motion[1:], dtype=float) - np.asarray(motion0[1:], dtype=float))
        return np.maximum(forces, 0.0, out=forces)

    def _constrained_cg(self, rigid, free, loads, forces, tol: float | None = None,
                        forces_in_double: bool = True, owned: bool = False):
        """The bound-constrained CG with δz imposed (``free`` = []) or found from P (``free`` = [0]);
        ``forces_in_double`` False: the products H p of the forces themselves in the working
        precision too (a coarse level's state at COARSE_TOL, which only starts the next level);
        ``owned``: ``forces`` are the solve's own to change (a fresh start), not copied first."""
        pb, settings = self.problem, self.settings
        tol = settings.tol if tol is None else tol
        # w_fixed (δz left out under load control); None where the imposed motion is zero and w
        # is −gap0, which the problem holds already: the iteration adds gap0 instead of
        # subtracting a copy of w (8 B per node less, the same bits)
        rigid, w, load = self._imposed(rigid, free, loads)
        w_scale = pb.interpenetration_scale(pb.gap0 if w is None else w)
        single = settings.precision == "mixed"
        if not owned:
            forces = forces.copy()
        if load is not None:
            forces *= pb.load_scale(forces, load)
        # H p of the forces themselves in double, but on a coarse level at a loose tolerance
        # (COARSE_TOL) with the rotation fixed: a single product's ~1e-7 is far below it, and a
        # 2048² coarse level's two double products took 0.8 s. Not in a Newton's evaluations,
        # whose Φ compares states through pᵀg (a 64² state at tol 1e-3 was off by 5e-8 of Φ)
        exact = lambda: pb.displacement(forces, single and not forces_in_double)    # noqa: E731
        displacement = exact()
        # under displacement control the forces' own scale, set by the energy along them
        # (``CGSettings.energy_scale``), at the start and after every step
        scaling = load is None and settings.energy_scale
        if scaling:
            _scale_to_energy(pb, forces, displacement, w, None)
        direction = np.zeros_like(forces)              # zero outside the free set
        last_z = np.zeros(forces.size, dtype=np.float32)   # z of the last iteration on its free set
        clipped = np.zeros_like(forces)                # c of the last cut at its nodes, zero elsewhere
        pending = self._pending()                      # cut forces whose far field waits (None: never)
        previous = None                                # gᵀz of the last iteration, None: restart
        working = np.zeros(0, dtype=np.intp)           # the free set of the last iteration
        free_mask = np.zeros(forces.size, dtype=bool)  # the same set as a mask (set changes by XOR)
        # the node vectors of every iteration, made once: fresh temporaries of N values (and index
        # arrays of changing sizes between them) fragmented the heap of each rank
        last_mask, changed, in_contact = (np.zeros(forces.size, dtype=bool) for _ in range(3))
        # the nodes that have left the contact set during this solve, and the squares of the
        # checkerboard on which they come back (``CGSettings.alternate_return``; None: off)
        left = np.zeros(forces.size, dtype=bool) if settings.alternate_return else None
        squares = self._squares() if settings.alternate_return else None
        # H p − w, the deformed gap before the approach is subtracted: the gap is this less the
        # approach, taken on the nodes that need it (a pass over N less per iteration)
        lifted = np.empty_like(forces)
        edge, stale = None, True                       # the edge weights on the free set (None: none)
        # they follow small changes of the free set through windows of C⁻¹ (EdgeWeights)
        # and the edge charge the holes of the free set let the preconditioner take back (None: none)
        edges, holes = self._set_corrections()
        taking = False                                 # whether the hole charge is taken now
        # M_T on a dust's set where the charge would be taken (None: never in this solve)
        extension = self._extension() if holes is not None else None
        extending = False                              # whether this iteration's set takes it
        # the solve's balancing coarse space, made where the hole charge is first taken (None: none)
        coarse_space = self._space if holes is not None else None
        correcting = self._corrected                   # the edge correction in use (dropped where it stalls)
        history: list[float] = []
        tracing = _log.isEnabledFor(logging.DEBUG)    # this rank's choice: nothing collective follows
        restarts: list[str] = []                       # why the directions restarted (the trace)
        since_refresh = 0
        best, since_best = np.inf, 0                   # the lowest residual, iterations since it
        since_restart = 0
        at_floor = False                               # H p taken exactly at SINGLE_FLOOR (mixed precision)
        # H d held this iteration: the last cut could not wait, or the first step of a fresh start
        holds = pb.flexibility.holds                   # whether the operator's products can be held
        holding = owned and self._fresh and holds
        # H of a nodal vector that is zero off some nodes: only those nodes go into the transform
        # (``scattered``), or the whole vector (``whole``, a dense set); ``single`` as it stands
        scattered = lambda values, nodes: pb.displacement_at(values[nodes], nodes, single)  # noqa: E731
        whole = lambda values, nodes: pb.displacement(values, single)                       # noqa: E731
        workers = pb.flexibility.workers               # the threads of the passes over the nodes (passes)
        for iteration in range(1, settings.max_iterations + 1):
            restarts.clear()
            # the set now, into the scratch mask: in_contact still holds the last step's set, and
            # the nodes in it but not in this one left (``alternate_return``); then the two swap
            passes.combine(np.greater, forces, 0.0, changed, workers)
            if left is not None:
                passes.combine(np.greater, in_contact, changed, in_contact, workers)   # the nodes that left
                passes.combine(np.logical_or, left, in_contact, left, workers)
            in_contact, changed = changed, in_contact
            contact = passes.nonzero(in_contact, workers)
            if w is None:
                passes.combine(np.add, displacement, pb.gap0, lifted, workers)
            else:
                passes.combine(np.subtract, displacement, w, lifted, workers)
            on_contact = passes.gather(lifted, contact, workers)
            approach = pb.allmean(on_contact) if load is not None else 0.0
            on_contact -= approach                     # the deformed gap on S, zero at the solution
            # max(|g| on S, max(−g) off S): −g ≤ |g| on S, so the minimum may run over all nodes
            residual = float(pb.allmax(max(passes.largest_magnitude(on_contact),
                                            approach - lifted.min(initial=approach)))) / w_scale
            # each vector of the set's size is let go as soon as it has served: left alive into the
            # products below, whose blocks were then allocated beside them, they raised a rank's
            # peak by 62 B per node near full contact at 2048² (docs/solvers.md)
            del contact, on_contact
            history.append(residual)
            best, since_best = (residual, 0) if residual < best else (best, since_best + 1)
            # single-precision products stalled (no new lowest residual in `renew` iterations: near
            # full contact at 512² the residual rose from 1e-7 to 8e-7, 949 iterations against 54).
            # Above SINGLE_FLOOR a rise is the contact set settling, not the precision: at 4096²
            # the residual rose from 2.0e-4 to 7.7e-4 over 6 iterations and fell again, and taking
            # the remaining 47 products in double cost 31.7 s of a 91.7 s solve. Four times as long
            # without a new lowest value is a stall wherever it stands
            stalled = single and since_best >= settings.renew and (best <= SINGLE_FLOOR
                                                                   or since_best >= 4 * settings.renew)
            if correcting and since_best >= 2 * settings.renew and best > SINGLE_FLOOR:
                # above the precision's floor no new lowest residual in 2 × `renew` iterations is
                # the free set cycling; near full contact on a rough surface (1024², Δ = 2.8, 1 E*)
                # the corrected preconditioner let 1-3 % of the set flip every iteration for 200
                # iterations (232 against 84 plain): the plain one from here, directions restarted
                # (105). After `renew` alone it also fired at 1024², Δ = 2.5, where the correction
                # gets through a slow stretch (88 iterations against 71 without the rule, 81 plain)
                correcting, stale, previous, since_best = False, True, None, 0
                restarts.append("correction dropped")
            if residual <= tol or stalled:
                if since_refresh == 0 and residual <= tol:
                    rigid[free] = approach
                    lifted -= approach
                    return self._state(forces, lifted, iteration, residual, history), rigid
                # confirm on an exact H p (the updated one carries the steps' round-off); if that
                # gap is not converged, the conjugate directions were built on the updated one:
                # restart them, and take every product in double from here (the single ones left
                # 1.2e-10 at 65² and tol 1e-11, and 1084 iterations against 310 when they went on)
                if since_refresh:
                    del displacement                   # not held through the product that replaces it
                    displacement = exact()
                if pending is not None and pending.count:
                    # the deferred far fields may have made the difference: no more deferring, but
                    # the products stay in single precision until a confirmation fails without them
                    pending = None
                else:
                    single = False
                since_refresh, previous, since_best = 0, None, 0
                continue
            # masks, not sorted-set operations: union1d's sort cost more than the FFT products at 512²
            last, last_mask, free_mask = _cleared(working, forces.size), free_mask, last_mask
            passes.combine(np.less, lifted, approach, free_mask, workers)              # interpenetrating
            passes.combine(np.logical_or, in_contact, free_mask, free_mask, workers)
            held = 0 if left is None else _hold_back(free_mask, in_contact, left, squares, iteration, changed,
                                                     workers)
            working = passes.nonzero(free_mask, workers)
            counts = pb.allsum(np.array([np.count_nonzero(passes.combine(np.not_equal, free_mask, last_mask,
                                                                         changed, workers)),
                                         working.size, held]))
            since_restart += 1
            if previous is None and not restarts:
                # nothing in this iteration: the first one, or a confirmation of convergence before
                restarts.append("start" if iteration == 1 else "confirmation")
            if counts[0] > 0 and since_restart >= settings.renew:
                previous = None                        # the renewal (``CGSettings.renew``)
                restarts.append("renewal")
            if previous is None:
                since_restart = 0
            if holes is not None and (counts[0] <= pb.size // EDGE_UPDATES) != taking:
                # the hole charge while the set changes by one node in EDGE_UPDATES or fewer
                # (``CGSettings.hole_block``); the directions restart where M changes
                taking, stale, previous, since_restart = not taking, True, None, 0
                restarts.append("charge on" if taking else "charge off")
                if taking:                             # the set moved since its rims were found
                    holes.labelled = False
                if taking and coarse_space is not None and not coarse_space.made:
                    # made once, on a sparse set (``CGSettings.balancing_from``)
                    if counts[1] <= BALANCING_SHARE * pb.size:        # the free set over all ranks
                        coarse_space.make(working, single)
                        restarts.append("coarse space")
                    else:
                        coarse_space = self._space = None
            charge = holes if taking else None         # the hole charge of this iteration (None: none)
            if extension is not None:
                # decided once as the charge is taken, on that set, and kept while it is (a share
                # near the bound would otherwise switch M, and restart the directions, as the set
                # moves); dropped with the edge correction where the set cycles
                if not (taking and correcting):
                    now = False
                else:
                    now = extending or ("charge on" in restarts and extension.chosen(working))
                if now != extending:                   # M changes: the directions restart
                    extending, previous, since_restart = now, None, 0
                    restarts.append("extension on" if now else "extension off")
            if extending:
                edge, stale = _skip_corrections(holes), True   # made again when the extension stops
            elif stale or counts[0] > 0:
                # the weights of the set as it is now: kept from the last restart while the set
                # moved, they let the residual wander between 1e-4 and 7e-4 for 30 iterations at
                # 4096² (61 fine iterations against 42)
                edge, stale = self._edge_weights(edges, working, free_mask, single, correcting, charge), False
            g = passes.gather(lifted, working, workers)
            g -= approach
            if pending is not None:                    # what the deferred far fields may reach
                square, size = pb.allsum(np.array([g @ g, g.size]))
                allowed = settings.defer * float(np.sqrt(square / size)) if size else 0.0
            z, gz = self._direction(g, working, single, edge, load is not None, charge,
                                    coarse_space if taking else None, extension if extending else None)
            if not gz > 0.0 and correcting:
                # the corrected preconditioner is positive definite only as far as C⁻¹'s positive
                # far entries allow; the plain one always is (never seen to fire in a solve). The
                # conjugate directions restart: the last ones were made with the corrected one
                z, gz = self._direction(g, working, single, None, load is not None, None)
                previous = None
                restarts.append("plain")
            if previous is not None and \
                    abs(float(pb.allsum(g @ passes.gather(last_z, working, workers)))) >= settings.restart * gz:
                previous = None                        # Powell's test (``CGSettings.restart``)
                restarts.append("powell")
            _clear(last_z, last, workers)
            passes.scatter(last_z, working, z.astype(np.float32), workers)   # converted first: a converting
            # scatter took twice as long
            if previous is None or gz <= 0.0:
                step_direction = z
            else:
                step_direction = z + (gz / previous) * passes.gather(direction, working, workers)
                if load is not None:
                    step_direction -= pb.allmean(step_direction)
            previous = gz
            _clear(direction, last, workers)
            passes.scatter(direction, working, step_direction, workers)
            del g, z
            # H d, held between its transforms with dᵀHd read off its spectrum (Parseval), after
            # an iteration whose cut could not wait and on the first step from a coarse grid's
            # or the punches' start (``holding``): such cuts come in runs, and the step then
            # decides below whether H d itself is wanted or only H of the step and its cut
            # together. Held too where the step ends in an exact H p. Elsewhere H d is made
            # whole: reading dᵀHd off the spectrum costs a pass over it that only a joined
            # product or a skipped inverse repays. On a dense set the direction field
            # itself (d on the set, zero elsewhere) goes into the transform whole, where
            # scattering d at the set's positions cost three passes over the slab (the product
            # 0.81-0.85 of the time near full contact at 1024² and 2048², 86 % of the nodes in
            # the set)
            crowded = dense(working.size, forces.size)
            # once, where the residual first reaches SINGLE_FLOOR: an exact H p drops the
            # single-precision errors of the large early steps (``CGSettings.precision``). A step
            # that ends in an exact H p (that, or a refresh) needs dᵀHd alone: H d is held too
            floor = single and forces_in_double and not at_floor and residual <= SINGLE_FLOOR
            refreshing = floor or since_refresh + 1 >= settings.refresh
            if (holding or refreshing) and holds:
                held_product, product = (pb.held_displacement(direction, single) if crowded
                                         else pb.held_displacement_at(step_direction, working, single)), None
                curvature = float(pb.allsum(held_product.energy))
            else:
                held_product, product = None, (pb.displacement(direction, single) if crowded
                                               else pb.displacement_at(step_direction, working, single))
                curvature = float(pb.allsum(step_direction @ passes.gather(product, working, workers)))
            if not curvature > 0.0:
                raise ConvergenceError(
                    "CG_INDEFINITE", f"iteration {iteration}: dᵀHd = {curvature:.3e} <= 0 on a set of "
                                     f"{int(counts[1])} nodes; the operator is not positive definite there")
            step = gz / curvature
            if tracing:
                _log_step(pb.size, iteration, residual, counts[0], counts[1], counts[2], step, restarts)
            step_direction *= step                     # α d in place (``direction`` keeps d): no temporary
            trial = passes.gather(forces, working, workers)
            trial -= step_direction
            del step_direction
            leaving = trial < 0.0
            cut = bool(pb.allmax(float(leaving.any())) > 0.0)
            if cut:                                    # the forces the cut adds back, c = −trial ≥ 0
                cut_nodes = working[leaving]
                clipped[cut_nodes] = -trial[leaving]
                trial[leaving] = 0.0
            # the load restored on the step's forces before their one scatter (a gather and a
            # second scatter of the free set cost 15 ms an iteration near full contact at 2048²)
            scale = pb.load_scale(trial, load) if load is not None else 1.0
            if scale != 1.0:
                trial *= scale
            passes.scatter(forces, working, trial, workers)
            del trial, leaving
            since_refresh += 1
            at_floor = at_floor or floor
            if refreshing:
                del held_product, product, displacement   # H d unused (held: its inverse transforms skipped)
                displacement = exact()
                since_refresh = 0
                if pending is not None:
                    pending.clear()
                if cut:
                    clipped[cut_nodes] = 0.0
                holding = False
                if scaling:
                    _scale_to_energy(pb, forces, displacement, w, working, pending)
                continue
            # H (p − α d + c) = H p − α H d + H c. After a cut whose far field cannot wait, or
            # with the far fields deferred grown past `allowed` (``CGSettings.defer``), the step
            # and the forces to settle go into one product, H (c − α d): the held H d is dropped
            # before its inverse transforms, half a product saved. Otherwise H d is completed,
            # and a cut whose far field waits adds only its near field
            if pending is None:
                joined = cut
                holding = cut and holds
            else:
                mass, count = pb.allsum(np.array([clipped[cut_nodes].sum(), cut_nodes.size])) if cut \
                    else (0.0, 0)
                deferred = (cut and pending.count + count <= self._deferred_nodes
                            and pending.bound(mass) <= allowed)
                if deferred:
                    pending.defer(displacement, cut_nodes, clipped[cut_nodes], float(mass), int(count))
                joined = (cut and not deferred) or (not cut and pending.bound() > allowed)
                # a cut too large to wait even alone: the next one is likely too (the first steps
                # after a start, the set settling); a settle of small cuts that added up is not
                holding = holds and cut and not (count <= self._deferred_nodes
                                                 and pending.bound_of(mass) <= allowed)
            if joined and held_product is not None:
                del held_product, product              # its spectrum is overwritten by the next transform
                # c − α d into ``clipped`` (d is zero off the set); on a dense set the whole vector,
                # rounded as on the set's nodes alone (daxpy's fused products would round it
                # otherwise), so that both write paths transform the same field
                if crowded:
                    clipped -= step * direction
                else:
                    clipped[working] -= step * direction[working]
                join = whole if crowded else scattered
                # (the ledger is empty after a cut that could not wait; it is settled in case not)
                settling = pending is not None and pending.count
                displacement += pending.settle(clipped, working, join) if settling else join(clipped, working)
                _clear(clipped, None if crowded else working, workers)
            else:
                if held_product is not None:
                    product = held_product.result()
                displacement = passes.add_scaled(displacement, -step, product)
                del held_product, product              # before the product of the cut forces
                if joined:                             # H d was made whole: c (and the deferred) apart
                    displacement += scattered(clipped, cut_nodes) if pending is None else \
                        pending.settle(clipped, cut_nodes if cut else working[:0], scattered)
                if cut:
                    clipped[cut_nodes] = 0.0
            if scale != 1.0:                           # (under displacement control: the energy's, below)
                passes.scale(displacement, scale, workers)   # H is linear: a uniform rescaling is exact
                if pending is not None:
                    pending.rescale(scale)
            if scaling:
                _scale_to_energy(pb, forces, displacement, w, working, pending)
        raise ConvergenceError(
            "CG_MAX_ITERATIONS",
            f"{settings.max_iterations} bound-constrained CG iterations without meeting tol={tol:g} "
            f"(last residual {history[-1]:.3e}); raise CGSettings.max_iterations or loosen tol")

    def _squares(self) -> np.ndarray:
        """The colour of each of this rank's nodes on the grid's checkerboard, (i + j) mod 2 as a
        bool (the same for a node on any number of ranks), made on first use."""
        if self._colours is None:
            self._colours = self.problem.flexibility.layout.parities()
        return self._colours

    def _stiffness(self, active: np.ndarray):
        """The Hessian over (θx, θy) of Φ minimised over δz: X = H_SS⁻¹ (C_θ − 1 μᵀ) with Σ X = 0,
        the forces' response to the rotations at a constant load (two Krylov solves on the
        contact set S, :class:`~.petsc.LoadKept`), and C_θᵀ X, the Schur complement over δz of
        C_Sᵀ H_SS⁻¹ C_S (Eq. 8: C_θ = [−y, −x]). Three solves for the whole of C_Sᵀ H_SS⁻¹ C_S
        took the fine level's Hessians 24 + 13 Krylov iterations on the large-grid scene with
        the rotation free at 2048², the two 14 + 8."""
        pb = self.problem
        if pb.allsum(active.sum()) == 0:
            self._basis = None
            return np.zeros((2, 2)), 0
        if self._krylov is None:
            from .petsc import KSPSubsolver

            # the Hessian only shapes the Newton step (its accuracy is set by the inner solves and
            # load_tol): rtol 1e-6 instead of 1e-11 took a 12-load sweep at 65² from 1.9 to 1.3 s;
            # 1e-3 instead of 1e-6 halved these solves' time in a 12-load sweep at 257² with the
            # same Newton steps, where 1e-2 took more steps (69 evaluations against 61). Its
            # products in single precision where the CG's are (``mixed``): their ~1e-7 lies far below
            # 1e-3, and the large-grid scene with the rotation free took the same iterations and
            # rotation to 12 digits, its Hessians 0.60-0.61 of the time at 1024² and 2048²
            self._krylov = KSPSubsolver(pb.flexibility, prefix="normal_rotation_", rtol=1e-3,
                                        edge_share=self.settings.edge_share,
                                        single=self.settings.precision == "mixed", keep_load=True)
        self._krylov.set_active(active)
        nodes = np.flatnonzero(active)
        columns = pb.columns_at(nodes)[:, 1:]
        guess = np.zeros_like(columns)
        if self._basis is not None:                    # the last step's solutions where S kept its nodes
            _, here, there = np.intersect1d(nodes, self._basis[0], assume_unique=True, return_indices=True)
            guess[here] = self._basis[1][there]
        basis = np.empty_like(columns)
        its = 0
        for j in range(2):
            basis[:, j], count = self._krylov.solve(columns[:, j], guess[:, j])
            its += count
        self._basis = (nodes, basis)
        hessian = pb.allsum(columns.T @ basis)
        return 0.5 * (hessian + hessian.T), its

    # ------------------------------------------------------------- helpers
    def _start(self, rigid, free, loads) -> tuple[np.ndarray, np.ndarray]:
        """Initial forces and rigid motion: the last solution (warm start), a coarse grid's
        (:mod:`.nested`), or independent punches at the Winkler approach."""
        pb = self.problem
        self.coarse_iterations = 0
        # a warm start (a neighbour's solution) cuts little on its first step; a coarse grid's or
        # the punches' cuts much (``holding`` in the CG)
        self._fresh = True
        if self.forces is not None and pb.allsum(self.forces.sum()) > 0.0:
            self._fresh = False
            return self.forces.copy(), self.rigid.copy()
        if self.nested is not None:
            start = self.nested.start(rigid, free, loads)
            if start is not None and pb.allsum(start[0].sum()) > 0.0:
                self.coarse_iterations = self.nested.iterations
                return start
        rigid = rigid.copy()
        if free:
            rigid[free] = 0.0
            rigid[0] = self.winkler_approach(rigid, loads[0])
        return np.maximum(pb.interpenetration(rigid), 0.0) / pb.flexibility.diagonal, rigid

    def _pending(self):
        """A ledger of cut forces whose far field waits (:class:`~roughcontact.operators.near_field.PendingFarField`),
        or None where the operator has no near field, the grid is below DEFER_FROM nodes or
        ``defer`` is 0."""
        if self.settings.defer <= 0.0 or self.problem.size < DEFER_FROM:
            return None
        near = self.problem.flexibility.near_field
        if near is None:
            return None
        from ..operators.near_field import PendingFarField

        return PendingFarField(near)

    @property
    def _deferred_nodes(self) -> int:
        """The most cut nodes whose far field may wait at once (all ranks): one in DEFER_NODES."""
        return max(1, self.problem.size // DEFER_NODES)

    @property
    def _corrected(self) -> bool:
        """Whether the preconditioner carries the edge correction (the same on every rank)."""
        return self.settings.preconditioner == "fourier" and self.settings.edge_share > 0.0

    def _set_corrections(self) -> tuple[EdgeWeights | None, HoleCharge | None]:
        """A solve's trackers of the preconditioner's corrections on its set: the edge weights
        (:class:`~roughcontact.operators.preconditioner.EdgeWeights`; None without the edge
        correction) and the hole charge (:class:`~roughcontact.operators.holes.HoleCharge`; None
        without it or with ``hole_block`` 0)."""
        settings, flexibility = self.settings, self.problem.flexibility
        if not self._corrected:
            return None, None
        edges = EdgeWeights(flexibility.preconditioner, settings.edge_share)
        holes = (HoleCharge(flexibility.layout, self.problem.comm, settings.edge_share, settings.hole_block)
                 if settings.hole_block != 0 else None)
        return edges, holes

    def _taken_from(self, start: int | None) -> bool:
        """Whether this level takes a part of the preconditioner that levels of ``start`` nodes or
        more take (None: none), which goes with the edge correction."""
        return start is not None and self.problem.size >= start and self._corrected

    def _coarse_space(self) -> BalancingSpace | None:
        """The balancing coarse space of this level (:mod:`~roughcontact.operators.balancing`), not
        yet made; None below ``CGSettings.balancing_from`` nodes or without the edge correction."""
        if not self._taken_from(self.settings.balancing_from):
            return None
        flexibility = self.problem.flexibility
        return BalancingSpace(flexibility.preconditioner, flexibility.layout, self.problem.comm)

    def _extension(self) -> SmoothExtension | None:
        """The smooth extension of a set's field (:mod:`~roughcontact.operators.extension`) for this
        solve; None below ``CGSettings.extension_from`` nodes or without the edge correction."""
        if not self._taken_from(self.settings.extension_from):
            return None
        flexibility = self.problem.flexibility
        return SmoothExtension(flexibility.preconditioner, flexibility.layout, self.problem.comm)

    def _edge_weights(self, edges, nodes: np.ndarray, members: np.ndarray, single: bool,
                      correcting: bool, holes: HoleCharge | None) -> np.ndarray | None:
        """The edge correction's weights on the free set, given by ``nodes`` and as the mask
        ``members``, from the tracker ``edges`` (collective; None without the correction,
        ``correcting`` False); ``holes``' charge follows them, its holes labelled again where the
        weights took a product."""
        if not correcting:
            return None
        products = edges.products
        weights = edges.weights(nodes, members, single)
        if holes is not None:
            if edges.products != products or not holes.labelled:
                holes.relabel(members)
            holes.update(nodes, weights)
        return weights

    def _direction(self, g: np.ndarray, nodes: np.ndarray, single: bool, edge: np.ndarray | None,
                   loaded: bool, holes: HoleCharge | None,
                   coarse: BalancingSpace | None = None,
                   extension: SmoothExtension | None = None) -> tuple[np.ndarray, float]:
        """(z, gᵀz): the preconditioned gap on the free set ``nodes``, less its mean under load
        control (``loaded``) so that Σ p stays P along it; with the edge weights ``edge``, less
        ``holes``' charge (None: none), or with the set's smooth ``extension`` instead of both
        (None: none); in the balancing form around that preconditioner with the coarse space
        ``coarse``, made (None: none)."""
        def precondition(values):
            if extension is not None:
                return extension.apply(values, nodes, single)
            z = self._precondition(values, nodes, single, edge)
            if edge is not None and holes is not None:
                holes.subtract(values, z)
            return z

        z = precondition(g) if coarse is None else coarse.apply(g, nodes, precondition)
        if loaded:
            z -= self.problem.allmean(z)
        return z, float(self.problem.allsum(g @ z))

    def _precondition(self, g: np.ndarray, nodes: np.ndarray, single: bool,
                      edge: np.ndarray | None) -> np.ndarray:
        """z = M g on the free set ``nodes``: the Fourier preconditioner less the edge weights
        ``edge`` (on the same nodes; None: none)."""
        if self.settings.preconditioner == "none":
            return g.copy()
        return self.problem.flexibility.precondition_nodes(g, nodes, single, edge)

    def _state(self, forces, gap, iterations, residual, history) -> ContactState:
        contact = forces > 0.0
        slack = float(self.problem.allsum(forces[contact] @ gap[contact]))
        gap[contact] = 0.0
        return ContactState(forces, contact, gap, 1, iterations, residual, tuple(history), slack)


def _skip_corrections(holes: HoleCharge | None) -> None:
    """None, the edge weights of a set that takes the smooth extension, which replaces the edge
    correction and the hole charge: neither is made for it (their trackers catch up with the set
    on the next that takes them, the charge's rims labelled again). Along an ensemble task's
    sweep, the rotation free, the weights had taken 0.84–0.88 of 10.9–12.4 s at 513² and 2.8 of
    47 s at 1025² (docs/solver-cost.md, "M_T's passes, and the corrections it replaces")."""
    if holes is not None:
        holes.labelled = False
    return None


def _scale_to_energy(pb, forces: np.ndarray, displacement: np.ndarray, w: np.ndarray | None,
                     nodes: np.ndarray | None, pending=None) -> float:
    """Under displacement control, the forces p and their displacement H p rescaled in place (with
    the far fields ``pending`` defers) by the s > 0 that minimises the potential energy along p,
    Π(s p) = ½ s² pᵀHp − s pᵀw: s = pᵀw / pᵀHp (w = C r − gap0, Eq. 7; −gap0 where ``w`` is None).
    The counterpart of Polonsky & Keer's rescaling to P under load control: CG's cuts and
    restarts keep losing the forces' own scale, which this restores exactly (H is linear, and
    s p ≥ 0 where p ≥ 0). ``nodes``: every node where p may be nonzero on this rank (None: all).
    Where far fields are deferred, H p lacks them and s is the minimum of the energy the iteration
    holds. Returns s (1 where pᵀHp or pᵀw is not positive: nothing to gain along p); collective."""
    workers = pb.flexibility.workers
    imposed = -pb.gap0 if w is None else w         # −gap0 only at δz = 0 with no rotation: rare
    if nodes is None:
        p, hp = forces, displacement
    else:
        p, hp, imposed = (passes.gather(field, nodes, workers) for field in (forces, displacement, imposed))
    along_w = float(p @ imposed)
    curvature, along_w = pb.allsum(np.array([float(p @ hp), along_w]))
    if not (curvature > 0.0 and along_w > 0.0):
        return 1.0
    scale = float(along_w / curvature)
    if nodes is None:
        passes.scale(forces, scale, workers)
    else:
        p *= scale
        passes.scatter(forces, nodes, p, workers)
    passes.scale(displacement, scale, workers)
    if pending is not None:
        pending.rescale(scale)
    return scale


def _hold_back(free: np.ndarray, contact: np.ndarray, left: np.ndarray, squares: np.ndarray, iteration: int,
               scratch: np.ndarray, workers: int = 1) -> int:
    """Takes out of the free set (a mask, in place) the nodes out of the contact set that left it
    earlier in the solve and whose checkerboard square (``squares``, (i + j) mod 2) is not the
    iteration's parity (``CGSettings.alternate_return``); returns how many it took out of this
    rank's nodes. ``scratch``: a bool array of the nodes' size, overwritten; each pass on
    ``workers`` threads (:mod:`~roughcontact.operators.passes`)."""
    passes.combine(np.not_equal, squares, bool(iteration & 1), scratch, workers)   # the other colour
    passes.combine(np.logical_and, scratch, left, scratch, workers)
    passes.combine(np.greater, scratch, contact, scratch, workers)                 # ... and out of the set now
    passes.combine(np.logical_and, scratch, free, scratch, workers)
    passes.combine(np.greater, free, scratch, free, workers)
    return int(np.count_nonzero(scratch))


def _cleared(nodes: np.ndarray, size: int) -> np.ndarray | None:
    """What :func:`_clear` needs of a set of ``nodes`` among ``size``: the nodes, or None where the
    set is dense (:func:`~roughcontact.operators.convolution.dense`, the test the direction's
    product takes) and the field is zeroed whole. Near full contact the free sets hold most nodes,
    and zeroing all of 2048² took 0.31 / 0.84 ms where zeroing 86 % of it by index took 3.6 /
    3.7 ms (float32 / float64); the last set's indices are then not kept alive beside the new
    set's (7 B per node)."""
    return None if dense(nodes.size, size) else nodes


def _clear(field: np.ndarray, nodes: np.ndarray | None, workers: int = 1) -> None:
    """field[nodes] = 0; the whole field where ``nodes`` is None (:func:`_cleared`); on ``workers``
    threads."""
    if nodes is None:
        passes.fill(field, 0.0, workers)
    else:
        passes.scatter(field, nodes, 0.0, workers)


def _log_step(nodes: int, iteration: int, residual: float, changed, free, held, alpha: float,
              restarts: list[str]) -> None:
    """One step of a level's iteration at DEBUG: a readable line and the record's ``cg_step`` dict
    (the constrained CG's steps and the primal–dual active set's, whose restarts say so)."""
    _log.debug("n %d iteration %d residual %.3e changed %d free %d held %d alpha %.3g restart %s",
               nodes, iteration, residual, changed, free, held, alpha, "+".join(restarts) or "-",
               extra={"cg_step": {"nodes": int(nodes), "iteration": iteration, "residual": residual,
                                  "changed": int(changed), "free": int(free), "held": int(held),
                                  "alpha": float(alpha), "restart": list(restarts)}})
