"""The fretting map of one contact: energy dissipated per cycle against the amplitude Q*.

One load history at constant P (:func:`~.history.tangential_history`) steps
the amplitude up, as a stepped-amplitude fretting test does: for each Q*
in increasing order, load from the last amplitude to +Q*, unload to −Q*
and reload to +Q*. By the memory rules of the discrete theorem
(Mindlin–Deresiewicz, Jäger) a reload that reaches +Q* closes its loop and
rejoins the virgin curve (Eqs. 21–24 with 2f), so each cycle is the one a
fresh contact would run at that amplitude, and the corrective states of
the smaller amplitudes are reused (one corrective normal solve at
P − X/f per distinct X, Eq. 23).

Per amplitude: the energy dissipated over the cycle, 4 E_f(Q*) with E_f
the monotonic frictional energy (Eq. 26) (the Mindlin–Deresiewicz loop;
on Hertz ∝ Q*³ at small Q*, Johnson 1985 §7.3), and the area of the Q–δx
loop ∮ Q dδx (trapezoidal rule, which converges to it as ``steps`` grows).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..normal.problem import NormalProblem
from ..normal.result import NormalResult
from .checks import check_amplitudes, check_friction, check_normal, check_steps
from .history import TangentialHistory, tangential_history


@dataclass(frozen=True)
class FrettingMap:
    """Energy per cycle against amplitude at one normal load.

    Attributes
    ----------
    amplitudes
        Q*/(fP) of each cycle, increasing.
    tangential
        Q* (N).
    dissipated_per_cycle
        Energy dissipated by friction over the cycle +Q* → −Q* → +Q* (J).
    loop_area
        ∮ Q dδx over the same cycle (trapezoidal rule), J.
    approach
        δx at +Q* (m), the half-width of the loop in δx.
    cycle_start, cycle_stop
        Indices into ``history`` of the points +Q* that open and close each cycle.
    history
        The whole stepped-amplitude load history.
    gamma, beta
        γ (Eq. 4b) and β (Eq. 5) of the interface (the model is exact when both vanish).
    """

    amplitudes: np.ndarray
    tangential: np.ndarray
    dissipated_per_cycle: np.ndarray
    loop_area: np.ndarray
    approach: np.ndarray
    cycle_start: tuple[int, ...]
    cycle_stop: tuple[int, ...]
    history: TangentialHistory
    gamma: float = 0.0
    beta: float = 0.0

    @property
    def friction(self) -> float:
        return self.history.friction

    @property
    def normal(self) -> NormalResult:
        return self.history.normal

    @property
    def model(self) -> str:
        return self.history.model


def stepped_amplitude_path(limit: float, amplitudes: np.ndarray, steps: int):
    """Q(t) of the stepped-amplitude test and the indices of each cycle's +Q* points.

    Indices count the history's first point Q = 0 (:func:`~.history.tangential_history`
    prepends it). Each branch has ``steps`` intervals.
    """
    path: list[float] = []
    starts, stops = [], []
    previous = 0.0
    for amplitude in amplitudes * limit:
        path += list(np.linspace(previous, amplitude, steps + 1)[1:])          # load to +Q*
        starts.append(len(path))
        path += list(np.linspace(amplitude, -amplitude, 2 * steps + 1)[1:])    # unload to −Q*
        path += list(np.linspace(-amplitude, amplitude, 2 * steps + 1)[1:])    # reload to +Q*
        stops.append(len(path))
        previous = amplitude
    return np.array(path), tuple(starts), tuple(stops)


def fretting_map(problem: NormalProblem, normal: NormalResult, friction: float, amplitudes, steps: int = 8,
                 direction=(1.0, 0.0), **solver_options) -> FrettingMap:
    """One cycle +Q* → −Q* → +Q* at each amplitude Q* = a fP, the amplitude stepped up.

    Parameters
    ----------
    problem, normal
        The normal problem and its actual solution (load P > 0).
    friction
        Coulomb coefficient f > 0.
    amplitudes
        a = Q*/(fP), strictly increasing, each in (0, 1).
    steps
        Intervals on the way to each +Q* (twice as many from +Q* to −Q*, the
        same spacing in Q); they set the resolution of ``loop_area``, not the
        dissipated energy, which is exact at each point.
    direction
        In-plane direction of Q.
    **solver_options
        Options of the corrective solver (:class:`~.cattaneo.CattaneoSolver`).
    """
    friction = check_friction(friction)
    check_normal(problem, normal)
    values = check_amplitudes(amplitudes)
    steps = check_steps(steps)
    path, starts, stops = stepped_amplitude_path(friction * normal.load, values, steps)
    history = tangential_history(problem, normal, friction, path, direction=direction, **solver_options)
    dissipated = np.array([history.dissipated[b] - history.dissipated[a] for a, b in zip(starts, stops)])
    loops = np.array([history.loop_energy(a, b) for a, b in zip(starts, stops)])
    return FrettingMap(amplitudes=values, tangential=values * friction * normal.load,
                       dissipated_per_cycle=dissipated, loop_area=loops,
                       approach=np.array([history.approach[a] for a in starts]),
                       cycle_start=starts, cycle_stop=stops, history=history,
                       gamma=float(problem.interface.composite_poisson),
                       beta=float(problem.interface.dundurs_beta))
