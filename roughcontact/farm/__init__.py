"""Parametric studies: study definitions, tasks, the MPI task farm, the result store and resume.

- :mod:`.definition`, :mod:`.axes`, :mod:`.schema`: a study read from TOML, its axes and tasks;
- :mod:`.task`: one task solved on a communicator (:func:`open_normal_solver` builds each solver);
- :mod:`.records`: a solved task as the groups of its NetCDF file;
- :mod:`.executor`: groups of ranks, the ``mpi4py.futures`` farm, aborting on unexpected errors;
- :mod:`.store`, :mod:`.combine`: the task files, resume, and the combined study dataset;
- :mod:`.guards`, :mod:`.progress`: checks before the first solve, the progress line;
- :mod:`.run`: all of it in order (``roughcontact run``).

Ensemble means, spreads and confidence intervals over seeds are
:func:`roughcontact.analysis.ensemble_statistics`, for a study's scalars as
for the measures of its analysis.
"""
from .definition import DEFAULT_STUDY, Study, load_study
from .run import RunSummary, combine_study, run_study
from .task import NormalOptions, TangentialOptions, Task, open_normal_solver, solve_task

__all__ = ["DEFAULT_STUDY", "NormalOptions", "RunSummary", "Study", "TangentialOptions", "Task", "combine_study",
           "load_study", "open_normal_solver", "run_study", "solve_task"]
