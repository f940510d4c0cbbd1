"""Measured tip positions: the CSV format a calibration reads, and its reader/writer.

One row per measurement, in the order the measurements were taken (the physics backends replay
that history, which is what makes friction hysteresis reproducible). A header row names the
columns; ``#`` starts a comment line; blank lines are skipped. Columns (any order):

============== ======== ==========================================================================
column         unit     meaning
============== ======== ==========================================================================
``T1`` … ``Tn`` N       cable tensions at the actuators, one column per cable in the robot's cable
                        order (section by section, proximal first) — **or**
``m1`` … ``mn`` kg      hanging masses on the cables (the paper's protocol), converted to tensions
                        with g = 9.81 m/s² (``cdcr_gym.params.STANDARD_GRAVITY``). Give one kind.
``x, y, z``     m       measured tip (last disk centre) in the base frame R0: origin at the base
                        disk centre, backbone along +Z0 (up), cable 1 at +X0.
``direction``   —       optional: ``up`` (loading) or ``down`` (unloading); empty = unknown.
                        Checked against the change of tensions from the previous row (the sum
                        over cables), used to mark the branches in the report.
``tx, ty, tz``  —       optional: measured unit backbone tangent at the tip (tip orientation),
                        fitted with the angular uncertainty ``sigma_dir``.
``sigma``       m       optional: the tip measurement's standard deviation (weights the row;
                        default 1 mm for every row, i.e. unweighted).
``sigma_dir``   rad     optional: the tangent's standard deviation (default 0.01 rad).
``label``       —       optional free text (ignored by the fit, kept in the report).
============== ======== ==========================================================================

Errors name the file, the 1-based line and the column: ``data.csv line 7, column 'z': 'abc' is
not a number``.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cdcr_gym.model.params import STANDARD_GRAVITY

__all__ = ["Measurements", "read_csv", "write_csv", "DEFAULT_SIGMA", "DEFAULT_SIGMA_DIR"]

#: Tip standard deviation (m) of rows without a ``sigma`` column.
DEFAULT_SIGMA = 1e-3
#: Tangent standard deviation (rad) of rows without a ``sigma_dir`` column.
DEFAULT_SIGMA_DIR = 0.01

_DIRECTIONS = {"up": 1, "down": -1, "": 0}
_KNOWN = {"x", "y", "z", "direction", "tx", "ty", "tz", "sigma", "sigma_dir", "label"}
_CABLE = re.compile(r"^([Tm])([1-9][0-9]*)$")


@dataclass(frozen=True)
class Measurements:
    """M measurements, in the order they were taken (SI units, float64).

    Attributes:
        tensions: (M, C) cable tensions, N.
        tip: (M, 3) measured tip positions in R0, m.
        direction: (M,) int, +1 loading (``up``), −1 unloading (``down``), 0 unknown.
        sigma: (M,) tip standard deviations, m.
        tip_direction: (M, 3) measured unit tangents at the tip, or None.
        sigma_dir: (M,) tangent standard deviations, rad.
        lines: (M,) the 1-based source line of each row (for messages).
        labels: per-row labels ("" where none).
        source: the file name (or "<memory>").
        from_masses: whether the file gave hanging masses (kg) rather than tensions.
    """

    # arrays after construction; direction, sigma and lines may be given as None (defaults)
    tensions: np.ndarray
    tip: np.ndarray
    direction: Any
    sigma: Any
    tip_direction: np.ndarray | None = None
    sigma_dir: np.ndarray | None = None
    lines: Any = None
    labels: tuple[str, ...] = ()
    source: str = "<memory>"
    from_masses: bool = False

    def __post_init__(self) -> None:
        t = np.asarray(self.tensions, dtype=np.float64)
        tip = np.asarray(self.tip, dtype=np.float64)
        if t.ndim != 2 or tip.shape != (t.shape[0], 3):
            raise ValueError(
                f"tensions must be (M, C) and tip (M, 3), got {t.shape} and {tip.shape}"
            )
        m = t.shape[0]
        if not (np.isfinite(t).all() and np.isfinite(tip).all()) or np.any(t < 0.0):
            raise ValueError("tensions must be finite and >= 0 N and tips finite")
        object.__setattr__(self, "tensions", t)
        object.__setattr__(self, "tip", tip)
        direction = np.zeros(m, dtype=np.int64) if self.direction is None else self.direction
        object.__setattr__(self, "direction", np.asarray(direction, dtype=np.int64).reshape(m))
        sigma = np.full(m, DEFAULT_SIGMA) if self.sigma is None else self.sigma
        sigma = np.broadcast_to(np.asarray(sigma, dtype=np.float64), (m,)).copy()
        if not (np.isfinite(sigma).all() and np.all(sigma > 0.0)):
            raise ValueError(f"sigma must be finite and > 0 m, got {sigma!r}")
        object.__setattr__(self, "sigma", sigma)
        if self.tip_direction is not None:
            d = np.asarray(self.tip_direction, dtype=np.float64).reshape(m, 3)
            object.__setattr__(self, "tip_direction", d)
            sd = DEFAULT_SIGMA_DIR if self.sigma_dir is None else self.sigma_dir
            sd = np.broadcast_to(np.asarray(sd, dtype=np.float64), (m,)).copy()
            object.__setattr__(self, "sigma_dir", sd)
        lines = np.arange(2, m + 2) if self.lines is None else self.lines
        object.__setattr__(self, "lines", np.asarray(lines, dtype=np.int64))
        if not self.labels:
            object.__setattr__(self, "labels", ("",) * m)

    def __len__(self) -> int:
        return int(self.tensions.shape[0])

    @property
    def n_cables(self) -> int:
        """Number of cable columns C."""
        return int(self.tensions.shape[1])

    def subset(self, index: np.ndarray | slice) -> Measurements:
        """The rows ``index`` (in their order), e.g. a few points for a quick check."""
        pick = np.arange(len(self))[index]
        return Measurements(
            self.tensions[pick],
            self.tip[pick],
            self.direction[pick],
            self.sigma[pick],
            None if self.tip_direction is None else self.tip_direction[pick],
            None if self.sigma_dir is None else self.sigma_dir[pick],
            None if self.lines is None else self.lines[pick],
            tuple(self.labels[i] for i in pick),
            self.source,
            self.from_masses,
        )


def _number(text: str, where: str, column: str, *, positive: bool = False) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{where}, column {column!r}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise ValueError(f"{where}, column {column!r}: {text!r} is not finite")
    if positive and value <= 0.0:
        raise ValueError(f"{where}, column {column!r}: must be > 0, got {text!r}")
    if value < 0.0 and column[0] in "Tm" and column[1:].isdigit():
        raise ValueError(f"{where}, column {column!r}: a cable cannot push, got {text!r} (< 0)")
    return value


def _cable_columns(header: list[str], name: str) -> tuple[str, list[str]]:
    """The kind ("T" or "m") and the ordered cable columns of a header."""
    found: dict[str, dict[int, str]] = {"T": {}, "m": {}}
    for col in header:
        match = _CABLE.match(col)
        if match:
            found[match.group(1)][int(match.group(2))] = col
    kinds = [k for k in ("T", "m") if found[k]]
    if not kinds:
        raise ValueError(
            f"{name} line 1 (header): no cable columns; give tensions T1..Tn (N) or hanging "
            f"masses m1..mn (kg), got columns {header}"
        )
    if len(kinds) == 2:
        raise ValueError(
            f"{name} line 1 (header): give either tensions (T1..Tn) or masses (m1..mn), not both"
        )
    kind = kinds[0]
    numbers = sorted(found[kind])
    if numbers != list(range(1, len(numbers) + 1)):
        missing = sorted(set(range(1, max(numbers) + 1)) - set(numbers))
        raise ValueError(
            f"{name} line 1 (header): cable columns must be {kind}1..{kind}n without gaps, "
            f"missing {[f'{kind}{i}' for i in missing]}"
        )
    return kind, [found[kind][i] for i in numbers]


def read_csv(path: str | Path) -> Measurements:
    """Read a measurement CSV (module docstring).

    Raises:
        ValueError: naming the file, the line and the column, for a missing or unknown column,
            a value that is not a number, a negative tension or mass, a ``direction`` other than
            up/down, a ``direction`` that contradicts the change of tensions, or no data rows.
    """
    path = Path(path)
    name = path.name
    if not path.is_file():
        raise ValueError(f"measurement file {str(path)!r} does not exist")
    with path.open(newline="") as fh:
        numbered = [(i, line) for i, line in enumerate(fh.read().splitlines(), start=1)]
    rows = [(i, line) for i, line in numbered if line.strip() and not line.lstrip().startswith("#")]
    if not rows:
        raise ValueError(f"{name}: no header and no data rows")
    parsed = list(csv.reader([line for _, line in rows], skipinitialspace=True))
    header_line = rows[0][0]
    header = [c.strip() for c in parsed[0]]
    dup = sorted({c for c in header if header.count(c) > 1})
    if dup:
        raise ValueError(f"{name} line {header_line} (header): duplicate column(s) {dup}")
    kind, cable_cols = _cable_columns(header, name)
    unknown = [c for c in header if c not in _KNOWN and c not in cable_cols]
    if unknown:
        raise ValueError(
            f"{name} line {header_line} (header): unknown column(s) {unknown}; accepted: "
            f"{kind}1..{kind}n, x, y, z, direction, tx, ty, tz, sigma, sigma_dir, label"
        )
    for col in ("x", "y", "z"):
        if col not in header:
            raise ValueError(f"{name} line {header_line} (header): missing column {col!r}")
    has_dir = [c in header for c in ("tx", "ty", "tz")]
    if any(has_dir) and not all(has_dir):
        raise ValueError(
            f"{name} line {header_line} (header): the tip tangent needs all of tx, ty, tz"
        )
    index = {c: k for k, c in enumerate(header)}
    data_rows = list(zip([i for i, _ in rows[1:]], parsed[1:]))
    if not data_rows:
        raise ValueError(f"{name}: a header but no data rows")
    tensions, tips, dirs, sig, tans, sig_dir, lines, labels = [], [], [], [], [], [], [], []
    scale = STANDARD_GRAVITY if kind == "m" else 1.0
    for line_no, cells in data_rows:
        where = f"{name} line {line_no}"
        if len(cells) != len(header):
            raise ValueError(f"{where}: {len(cells)} values for {len(header)} columns {header}")
        cell = {c: cells[index[c]].strip() for c in header}
        tensions.append([scale * _number(cell[c], where, c) for c in cable_cols])
        tips.append([_number(cell[c], where, c) for c in ("x", "y", "z")])
        word = cell.get("direction", "").lower()
        if word not in _DIRECTIONS:
            raise ValueError(
                f"{where}, column 'direction': must be 'up', 'down' or empty, got {cell['direction']!r}"
            )
        dirs.append(_DIRECTIONS[word])
        sig.append(
            _number(cell["sigma"], where, "sigma", positive=True)
            if "sigma" in cell
            else DEFAULT_SIGMA
        )
        if all(has_dir):
            t = [_number(cell[c], where, c) for c in ("tx", "ty", "tz")]
            norm = math.sqrt(sum(v * v for v in t))
            if not 0.99 < norm < 1.01:
                raise ValueError(
                    f"{where}, columns 'tx, ty, tz': the tangent must be a unit vector, "
                    f"got norm {norm:.6g}"
                )
            tans.append([v / norm for v in t])
            sig_dir.append(
                _number(cell["sigma_dir"], where, "sigma_dir", positive=True)
                if "sigma_dir" in cell
                else DEFAULT_SIGMA_DIR
            )
        lines.append(line_no)
        labels.append(cell.get("label", ""))
    t_arr = np.array(tensions)
    direction = np.array(dirs)
    check_directions(t_arr, direction, np.array(lines), name)
    return Measurements(
        t_arr,
        np.array(tips),
        direction,
        np.array(sig),
        np.array(tans) if tans else None,
        np.array(sig_dir) if tans else None,
        np.array(lines),
        tuple(labels),
        name,
        kind == "m",
    )


def check_directions(
    tensions: np.ndarray, direction: np.ndarray, lines: np.ndarray, name: str
) -> None:
    """ValueError naming the line if a row's ``direction`` contradicts the change of the summed
    tension from the previous row (a rise is loading, ``up``; a fall unloading, ``down``)."""
    total = tensions.sum(axis=1)
    change = np.diff(total, prepend=0.0)
    tol = 1e-9 * max(1.0, float(np.max(total, initial=0.0)))
    for k in range(len(total)):
        if direction[k] == 1 and change[k] < -tol or direction[k] == -1 and change[k] > tol:
            word = "up" if direction[k] == 1 else "down"
            trend = "fell" if change[k] < 0 else "rose"
            raise ValueError(
                f"{name} line {lines[k]}, column 'direction': {word!r}, but the total tension "
                f"{trend} from {total[k] - change[k]:.6g} N to {total[k]:.6g} N; rows must be in "
                "the order they were measured"
            )


def write_csv(path: str | Path, data: Measurements, comment: str = "") -> None:
    """Write ``data`` in the format of :func:`read_csv` (tensions as T columns, SI units)."""
    path = Path(path)
    words = {1: "up", -1: "down", 0: ""}
    cols = [f"T{i + 1}" for i in range(data.n_cables)] + ["direction", "x", "y", "z", "sigma"]
    if data.tip_direction is not None:
        cols += ["tx", "ty", "tz", "sigma_dir"]
    with path.open("w", newline="") as fh:
        for line in comment.splitlines():
            fh.write(f"# {line}\n")
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(cols)
        for k in range(len(data)):
            row = [repr(float(v)) for v in data.tensions[k]] + [words[int(data.direction[k])]]
            row += [repr(float(v)) for v in data.tip[k]] + [repr(float(data.sigma[k]))]
            if data.tip_direction is not None and data.sigma_dir is not None:
                row += [repr(float(v)) for v in data.tip_direction[k]]
                row += [repr(float(data.sigma_dir[k]))]
            writer.writerow(row)
