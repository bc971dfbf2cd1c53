"""One task of a study: a composite topography, its load sweep, tangential sweeps and fretting.

A :class:`Task` is a small, picklable, pure description; :func:`solve_task`
needs only the communicator it is handed (the ranks of one group of the
farm, or any communicator when called by hand). The normal problem and its
solver are opened in one place, :func:`open_normal_solver`, which is where
a study's ``[normal]`` choices (:class:`NormalOptions`) reach the solvers.
"""
from __future__ import annotations

import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field
from dataclasses import fields as dataclass_fields
from pathlib import Path
from typing import Any

from ..checks import check_choice
from ..errors import RoughContactError, TaskTimeout
from ..materials import Interface
from ..normal.choice import METHODS as _NORMAL_METHODS
from ..operators.memory import KINDS
from ..surfaces.topography import Topography

#: flexibility operators a study's ``normal.operator`` may name (built in :func:`open_normal_solver`;
#: "auto": :func:`roughcontact.normal.choice.choose_operator`)
OPERATORS = ("auto", *KINDS)
#: normal methods (``normal.method``, :func:`roughcontact.normal.make_solver`; "auto":
#: :func:`roughcontact.normal.choice.choose_method`)
METHODS = ("auto", *_NORMAL_METHODS)


@dataclass(frozen=True)
class NormalOptions:
    """How each normal problem is assembled and solved: ``operator``, ``method`` and the rotation.

    ``rotation`` None lets θ follow from zero moments about the footprint's
    centroid (load control only); a pair (θx, θy) in rad fixes it (Eq. 7),
    the moments then being outputs (the centroid path G_P of Fig. 11).
    """

    operator: str = "auto"
    method: str = "auto"
    rotation: tuple[float, float] | None = None

    def __post_init__(self):
        check_choice("normal.operator", self.operator, OPERATORS)
        check_choice("normal.method", self.method, METHODS)

    def solve(self, solver, control: str, value: float, gather: bool = True):
        """The normal solution at ``value`` (SI) of ``control``: ``"closure"`` (δz, m) or a load (P, N);
        ``gather=False``: each rank keeps its own rows of the fields (:mod:`roughcontact.normal.fields`)."""
        if control == "closure":
            return solver.solve_closure(value, self.rotation or (0.0, 0.0), gather=gather)
        return solver.solve_load(value, rotation=self.rotation, gather=gather)


@dataclass(frozen=True)
class TangentialOptions:
    """Tangential sweeps Q = k fP / N (k = 0 … N − 1, then the limit Q → fP) at some loads.

    ``at`` holds indices into the task's loads; ``fretting_amplitude`` is Q*/(fP)
    of an optional fretting cycle at the same loads, ``fretting_steps`` its
    intervals per branch.
    """

    friction: float
    steps: int
    at: tuple[int, ...]
    fretting_amplitude: float | None = None
    fretting_steps: int = 10


@dataclass(frozen=True)
class FrettingOptions:
    """The fretting map (:func:`~roughcontact.tangential.fretting_map`) at some loads.

    One cycle +Q* → −Q* → +Q* at each ``amplitudes`` value Q*/(fP) (increasing,
    the amplitude stepped up), ``steps`` intervals on the way to each +Q*;
    ``at`` holds indices into the task's loads.
    """

    friction: float
    amplitudes: tuple[float, ...]
    steps: int
    at: tuple[int, ...]


@dataclass(frozen=True, kw_only=True)
class Loading:
    """What every task of a study is asked, held by the study and by each of its tasks.

    ``loads`` are the controls of the normal problem: P (N) when ``load_dim``
    is ``"normal_load"``, nominal pressures σ0 = P/A0 (Pa) when it is
    ``"mean_pressure"``, closures δz from first touch (m, Eq. 7) when it is
    ``"closure"``; ``normal``,
    ``tangential`` and ``fretting`` say how they are solved, ``fields`` what
    is stored (:data:`roughcontact.datasets.FIELDS`).
    """

    loads: tuple[float, ...]
    load_dim: str = "normal_load"
    normal: NormalOptions = field(default_factory=NormalOptions)
    tangential: TangentialOptions | None = None
    fretting: FrettingOptions | None = None
    fields: str = "contact"

    def loading(self) -> dict[str, Any]:
        """These fields by name (what a study hands each of its tasks)."""
        return {f.name: getattr(self, f.name) for f in dataclass_fields(Loading)}


@dataclass(frozen=True)
class Task(Loading):
    """Everything one task needs, and nothing else (pickled to the rank that solves it).

    ``position`` is its index along each study dimension, ``labels`` the axis
    values that made it, ``index`` its number in the study's order; ``key``
    (:func:`~.definition.task_key`) names what it computes, and its file. The
    loads and options are those of :class:`Loading`.
    """

    index: int
    position: tuple[int, ...]
    labels: dict[str, Any]
    surface: dict[str, Any]
    interface: Interface
    key: str = ""

    @property
    def name(self) -> str:
        """A label for messages: the task number and its axis values."""
        values = ", ".join(f"{k}={_short(v)}" for k, v in self.labels.items())
        return f"task {self.index}" + (f" ({values})" if values else "")

    def topography(self) -> Topography:
        """The composite topography Δh (identical on every rank).

        Steps, each optional after the first: generate or read the surface;
        decimate it by ``coarsening`` (the same surface at s, 2s, 4s…, Fig. 1);
        detrend it; restrict it to a disc footprint (a cylindrical specimen,
        §3.4); form the composite with its mate shifted by v (Fig. 7).
        """
        from ..surfaces import coarsen, detrend, disc, mated_composite

        spec = dict(self.surface)
        generator = spec.pop("generator")
        factor = spec.pop("coarsening", None)
        mode = spec.pop("detrend", None)
        shift = spec.pop("mate_shift", None)
        diameter = spec.pop("footprint_diameter", None)
        topography = generators()[generator](**spec)
        if factor is not None and factor != 1:
            topography = coarsen(topography, factor)
        if mode is not None:
            topography = detrend(topography, mode)
        if diameter is not None:
            topography = topography.with_footprint(
                topography.footprint & disc(topography.shape, topography.spacing, diameter))
        if shift is not None:
            topography = mated_composite(topography, tuple(shift))
        return topography


def generators() -> dict[str, Any]:
    """The surface generators a study's ``surface.generator`` may name."""
    from ..surfaces import fourier_surface, midpoint_surface, read_topography

    return {"midpoint": midpoint_surface, "fourier": fourier_surface, "file": read_topography}


@contextmanager
def open_normal_solver(topography: Topography, interface: Interface, comm, options: NormalOptions):
    """The normal problem of ``topography`` on ``comm`` and its solver, both freed on exit.

    The one place where a study's ``[normal]`` choices reach the solvers:
    ``options.operator`` names the flexibility operator H (Eq. 10) of
    :class:`~roughcontact.normal.NormalProblem`, ``options.method`` the solver
    (:func:`~roughcontact.normal.make_solver`). Yields the solver
    (``solver.problem`` is the problem).
    """
    from ..normal import NormalProblem, make_solver

    with NormalProblem(topography, interface, comm, operator=options.operator) as problem:
        with make_solver(problem, options.method) as solver:
            yield solver


@dataclass
class TaskOutcome:
    """What solving a task produced, on every rank of its communicator.

    ``normal`` holds the solved loads in order, each with only the fields the
    task stores (``task.fields``; the others None: the whole result served the
    load's tangential solves first); after a failure (``error``), the loads
    solved before it. ``loads`` are the normal loads P (N) of
    those solutions: the imposed ones under load control, the solved ones
    under closure control. ``sweeps`` and ``cycles`` are keyed by the index
    of the load they were run at, as are ``fretting_maps``.
    """

    task: Task
    topography: Topography | None = None
    loads: list = field(default_factory=list)
    normal: list = field(default_factory=list)
    incipient_energy: list = field(default_factory=list)
    sweeps: dict = field(default_factory=dict)
    cycles: dict = field(default_factory=dict)
    fretting_maps: dict = field(default_factory=dict)
    error: str | None = None
    warnings: tuple[str, ...] = ()
    elapsed: float = 0.0
    ranks: int = 1


def solve_task(task: Task, comm, timeout: float | None = None) -> TaskOutcome:
    """Solve ``task`` on the ranks of ``comm``: each load warm-started from the last (§3.1).

    With ``task.tangential``, every load also gets the incipient-sliding energy
    E_tot (Eq. 27) and the chosen loads a Q sweep (Eqs. 21–26) and a fretting
    cycle. A :class:`~roughcontact.errors.RoughContactError` (bad input met
    inside the task, a solver that does not converge) ends the task: the
    outcome keeps what was solved before it and the message. Warnings are
    recorded with the outcome, not printed.

    ``timeout`` (s) ends the task with a :class:`~roughcontact.errors.TaskTimeout`
    at the first load boundary past it (:func:`_check_deadline`): the solve of a
    load is never cut short, so every number kept is a converged one.
    """
    from ..datasets import keep_fields
    from ..normal import gather_result

    t0 = time.perf_counter()
    outcome = TaskOutcome(task=task, ranks=comm.Get_size())
    # a task without tangential work on several ranks solves on rows: its first rank makes the surface
    # and hands out the rows, and receives the fields the task stores; no other rank holds N values
    by_rows = task.tangential is None and task.fretting is None and comm.Get_size() > 1
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            topography = _surface_by_rows(task, comm, outcome) if by_rows else task.topography()
            if not by_rows:
                outcome.topography = topography
            scale = topography.nominal_area if task.load_dim == "mean_pressure" else 1.0
            with open_normal_solver(topography, task.interface, comm, task.normal) as solver:
                problem = solver.problem
                for i, control in enumerate(task.loads):
                    if i:
                        _check_deadline(comm, t0, timeout, i, len(task.loads))
                    normal = task.normal.solve(solver, task.load_dim, float(control) * scale, gather=not by_rows)
                    if by_rows:
                        normal = gather_result(keep_fields(normal, task.fields), problem, root=0)
                    outcome.normal.append(normal)
                    load = normal.load if task.load_dim == "closure" else float(control) * scale
                    outcome.loads.append(load)
                    try:
                        _tangential_at(task, i, problem, normal, load, outcome)
                    finally:
                        # what the task stores of this load, once the whole result has served: every
                        # field kept was 25 B/node per load on every rank (8 loads at 2048²: 0.8 GB a
                        # rank); nothing else refers to the whole result during the next load's solve
                        outcome.normal[-1] = keep_fields(normal, task.fields)
                        del normal
        except RoughContactError as exc:
            outcome.error = f"{type(exc).__name__}: {exc}"
    outcome.warnings = tuple(dict.fromkeys(f"{w.category.__name__}: {w.message}" for w in caught))
    outcome.elapsed = time.perf_counter() - t0
    return outcome


def _surface_by_rows(task: Task, comm, outcome: TaskOutcome):
    """Rank 0 makes the task's surface (kept in ``outcome.topography`` there, for the task's file) and
    hands every rank its rows; a failure to make it raises the same error on every rank."""
    from ..surfaces import TopographyRows
    from .executor import on_root

    def make() -> None:                     # the surface stays on rank 0: nothing is broadcast
        outcome.topography = task.topography()

    on_root(comm, make)
    return TopographyRows.scatter(outcome.topography, comm)


def _tangential_at(task: Task, i: int, problem, normal, load: float, outcome: TaskOutcome) -> None:
    """What the task asks at its load ``i`` besides the normal solve: the fretting map, the
    incipient-sliding energy, the tangential sweep and the fretting cycle (into ``outcome``)."""
    from ..tangential import fretting_cycle, fretting_map, incipient_sliding_energy, tangential_loads, tangential_sweep

    tangential = task.tangential
    if task.fretting is not None and i in task.fretting.at:
        outcome.fretting_maps[i] = fretting_map(
            problem, normal, task.fretting.friction, task.fretting.amplitudes,
            task.fretting.steps, method=task.normal.method)
    if tangential is None:
        return
    f = tangential.friction
    outcome.incipient_energy.append(incipient_sliding_energy(problem, normal, f) if load > 0.0 else 0.0)
    if i not in tangential.at:
        return
    outcome.sweeps[i] = tangential_sweep(problem, normal, f, tangential=tangential_loads(f, load, tangential.steps),
                                         method=task.normal.method)
    if tangential.fretting_amplitude is not None:
        outcome.cycles[i] = fretting_cycle(problem, normal, f, tangential.fretting_amplitude * f * load,
                                           tangential.fretting_steps, method=task.normal.method)


def _check_deadline(comm, start: float, timeout: float | None, done: int, loads: int) -> None:
    """Raise :class:`~roughcontact.errors.TaskTimeout` if ``timeout`` seconds have passed since
    ``start`` on any rank of ``comm`` (collective: every rank of a group stops at the same load).

    Checked between loads, not by a timer signal: a signal interrupts each rank
    of a group at a different point of a distributed solve, so the rank that
    leaves it would leave the others waiting in the solve's next reduction (a
    hang), and PETSc objects interrupted mid-solve are left in an error state.
    A load's solve is bounded by its own iteration limits.
    """
    if timeout is None:
        return
    from mpi4py import MPI

    elapsed = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    if elapsed > timeout:
        raise TaskTimeout(f"[farm] task_timeout of {timeout:g} s passed after {done} of {loads} load(s) "
                          f"({elapsed:.1f} s); the loads solved are kept. Raise it and run again with "
                          f"--retry-failed to solve the task whole")


def _short(value) -> str:
    if isinstance(value, Interface):
        return f"E1={value.body1.E:g}/E2={value.body2.E:g}"
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(f"{v:g}" for v in value) + "]"
    if isinstance(value, str):
        return Path(value).name
    return f"{value:g}" if isinstance(value, float) else str(value)
