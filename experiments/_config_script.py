"""Import a script of ``configs/calibration/`` (not a package) as a module, from the checkout.

Shared by ``experiments.ftdcr_v4_term_selection`` and ``experiments.ftdcr_v4_mujoco_probes``.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

__all__ = ["load_script"]


def load_script(path: Path) -> ModuleType:
    """The module of the script at ``path`` (relative to the checkout's root, the working
    directory); a ValueError names the path when it is not there."""
    spec = importlib.util.spec_from_file_location(path.stem, path)
    if spec is None or spec.loader is None or not path.is_file():
        raise ValueError(f"{path}: not found (run from the checkout)")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
