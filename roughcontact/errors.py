"""Exceptions raised by roughcontact.

Every error a user can trigger by bad input is an :class:`InputError` that
names the offending parameter; every numerical failure (a Krylov solve that
diverges, an active set that cycles or runs out of iterations) is a
:class:`ConvergenceError` that says what happened. Nothing fails silently.
"""
from __future__ import annotations


class RoughContactError(Exception):
    """Base class of the package's own errors."""


class InputError(RoughContactError, ValueError):
    """Bad input, with the name of the offending parameter.

    Parameters
    ----------
    parameter
        Name of the argument or field that is wrong (as the user wrote it).
    message
        What is wrong with it and, where possible, what would be right.
    """

    def __init__(self, parameter: str, message: str):
        self.parameter = parameter
        super().__init__(f"{parameter}: {message}")


class ConvergenceError(RoughContactError, RuntimeError):
    """A solver stopped without meeting its tolerance.

    Attributes
    ----------
    reason
        Short machine-readable reason, e.g. ``"KSP_DIVERGED_ITS"``,
        ``"ACTIVE_SET_CYCLING"``, ``"ACTIVE_SET_MAX_ITERATIONS"``.
    """

    def __init__(self, reason: str, message: str):
        self.reason = reason
        super().__init__(f"{reason}: {message}")


class StorageError(RoughContactError):
    """A file of a study could not be written or read back (no space, quota, permission, a
    vanished directory): what failed, the path, and how a run resumes.

    Attributes
    ----------
    path
        The file or directory concerned.
    """

    def __init__(self, path, message: str):
        self.path = str(path)
        super().__init__(message)


class TaskTimeout(RoughContactError):
    """A task of a study ran past its ``[farm] task_timeout``: the loads solved before are kept."""
