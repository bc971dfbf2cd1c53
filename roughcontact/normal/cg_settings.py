"""The bound-constrained CG's settings (:class:`CGSettings`): its tolerances, its limits and its levers.

Each lever's docstring entry gives what it was measured to do on the
large-grid scene and near full contact (docs/solver-cost.md has the runs).
The solver itself is :class:`~.constrained_cg.ConstrainedCGSolver`. The
constants named below are its own (SINGLE_FLOOR, DEFER_NODES, DEFER_FROM,
in :mod:`.constrained_cg`), the nested start's (COARSE_TOL, :mod:`.nested`)
and the preconditioner's (EDGE_UPDATES, HOLE_BLOCK, HOLE_SPAN, DUST,
BALANCING_PARTS, BALANCING_SHARE, EXTENSION_BOUNDARY, in :mod:`roughcontact.operators`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..checks import check_closed_interval
from ..errors import InputError
from ..operators.balancing import BALANCING_FROM
from ..operators.extension import EXTENSION_FROM
from ..operators.preconditioner import EDGE_SHARE

PRECONDITIONERS = ("fourier", "none")
PRECISIONS = ("mixed", "double")

#: the levels (nodes) from which a start with much of the level in contact settles its set by the
#: primal–dual active set (``CGSettings.primal_dual_from``)
PRIMAL_DUAL_FROM = 512 * 512
#: the share of a level's nodes in contact from which its start (fresh or warm) settles its set by the
#: primal–dual active set (``CGSettings.primal_dual_share``). Along an ensemble task's load sweeps
#: with the rotation fixed (warm starts, 513² and 1025²), each load against the constrained CG's
#: time: from a quarter of the nodes 0.50–0.92 but one load (1.14); below it 0.75–1.14 over two runs,
#: and fresh starts lost at 2 % and below (docs/solver-cost.md, "The primal–dual steps from a quarter
#: of the nodes in contact")
PRIMAL_DUAL_SHARE = 0.25
#: the same share for a warm start (a neighbour's solution: the next load or closure of a sweep)
#: (``CGSettings.primal_dual_warm_share``): any. With the preconditioner on the set's smooth extension
#: the steps from any warm start took 0.84 / 0.89 of the quarter's time along an ensemble task's
#: 513² sweeps with the rotation fixed, 0.93 at 1025², its closures 0.94, the Newton's first
#: evaluations 0.975 (docs/solver-cost.md, "The quarter's rule with the extension")
PRIMAL_DUAL_WARM_SHARE = 0.0
#: the levels (nodes) from which a free rotation is found with the forces (any start, any share in contact)
#: by the primal–dual steps (``CGSettings.rotation_from``): every level
ROTATION_FROM = 1


@dataclass(frozen=True)
class CGSettings:
    """Tolerances and limits of the bound-constrained CG.

    tol
        The contact conditions hold when |g| ≤ tol · (scale of w) on S and
        g ≥ −tol · (scale of w) off S; the loads hold to round-off.
    max_iterations
        CG iterations allowed before raising.
    preconditioner
        ``"fourier"`` (default) or ``"none"`` (Polonsky & Keer's original).
    refresh
        Recompute H p from scratch every this many iterations without a change
        of S (otherwise it is updated by the step, which accumulates round-off).
    restart
        Restart the conjugate directions where the new gap is far from
        orthogonal to the last preconditioned one, |g_kᵀ z_{k−1}| ≥
        ``restart`` · g_kᵀ z_k (Powell's test; on a fixed set CG keeps
        g_kᵀ z_{k−1} = 0): a change of the free set spoils conjugacy in
        proportion to what it changes in the gap, not to how many nodes it
        moves. It replaced a restart when more than 1 % of the set changed,
        which near full contact (Δ = 2.5, 1 E*; sets of 3.6 M nodes at
        2048²) let 10–40 k nodes change per iteration without a restart while
        the residual rose from 8e-4 to 2e-2, and restarted through the first
        39 iterations. Fine iterations (coarse in brackets), 1 % of the set →
        Powell's test at 0.2: near full contact 256² / 512² / 1024² / 2048²
        31 / 40 / 56 / 147 (84) → 32 / 38 / 44 / 63 (30); the large-grid
        scene 512² to 2048² 15 / 17 / 25 both, 4096² 39 (20) → 36 (15); the
        stability map 2928 → 2781 iterations, 120 / 120 converged, no cell
        above 1.09 times. 0.1 / 0.3 / 0.5: near full contact at 1024² 47 /
        48 / 51, the scene at 2048² 25 / 25 / 31. Both tests together (1 %
        and 0.2): near full contact at 2048² 80; 5 % and 0.2: 71, 4096² 35.
        Polak–Ribière's β (which also weighs g_kᵀ z_{k−1}) instead of
        Fletcher–Reeves': no fewer anywhere.
    renew
        Also restart on an iteration whose free set changed once this many
        iterations have passed since the last such restart (or one at a
        convergence check): small changes that each pass ``restart``
        otherwise accumulate into directions that are far from conjugate,
        and the iteration crawls even after the set has settled (at 2048²,
        0.83 per iteration for 15 iterations on a fixed set; 57 iterations
        where renewing every 8 took 28). It made no difference from 256² to
        1024². Powell's restarts do not reset this count: resetting it took
        near full contact at 1024² / 2048² 44 / 63 → 48 / 68 fine
        iterations and the scene at 2048² 25 → 27. The renewal waits for a
        change of the set: restarting 8 iterations after any change, also
        on a set that had stopped changing, threw away directions conjugate
        on it (near full contact at 1024², a restart 4 iterations after the
        last change took the residual from 4.7e-8 to 3.1e-8 and 2.4e-8 in
        the next two). Near full contact at 1024² / 2048² 38 / 55 → 36 / 53
        fine iterations, the scene at 1024² / 2048² / 4096² 17 / 24 / 32
        both; the stability map 2201 → 2170, 120 / 120, per cell 0.92–1.07.
    load_tol, max_newton
        Free rotation: the moment residual allowed (relative to P times the
        footprint's half-size) and the Newton steps on (θx, θy) (:mod:`.rigid_motion`).
    edge_share
        The share of the Fourier preconditioner's edge term removed on the
        boundary nodes of the free set (:mod:`~roughcontact.operators.preconditioner`;
        0 for the plain R_S C⁻¹ R_Sᵀ). Its weights follow the free set: one
        periodic product where it changed by more than one node in 1000, else
        windows of C⁻¹ around the nodes that changed
        (:class:`~roughcontact.operators.preconditioner.EdgeWeights`). Whole solves of the
        large-grid scene (fine iterations, 0 → 0.8): 256² 16 → 14,
        512² 19 → 15, 1024² 22 → 17, 2048² 35 → 27, 4096² 54 → 42; near
        full contact (Δ = 2.5, 1 E*) 46 → 34, 70 → 44, 81 → 71 (256² to
        1024²). Where the residual reaches no new lowest value for 2 × ``renew``
        iterations above SINGLE_FLOOR (the free set cycling: near full contact
        at 1024², Δ = 2.8) the rest of the solve takes the plain one.
        docs/solver-cost.md, "The edge correction".
    hole_block
        The side (nodes) of the blocks on which the preconditioner takes back
        the edge charge left on the rims of holes, the parts of the outside of
        the free set that touch no edge of the grid
        (:mod:`~roughcontact.operators.holes`); 0: not taken back. Taken on
        the iterations whose free set changes by at most one node in
        EDGE_UPDATES, the directions restarting where it starts or stops:
        taken while the set moved, near full contact at 1024² wandered (61
        fine iterations against 36). The holes and rims are found again
        where the charge starts and whenever the edge weights take a
        product while it is taken (finding them again only on a product
        left rims found before the set last moved: the same counts on the
        scenes below, the residual at the end 6.22e-9 → 6.57e-9 on the
        scene at 2048²). Whole solves near full
        contact (Δ = 2.5, 1 E*), 0 → 64: 256² 20 → 18, 512² 26 → 23, 1024²
        36 → 32, 2048² 53 → 44; the large-grid scene 24 → 23 at 2048², 32 →
        31 at 4096²; the stability map 2170 → 2108, 120 / 120. Where the
        holes hold most of the outside (near full contact,
        :data:`~roughcontact.operators.holes.DUST`) the blocks that are
        mostly holes take it on all their nodes of the set: near full contact
        256² to 4096² 18 / 22 / 29 / 37 / 52 → 19 / 21 / 27 / 34 / 48, the
        scene unchanged; the stability map 2081 → 2070, 120 / 120.
        None (the default): HOLE_BLOCK = 64, or the grid's longer side over
        HOLE_SPAN = 32 where that is more
        (:func:`~roughcontact.operators.holes.block_side`).
    defer
        The far fields of the forces a cut restores wait (only their near
        field, 32 nodes around each, is added to H p at once) while
        ``far_bound`` × their sum, the most they can add to the gap of any
        node, stays at most ``defer`` × the root mean square of the gap on the
        free set; then one product settles them all with the cut that passed
        the bound (:mod:`~roughcontact.operators.near_field`). An exact H p
        (a refresh) forgets them. At most one node in DEFER_NODES waits, and
        only on grids of DEFER_FROM nodes or more. 0: every cut takes its
        product at once. Padded products of whole solves
        (fine iterations), 0 → 1: the large-grid scene at 512² 21 → 18 (15 →
        15), 1024² 26 → 22 (17 → 17), 2048² 46 → 34 (27 → 26), 4096² 75 → 63
        (42 → 41); near full contact (Δ = 2.5, 1 E*) 512² 60 → 52 (44 →
        44), 1024² 118 → 101 (69 → 68). A bound of 0.25 × the largest gap
        error instead (the residual) let 4096² wander for 35 iterations (80
        against 42): the far fields reach every node, the residual only a few.
        Where a confirmation of convergence fails with far fields deferred,
        the rest of the solve settles every cut at once (still in single
        precision: the deferred fields, not the precision, may have failed it).
    precision
        ``"mixed"`` (default): the product H d of each search direction, the
        product H c of the forces a cut restores, and the preconditioner in
        single precision (0.5–0.7 of the time of a double FFT product,
        :mod:`~roughcontact.operators.convolution`); the products H p of the
        forces themselves — the first, every ``refresh`` and the confirmation
        of convergence — in double, except on the coarse levels of a nested
        start with the rotation fixed (tolerance COARSE_TOL): there a single
        product's error is 1000 times below the tolerance. The error of a
        single product, ~1e-7 of its scale, enters the gap only through the
        increments α H d and H c, which shrink with the residual; the
        residual a solve reports is measured on a double H p, so the
        precision cannot loosen it. These errors pile up in the updated H p
        with the size of the steps since the last exact one, and the first
        steps are of the size of the starting gap: H p is taken again in
        double once, when the residual first reaches SINGLE_FLOOR, so that
        only the errors of the later, smaller steps remain. Near full contact
        (Δ = 2.5, 1 E*) the residual stalled at 4e-8 for 8 iterations at
        1024² without it (256² / 512² / 1024² 35 / 43 / 64 → 31 / 40 / 56
        fine iterations; 2048² 146 → 147); the stability map 3210 → 2928
        iterations, no cell more (benchmarks/bench_stability.py).
        Where that fails the rest of the solve is taken in double: when the
        residual has not reached a new lowest value for ``renew``
        iterations once it is below SINGLE_FLOOR (1e-5; near full contact the
        single products stall it at ~1e-7; above that a rise is the contact
        set settling) or for 4 × ``renew`` iterations anywhere, or when the
        exact confirmation of convergence
        disagrees with the updated gap (tolerances near 1e-11).
        ``"double"``: every product in double precision.
    alternate_return
        A node that has left the contact set during the solve comes back
        into the free set only on every other iteration, by the colour of
        its square on the grid's checkerboard ((i + j) mod 2 against the
        iteration's parity): two side-by-side nodes that left never come back
        in the same iteration. After a nested start the set churns more than
        it moves: near full contact at 1024² (Δ = 2.5, 1 E*) the fine level's
        contact set took 183 k entries and exits for a net change of 41 k
        nodes; 49 k nodes changed twice or more, and from the third step on
        98–100 % of the nodes entering had left before. Nodes entering for
        the first time are not held: from a cold start the set must grow
        (holding every entering node every other iteration took the
        stability map's 64² / 128² cold solves from 293 / 376 to 336 / 448
        fine iterations). Fine iterations, off → on: near full contact 256²
        / 512² / 1024² / 2048² 18 / 23 / 32 / 44 → 18 / 22 / 29 / 37; the
        large-grid scene 256² to 4096² 14 / 14 / 17 / 23 / 31 → 14 / 15 /
        17 / 21 / 31 (coarse at 4096² 16 → 14); the stability map 2108 →
        2082, 120 / 120, per cell 0.72–1.20, at 1024² 597 → 561. The step
        scaled by 0.99 or 1.01 where the set changed moved the counts by at
        most 1 (near full contact at 1024² and 2048², the scene at 4096²;
        docs/solver-cost.md, "Nodes that leave and come back").
    balancing_from
        Levels of at least this many nodes add the balancing coarse space on
        BALANCING_PARTS² blocks of the set (:mod:`~roughcontact.operators.balancing`):
        P = Z E⁻¹ Zᵀ + (I − Z E⁻¹ Wᵀ) M (I − W E⁻¹ Zᵀ) around the preconditioner M,
        with W = C Z made by one periodic product per block where the hole
        charge is first taken. Only on a free set of at most BALANCING_SHARE of
        the grid's nodes, and in solves from a fresh start (a coarse grid's or
        the punches'), whose free-rotation evaluations share it; a warm start
        has little left to settle. Only with the hole charge (``hole_block`` not
        0) and the edge correction. None: never. The large-grid scene, fine iterations
        (one rank): 4096² 29 / 30 / 25 → 25 / 25 / 23 on three surfaces (with
        the space from 2048² up, 2048² 21 → 20 and no faster); near full
        contact no space is made (docs/solver-cost.md, "A balancing coarse
        space on blocks of the set").
    extension_from
        Levels of at least this many nodes precondition a set whose nodes lie
        mostly on its boundary (EXTENSION_BOUNDARY of them or more with a
        4-neighbour outside it: a dust of small islands) by the Fourier
        preconditioner applied to a smooth extension of the set's field,
        M_T = Eᵀ C⁻¹ E (:mod:`~roughcontact.operators.extension`), instead of
        the edge correction and the hole charge, wherever the hole charge
        would be taken: on the constrained CG's set once it changes by one
        node in EDGE_UPDATES or fewer, and on every set the primal–dual steps
        hold. Only with the hole charge (``hole_block`` not 0) and the edge
        correction. None: never. An ensemble task's 12-load sweeps (seed 1,
        fine iterations, rotation fixed / free): 203 / 298 → 163 / 227 at
        65², 282 / 403 → 217 / 282 at 129², 388 / 550 → 290 / 354 at 257²,
        in 0.67–0.90 of the time; 619 / 755 → 415 / 462 at 513², 823 / 961
        → 542 / 576 at 1025², in 0.73–0.83, and 1114 / 1276 → 709 / 747 at
        2049², in 0.70–0.75 (one run). The default study's 24 tasks (65²)
        in 0.71–0.75 of the time; 12-load tasks at 17²–48² (below 64², the
        fine level alone) in 0.64–0.86. The large-grid scenes' sets (2 % and
        87 % in contact, on a few large islands) keep their counts, 64² to
        4096² (docs/solver-cost.md, "The preconditioner on the set's smooth
        extension", "The extension from 64²" and "… from 16²").
    primal_dual_from
        Levels of at least this many nodes whose start (a coarse grid's, the
        punches' or a neighbour's) holds at least ``primal_dual_share`` of
        their nodes in contact settle the set by the primal–dual active set first
        (:mod:`.primal_dual`): each set held while the CG solves on it to a
        share of its residual, then moved at once; where that gives up
        (a set cycling) the constrained CG goes on from its forces. With the
        rotation free, where the steps that find it gave up (or with
        ``rotation_from=None``, or on levels below it), the Newton's first
        evaluation, fresh or warm (the later ones go to the constrained CG): near full contact at 2048² 39.6 s against
        42.7 s, 72 fine iterations against 74 (medians of 2, alternated), at
        1024² 10.9 s against 11.2 s (3). None: never. Near full contact (Δ =
        2.5, 1 E*, seed 1), CG steps / sets (fine iterations, which count
        each set's exact H p too) against the
        constrained CG's fine iterations: 512² 21 / 6 (28) against 21, 1024²
        24 / 6 (31) against 27, 2048² 27 / 7 (35) against 34, 4096² 33 / 8
        (42) against 47. One rank, the two alternated in one process: 512²
        0.74 s against 0.86 s, 1024² 3.0–3.2 s against 3.6–3.8 s, 2048²
        15.1–16.6 s against 19.9–20.6 s (three surfaces), 4096² 85 s against
        158 s; the large-grid scene's sparse starts never take it
        (docs/solver-cost.md, "The contact set settled by a primal–dual
        active set").
    primal_dual_share
        The share of a level's nodes in contact at a fresh start (warm starts:
        ``primal_dual_warm_share``; the figures below took it for both)
        from which ``primal_dual_from`` settles the set first, 0–1. An
        ensemble task's 12-load sweep with the rotation fixed, each load
        started from the last one's solution (``python -m
        benchmarks.bench_settling``, one rank, alternated with
        ``primal_dual_from=None``): 0.86 / 0.90 of the constrained CG's time
        at 513² and 0.85 / 0.87 at 1025² (seeds 1 / 2), the loads started
        from 29–86 % in contact at 0.50–0.92 of its time but one (1.14, from
        31 %), those from 68–86 % at about half of it. Their sets settle
        where the constrained CG's directions keep restarting on a moving
        set, and the steps take no second product for the forces a cut
        restores. Fresh starts of the large-grid scene's surface at 0.3 E*
        (43–45 % in contact): 0.82–0.89 at 512² and 1024². Below a quarter
        (``primal_dual_share=0``) fresh starts lost at 0.003 and 0.01 E*
        (1–2 % in contact: 1.01–1.28), were even at 0.03 E* (6 %:
        0.89–1.10) and a little ahead at 0.1 E* (17–18 %: 0.83–0.99), and warm
        ones along the sweeps took 0.75–0.99 of the time in one run and
        0.90–1.14 in another: one rule for both starts was kept. Before,
        0.5 and fresh starts only (docs/solver-cost.md, "The
        primal–dual steps from a quarter of the nodes in contact"). The same
        task's closures (displacement control, the forces rescaled by
        ``energy_scale``): 0.81–0.94 of the time; its loads with the
        rotation found by the Newton alone (``rotation_from=None``, the
        first evaluation of each load): 0.72–0.97 (docs/solver-cost.md,
        "The forces' scale under displacement control").
    primal_dual_warm_share
        ``primal_dual_share`` for a warm start (the last solution of the
        same solver: a sweep's next load or closure), 0–1; ``primal_dual_share``
        then decides fresh starts (a coarse grid's or the punches') alone.
        With the preconditioner on the set's smooth extension, the steps from
        any warm start (0, the default) against the quarter (``python -m
        benchmarks.bench_settling --parts sweeps --steps``, one rank,
        alternated, medians of 3): an ensemble task's load sweeps with the
        rotation fixed 0.84 / 0.89 of the time at 513² (seeds 1 / 2) and 0.93
        at 1025², its warm loads below a quarter 0.67–1.04; its closures 0.94
        and the Newton's first evaluations (``rotation_from=None``) 0.975 at
        513² (docs/solver-cost.md, "The quarter's rule with the extension").
    rotation_from
        Under load control with the rotation free, levels of at least this
        many nodes find (δz, θx, θy) with the forces, from any start (a
        coarse grid's, the punches' or a neighbour's) and at any share in
        contact: the primal–dual steps with the moments as two more
        constraints of each set's solve (:mod:`.primal_dual`), instead of
        the Newton on θ around solves at a fixed rotation
        (:mod:`.rigid_motion`: two or more evaluations and Hessians). Where
        those steps give up (a set that cannot hold the moments, or that
        cycles), the Newton goes on from their forces. None: never. One
        rank, alternated processes against the Newton: the large-grid
        scene (2 % in contact) 0.57 / 0.55 / 0.52 of the time at 1024² /
        2048² / 4096² (4096²: 23.7 s against 45.6 s); an ensemble task's
        12-load sweeps 0.42–0.51 at 257² and 513²; near full contact (Δ =
        2.5, 1 E*) fine + coarse iterations and seconds:
        1024², seeds 1–3, 29 + 21, 26 + 18 and
        26 + 21 against 58 + 44, 57 + 42 and 55 + 43, medians 1.76–2.01 s
        against 3.37–3.90 s; 2048² 32 + 22 against 65 + 52, 9.2 / 9.5 s
        against 17.6 / 17.8 s; 4096² 39 + 22 against 78 + 56, 49.8 s against
        92.7 s. On 256² and 512² maps of three Δ at 1e-4 to 1e-2 E* (0.03–2
        % in contact) 0.76–1.03 and 0.64–0.87. On every level (the
        default, 1), the two alternated in one process: the ensemble task's
        12-load sweeps (seeds 1–10, medians of 3) 0.57–0.87 / 0.53–0.76 /
        0.49–0.60 / 0.50–0.56 of the time at 17² / 33² / 65² / 129²; the
        few-node map (fresh solves at 1e-5 to 2e-4 E*, 17²–129², 3–1430
        nodes in contact) 0.43–0.72 where the median contact holds 6
        nodes or more, 0.99–1.06 on contacts of 3–4 nodes, whose sets
        mostly cannot carry the moments (the steps give up at once for the
        Newton); the states the active set's to 3.6e-7 of the largest force
        (docs/solver-cost.md, "A free rotation found with the forces").
        The steps' products count against ``max_iterations``, as the
        constrained CG's iterations do: each solve's steps, and where they
        give up each solve of the Newton that goes on, have that bound.
    energy_scale
        Under displacement control, the constrained CG rescales the forces
        at its start and after every step to the minimum of the potential
        energy along them, Π(s p) = ½ s² pᵀHp − s pᵀw at s = pᵀw / pᵀHp:
        the counterpart of Polonsky & Keer's rescaling to P under load
        control, for the mode CG otherwise keeps losing at its cuts and
        restarts, the forces' own scale. Exact (H is linear, the bounds
        hold for s > 0): two dot products on the free set and a pass over
        H p a step. An
        ensemble task's 12 closures (the closures of its load sweep, each
        started from the last one's solution, the constrained CG alone, one
        rank): 821 / 818 → 589 / 587 fine + coarse iterations at 513² and
        1254 / 1117 → 789 / 757 at 1025² (seeds 1 / 2); at 513² 13.5 / 13.4
        s against 17.3 / 19.2 s, alternated, medians of 3 (docs/solver-cost.md, "The forces' scale under displacement
        control"). False: no rescaling (Polonsky & Keer's CG has none under
        displacement control).
    """

    tol: float = 1e-8
    max_iterations: int = 5000
    preconditioner: str = "fourier"
    refresh: int = 50
    restart: float = 0.2
    renew: int = 8
    load_tol: float = 1e-8
    max_newton: int = 50
    precision: str = "mixed"
    edge_share: float = EDGE_SHARE
    hole_block: int | None = None
    defer: float = 1.0
    alternate_return: bool = True
    balancing_from: int | None = BALANCING_FROM
    extension_from: int | None = EXTENSION_FROM
    primal_dual_from: int | None = PRIMAL_DUAL_FROM
    primal_dual_share: float = PRIMAL_DUAL_SHARE
    primal_dual_warm_share: float = PRIMAL_DUAL_WARM_SHARE
    rotation_from: int | None = ROTATION_FROM
    energy_scale: bool = True

    def __post_init__(self):
        if self.preconditioner not in PRECONDITIONERS:
            raise InputError("preconditioner", f"must be one of {', '.join(PRECONDITIONERS)}, "
                                               f"got {self.preconditioner!r}")
        if self.precision not in PRECISIONS:
            raise InputError("precision", f"must be one of {', '.join(PRECISIONS)}, got {self.precision!r}")
        if not 0.0 <= self.restart:
            raise InputError("restart", f"must be >= 0 (Powell's test: the directions restart where |g_kᵀ "
                                        f"z_k-1| >= restart · g_kᵀ z_k; 0: every step), got {self.restart!r}")
        if not 0.0 <= self.defer < np.inf:
            raise InputError("defer", f"must be a finite share >= 0 of the gap's root mean square (0: "
                                      f"every cut takes its product at once), got {self.defer!r}")
        if not 0.0 <= self.edge_share < 1.0:
            raise InputError("edge_share", f"must be in [0, 1) (1 removes the whole edge term and leaves "
                                           f"isolated nodes without a scaling), got {self.edge_share!r}")
        for name in ("alternate_return", "energy_scale"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise InputError(name, f"must be True or False, got {getattr(self, name)!r}")
        _check_optional_count("hole_block", self.hole_block, 0, "the grid's own",
                              "the side of the blocks of the hole charge, 0: none")
        _check_optional_count("balancing_from", self.balancing_from, 1, "no coarse space",
                              "the nodes from which a level takes it")
        _check_optional_count("extension_from", self.extension_from, 1, "never",
                              "the nodes from which a level takes it")
        _check_optional_count("primal_dual_from", self.primal_dual_from, 1, "never",
                              "the nodes from which a level takes it")
        object.__setattr__(self, "primal_dual_share", check_closed_interval(
            "primal_dual_share", self.primal_dual_share, 0.0, 1.0,
            " (the share of a level's nodes in contact from which its start settles the set first)"))
        object.__setattr__(self, "primal_dual_warm_share", check_closed_interval(
            "primal_dual_warm_share", self.primal_dual_warm_share, 0.0, 1.0,
            " (the share of a level's nodes in contact from which a warm start settles the set first)"))
        _check_optional_count("rotation_from", self.rotation_from, 1, "never",
                              "the nodes from which a level finds a free rotation with the forces")


def _check_optional_count(name: str, value, minimum: int, none: str, meaning: str) -> None:
    """``value`` is None (``none``) or an integer ≥ ``minimum`` (``meaning``), not a bool."""
    if value is None or (isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))
                         and value >= minimum):
        return
    raise InputError(name, f"must be None ({none}) or an integer >= {minimum} ({meaning}), got {value!r}")
