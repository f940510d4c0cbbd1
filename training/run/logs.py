"""The run's logs: SB3's logger (stdout, CSV continued on resume, TensorBoard) and CSV rows."""

from __future__ import annotations

import csv
import sys
from pathlib import Path
from typing import Any

import numpy as np

from training.run.rundir import RunDir


# -- CSV logs that survive --resume -------------------------------------------------------------
def append_csv(path: Path, row: dict[str, Any]) -> None:
    new = not path.exists()
    with open(path, "a", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(row))
        if new:
            writer.writeheader()
        writer.writerow(row)


def truncate_csv(path: Path, step_key: str, max_step: int) -> None:
    """Drop rows of ``path`` whose ``step_key`` exceeds ``max_step`` (logs past a checkpoint)."""
    if not path.exists():
        return
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        fields = reader.fieldnames or []
        rows = [r for r in reader if not r.get(step_key) or float(r[step_key]) <= max_step]
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)


def _resumable_csv_format(path: Path) -> Any:
    """An SB3 logger output that appends to ``path`` (keeping its rows) instead of truncating."""
    from stable_baselines3.common.logger import KVWriter, filter_excluded_keys

    class ResumableCSV(KVWriter):
        def __init__(self) -> None:
            self.rows: list[dict[str, Any]] = []
            self.keys: list[str] = []
            if path.exists():
                with open(path, newline="") as f:
                    reader = csv.DictReader(f)
                    self.keys = list(reader.fieldnames or [])
                    self.rows = list(reader)

        def write(self, key_values: dict[str, Any], key_excluded: Any, step: int = 0) -> None:
            values = filter_excluded_keys(key_values, key_excluded, "csv")
            row = {k: v for k, v in values.items() if isinstance(v, (int, float, str, np.number))}
            self.rows.append(row)
            extra = [k for k in row if k not in self.keys]
            if extra:
                self.keys.extend(sorted(extra))
                with open(path, "w", newline="") as f:
                    writer = csv.DictWriter(f, fieldnames=self.keys)
                    writer.writeheader()
                    writer.writerows(self.rows)
            else:
                with open(path, "a", newline="") as f:
                    csv.DictWriter(f, fieldnames=self.keys).writerow(row)

        def close(self) -> None:
            pass

    return ResumableCSV()


def make_logger(run: RunDir, verbose: bool = False) -> Any:
    """SB3's logger of a run: ``progress.csv`` (continued on resume) and TensorBoard; with
    ``verbose`` also SB3's tables on stdout (one per rollout: thousands of lines in a minute)."""
    from stable_baselines3.common.logger import HumanOutputFormat, Logger, TensorBoardOutputFormat

    run.tb.mkdir(parents=True, exist_ok=True)
    formats = [_resumable_csv_format(run.progress), TensorBoardOutputFormat(str(run.tb))]
    if verbose:
        formats.insert(0, HumanOutputFormat(sys.stdout))
    return Logger(folder=str(run.root), output_formats=formats)
