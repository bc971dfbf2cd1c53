"""When the discrete Cattaneo analogy is exact, and saying so when it is not (§4.1).

The tangential problem reduces to a second normal problem (Eqs. 21–23) only
when the shear tractions are uncoupled from the pressure (Dundurs' β = 0,
Eq. 5) and from each other (composite Poisson ratio γ = 0, Eqs. 15–18). For
non-negative Poisson ratios γ = 0 needs ν1 = ν2 = 0 (footnote 7). For any
other pair of materials the same construction is the *uncoupled
approximation* (Eqs. 17–18 with the γ and β terms dropped): every result is
labelled with :func:`cattaneo_model`, and the first use in a process warns
with :class:`UncoupledApproximationWarning`.
"""
from __future__ import annotations

import warnings

from ..materials import Interface

EXACT = "exact"
UNCOUPLED = "uncoupled approximation"

_warned: set[str] = set()


class UncoupledApproximationWarning(UserWarning):
    """The Cattaneo analogy is applied to materials with β ≠ 0 or γ ≠ 0."""


class CattaneoConsistencyWarning(UserWarning):
    """A discrete state breaks an assumption of the Cattaneo construction: Coulomb's
    inequalities 0 ≤ q ≤ f p (Eq. 14a) beyond the solver tolerance, or stick sets
    that do not recede along a sweep (Eq. 26 then undercounts the slip of re-stuck
    nodes). The results are still returned, labelled by their diagnostics."""


#: Coulomb breach, relative to f max p, beyond which a state is flagged: two orders
#: above the active-set tolerance (1e-8) that bounds the breach of a consistent state.
COULOMB_TOLERANCE = 1e-6


def cattaneo_model(interface: Interface, warn: bool = True) -> str:
    """``"exact"`` when β = 0 and γ = 0, else ``"uncoupled approximation"``.

    Parameters
    ----------
    interface
        The two materials.
    warn
        Warn (once per process) when the result is an approximation.
    """
    if interface.cattaneo_exact:
        return EXACT
    if warn and UNCOUPLED not in _warned:
        _warned.add(UNCOUPLED)
        warnings.warn(
            f"the Cattaneo analogy (Eqs. 21-23) is exact only for beta = 0 and gamma = 0; this "
            f"interface has beta = {interface.dundurs_beta:.3g}, gamma = {interface.composite_poisson:.3g}: "
            "tangential results are the uncoupled approximation (labelled cattaneo_model)",
            UncoupledApproximationWarning, stacklevel=3)
    return UNCOUPLED


def resticking_nodes(states) -> int:
    """The most nodes that joined the stick set between two successive states."""
    return max((int((b.stick & ~a.stick).sum()) for a, b in zip(states, states[1:])), default=0)


def check_resticking(states, between: str = "two steps of the sweep", stacklevel: int = 3) -> int:
    """:func:`resticking_nodes` of ``states`` (in increasing Q), warned about unless zero.

    ``stacklevel`` 3 points the :class:`CattaneoConsistencyWarning` at the
    caller of the function that calls this one.
    """
    resticking = resticking_nodes(states)
    if resticking:
        warnings.warn(f"{resticking} node(s) joined the stick set between {between}: the "
                      "stick sets do not recede, so E_f (Eq. 26) undercounts their earlier slip "
                      "(resticking_nodes)", CattaneoConsistencyWarning, stacklevel=stacklevel)
    return resticking
