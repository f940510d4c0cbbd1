"""The evaluation tables of ``cdcr-gym evaluate``, ``results`` and ``oracles``.

A table is a list of :class:`Column`: a short header, a legend (what the number is, its unit)
and a formatter of one row's record. By default only the columns marked ``narrow`` are shown, so
that a table of typical rows fits :data:`WIDTH` characters; ``--wide`` shows them all. The
legend of the shown columns is printed under the table, wrapped to the same width.
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

__all__ = [
    "WIDTH",
    "Column",
    "shown",
    "text_table",
    "markdown_table",
    "legend",
    "wrap",
    "pct",
    "task_columns",
]

#: characters per line of the default (narrow) output
WIDTH = 100


@dataclass(frozen=True)
class Column:
    """One column: ``header`` (short), ``legend`` (its meaning and unit), ``cell`` (row -> text),
    ``narrow``: shown by default (False: only with ``--wide``)."""

    header: str
    legend: str
    cell: Callable[[Any], str]
    narrow: bool = True


def pct(fraction: float) -> str:
    """A fraction as a percentage with one decimal (``0.953`` -> ``95.3%``)."""
    return f"{100 * fraction:.1f}%"


def shown(columns: Sequence[Column], wide: bool) -> list[Column]:
    """The columns of the table: all with ``wide``, else the narrow ones."""
    return [c for c in columns if wide or c.narrow]


def text_table(columns: Sequence[Column], rows: Sequence[Any], wide: bool = False) -> str:
    """An aligned plain-text table (the first column left, the others right-aligned)."""
    cols = shown(columns, wide)
    cells = [[c.header for c in cols]] + [[c.cell(r) for c in cols] for r in rows]
    widths = [max(len(line[i]) for line in cells) for i in range(len(cols))]

    def line(values: list[str]) -> str:
        first = values[0].ljust(widths[0])
        rest = [v.rjust(w) for v, w in zip(values[1:], widths[1:], strict=True)]
        return "  ".join([first, *rest]).rstrip()

    out = [line(cells[0]), "  ".join("-" * w for w in widths)]
    out += [line(values) for values in cells[1:]]
    return "\n".join(out)


def markdown_table(columns: Sequence[Column], rows: Sequence[Any], wide: bool = False) -> str:
    """A Markdown table of the shown columns."""
    cols = shown(columns, wide)
    out = ["| " + " | ".join(c.header for c in cols) + " |", "|" + "---|" * len(cols)]
    out += ["| " + " | ".join(c.cell(r) for c in cols) + " |" for r in rows]
    return "\n".join(out)


def legend(columns: Sequence[Column], wide: bool = False, width: int = WIDTH) -> str:
    """``header: meaning; ...`` of the shown columns, wrapped to ``width`` characters, and a note
    that ``--wide`` shows the hidden ones."""
    cols = shown(columns, wide)
    text = "; ".join(f"{c.header}: {c.legend}" for c in cols if c.legend) + "."
    hidden = len(columns) - len(cols)
    if hidden:
        text += f" --wide shows {hidden} more column{'s' if hidden > 1 else ''}."
    return wrap(text, width)


def wrap(text: str, width: int = WIDTH) -> str:
    """``text`` wrapped to ``width`` characters (long words, e.g. paths, are not broken)."""
    return textwrap.fill(text, width, break_long_words=False, break_on_hyphens=False)


def task_columns(
    task: str, first: tuple[str, str] = ("condition", "starting shape and episode length")
) -> list[Column]:
    """The columns of a table of evaluation summaries (``cdcr-gym evaluate``, ``results``,
    ``oracles``; every task): rows are ``(label, who, summary)``, ``first`` the label column's
    header and legend, ``summary`` from :func:`training.run.metrics.summarize`. The columns
    every task has, then ``task``'s own; a number a summary lacks (a file written before it was
    reported) reads ``–``."""
    C = Column

    def stat(key: str, s: str, fmt: str = ".3f") -> Any:
        return lambda r: format(r[2][key][s], fmt) if key in r[2] else "–"

    def rate(key: str) -> Any:
        return lambda r: pct(r[2][key]) if key in r[2] else "–"

    def to_oracle(key: str, fmt: str) -> Any:
        return lambda r: (
            format(r[2]["to_oracle"][key]["median"], fmt) if "to_oracle" in r[2] else "–"
        )

    cols = [
        C(*first, lambda r: r[0]),
        C(
            "policy",
            "policy = the trained model, oracle = the task's oracle "
            "(cdcr_gym.controllers), _closed_loop = corrected from the measured tip, reach_ik = "
            "the plain reach IK, random = uniform random actions",
            lambda r: r[1],
        ),
        C("success", "episodes that end successful", rate("success_rate")),
        C("≤1mm", "episodes ending within 1 mm of the goal", rate("within_1mm")),
        C("dist med", "median final tip-to-goal distance, mm", stat("final_distance_mm", "median")),
        C("dist mean", "its mean, mm", stat("final_distance_mm", "mean"), narrow=False),
        C("dist p95", "its 95th percentile, mm", stat("final_distance_mm", "p95")),
        C("dist max", "its largest value, mm", stat("final_distance_mm", "max"), narrow=False),
        C(
            "return",
            "mean episode return",
            lambda r: f"{r[2]['mean_return']:.2f}" if "mean_return" in r[2] else "–",
            narrow=False,
        ),
        C(
            "ΔL oracle",
            "median distance of the policy's final cable lengths from the oracle's on the same "
            "episode (Euclidean over the cables), mm",
            to_oracle("cable_length_distance_mm", ".3f"),
            narrow=False,
        ),
        C(
            "ΔT oracle",
            "median distance of the policy's final tensions from the oracle's, N",
            to_oracle("tension_distance_n", ".2f"),
            narrow=False,
        ),
    ]
    if task == "Track":
        cols += [
            C(
                "RMS mean",
                "mean tracking RMS error after settling, mm",
                stat("tracking_rms_mm", "mean"),
            ),
            C(
                "RMS max",
                "largest tracking RMS error, mm",
                stat("tracking_rms_mm", "max"),
                narrow=False,
            ),
        ]
    elif task == "Pose":
        cols += [
            C(
                "angle med",
                "median final tip-direction error, degrees",
                stat("final_angle_deg", "median"),
            ),
            C(
                "≤1mm,1°",
                "episodes within 1 mm and 1 degree",
                lambda r: pct(r[2]["within_1mm_1deg"]),
                narrow=False,
            ),
        ]
    elif task == "Obstacle":
        cols += [
            C(
                "collided",
                "episodes with a collision",
                lambda r: pct(r[2]["collision_rate"]),
            ),
            C(
                "coll.ok",
                "collisions in successful episodes (count)",
                lambda r: str(r[2]["collisions_in_successful_episodes"]),
                narrow=False,
            ),
            C(
                "clear med",
                "median smallest clearance to an obstacle, mm",
                stat("min_clearance_mm", "median"),
                narrow=False,
            ),
            C(
                "filtered",
                "steps the safety filter changed (when on)",
                lambda r: (
                    pct(r[2]["filtered_step_fraction"]) if "filtered_step_fraction" in r[2] else "–"
                ),
                narrow=False,
            ),
        ]
    return cols
