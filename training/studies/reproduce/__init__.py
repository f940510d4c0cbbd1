"""The paper's CCKA-vs-physics study: ``cdcr-gym reproduce [--out DIR] ...``.

The paper (section 4) compares the constant-curvature kinematics (CCKA) with a nonlinear
simulation of its robot; this subpackage repeats that study on a physics backbone — MuJoCo by
default (``--backend mujoco``, the reference physics), or pybullet (``--backend bullet``) — and
extends it (gravity, tip payload, model resolution, number of disks, horizontal base):

- :mod:`training.studies.reproduce.study`: the sweeps and the settling check;
- :mod:`training.studies.reproduce.outputs`: the CSV/JSON outputs, figures and report of a run;
- :mod:`training.studies.reproduce.cli`: the command line (``cdcr-gym reproduce``);
- :mod:`training.studies.reproduce.plots`: the figures (matplotlib, PNG);
- :mod:`training.studies.reproduce.report`: the Markdown report, its numbers computed from the run.

Everything public is re-exported here. Imports run one way: study <- plots, report <- outputs
<- cli (no circle).
"""

from training.studies.reproduce.cli import build_parser, config_from_args, main, quick_config
from training.studies.reproduce.outputs import (
    SWEEP_HEADER,
    summary_rows,
    sweep_rows,
    write_outputs,
)
from training.studies.reproduce.study import (
    DEFAULT_OUT,
    HORIZONTAL_BASE,
    PAPER_RESULTS,
    BackendFactory,
    CCKASweep,
    SettleError,
    SettleInfo,
    StudyConfig,
    StudyResults,
    Sweep,
    backend_configs,
    bullet_factory,
    cable1_tensions,
    ccka_cable_sweep,
    mujoco_factory,
    preflight,
    robot_mass,
    run_force_sweep,
    run_study,
    settle,
    tip_of,
)

__all__ = [
    "DEFAULT_OUT",
    "HORIZONTAL_BASE",
    "PAPER_RESULTS",
    "SWEEP_HEADER",
    "BackendFactory",
    "CCKASweep",
    "SettleError",
    "SettleInfo",
    "StudyConfig",
    "StudyResults",
    "Sweep",
    "backend_configs",
    "build_parser",
    "bullet_factory",
    "mujoco_factory",
    "cable1_tensions",
    "ccka_cable_sweep",
    "config_from_args",
    "main",
    "preflight",
    "quick_config",
    "robot_mass",
    "run_force_sweep",
    "run_study",
    "settle",
    "summary_rows",
    "sweep_rows",
    "tip_of",
    "write_outputs",
]
