"""The paper's figures and the studies that make them.

Each study of ``studies/paper/`` (quick scale) has a twin of the same file
name in ``studies/paper/full/`` (the paper's resolutions, ≥ 8 seeds). A figure
needs one or more studies; ``--only`` runs the union of what the chosen
figures need, in the order below (cheapest first).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError


@dataclass(frozen=True)
class PaperStudy:
    """One study of the paper set: its key, its TOML file stem and the figures it feeds."""

    key: str
    stem: str
    figures: tuple[int, ...]


#: run order: cheapest first
STUDIES = (
    PaperStudy("closure", "fig04_closure", (4, 5)),
    PaperStudy("resolution", "fig01_resolution", (1, 5)),
    PaperStudy("load", "fig05_load", (2, 3, 5, 6, 9, 12, 13, 14)),
    PaperStudy("shear", "fig10_shear", (10, 11)),
    PaperStudy("rock", "fig08_rock", (7, 8, 14)),
)

#: every figure of the paper that is reproduced (Fig. 3b–d are schemes)
FIGURES = tuple(sorted({f for s in STUDIES for f in s.figures}))


def studies_folder(full: bool, root: Path | None = None) -> Path:
    """``studies/paper`` (or its ``full/``) of the source tree, or under ``root``."""
    base = Path(root) if root is not None else Path(__file__).resolve().parents[2] / "studies" / "paper"
    folder = base / "full" if full else base
    if not folder.is_dir():
        raise InputError("studies", f"{folder} does not exist (the paper's study files come with the source tree; "
                                    "give --studies DIR)")
    return folder


def needed(figures) -> tuple[PaperStudy, ...]:
    """The studies the figures need, in run order; all of them for no figures."""
    figures = tuple(figures or ())
    unknown = sorted(set(figures) - set(FIGURES))
    if unknown:
        raise InputError("--only", f"figure(s) {unknown} are not reproduced; choose among {list(FIGURES)}")
    if not figures:
        return STUDIES
    return tuple(s for s in STUDIES if set(s.figures) & set(figures))


def drawable(figure: int, done: set[str]) -> bool:
    """Whether every study ``figure`` needs is in ``done`` (keys)."""
    return all(s.key in done for s in STUDIES if figure in s.figures)
