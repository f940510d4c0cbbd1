"""The old flat module paths of ``training`` (``training.train``, ``training.rollout``, ...).

``training`` was 24 flat modules; it is now a package with rooms (``run/``, ``evaluate/``,
``sweep/``, ``studies/``) and one command, ``cdcr-gym``. Each old module is kept as a thin alias
so that ``python -m training.X`` and ``from training.X import name`` go on working:

* imported, the alias *is* the new module (``sys.modules`` points the old name at it, so
  attributes, monkeypatching and ``isinstance`` all behave as before), with a
  :class:`DeprecationWarning`;
* run with ``python -m training.X``, it prints a one-line note naming the new command and runs
  the new module's ``main`` with the same arguments.
"""

from __future__ import annotations

import importlib
import sys
import warnings

__all__ = ["MOVED", "alias"]

#: old module -> (new module, the ``cdcr-gym`` subcommand that runs it, or "")
MOVED: dict[str, tuple[str, str]] = {
    "training.config": ("training.run.config", ""),
    "training.train": ("training.run.train", "train"),
    "training.sb3_vec": ("training.run.sb3_vec", ""),
    "training.from_zoo": ("training.run.from_zoo", "from-zoo"),
    "training.rollout": ("training.run.rollout", ""),
    "training.task_metrics": ("training.run.metrics", ""),
    "training.oracles": ("training.evaluate.oracles", "oracles"),
    "training.results": ("training.evaluate.results", "results"),
    "training.task_results": ("training.evaluate.task_results", "task-results"),
    "training.video": ("training.evaluate.video", ""),
    "training.plots": ("training.evaluate.plots", ""),
    "training.ik_demo": ("training.evaluate.ik_demo", "demo"),
    "training.aggregate": ("training.sweep.aggregate", "aggregate"),
    "training.hysteresis": ("training.studies.hysteresis", "hysteresis"),
    "training.sim2sim": ("training.studies.sim2sim", "sim2sim"),
    "training.step_response": ("training.studies.step_response", "step-response"),
    "training.transfer_probe": ("training.studies.transfer_probe", "transfer-probe"),
    "training.verification": ("training.studies.verification", "verification"),
    "training.bench": ("training.studies.bench", "bench"),
    "training.bench_realism": ("training.studies.bench_realism", "bench-realism"),
    "training.reproduce": ("training.studies.reproduce", "reproduce"),
    "training.reproduce.study": ("training.studies.reproduce.study", ""),
    "training.reproduce.plots": ("training.studies.reproduce.plots", ""),
    "training.reproduce.report": ("training.studies.reproduce.report", ""),
    "training.calibrate": ("training.studies.calibrate", "calibrate"),
    "training.bench_physics": ("training.studies.bench_physics", "bench-physics"),
    "training.oracle_feedback": ("training.evaluate.oracle_feedback", "oracle-feedback"),
    "training.cosserat_reference": ("training.studies.cosserat", "cosserat-reference"),
}


def alias(name: str, old: str) -> None:
    """Called at the top of the alias module ``old`` (its ``__name__`` is ``name``).

    Imported: replace it by the new module in ``sys.modules``. Run as ``__main__``: print a note
    and exit with the new module's ``main()``."""
    new, command = MOVED[old]
    if name == "__main__":
        module = importlib.import_module(new)
        hint = f"cdcr-gym {command}" if command else f"python -m {new}"
        print(f"note: python -m {old} is now `{hint}` (this alias still works)", file=sys.stderr)
        sys.exit(module.main())
    warnings.warn(f"{old} moved to {new}", DeprecationWarning, stacklevel=3)
    sys.modules[old] = importlib.import_module(new)
