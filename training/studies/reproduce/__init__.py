"""The paper's CCKA-vs-physics study: ``python -m training.reproduce [--out DIR] ...``.

The paper (section 4) compares the constant-curvature kinematics (CCKA) with a nonlinear
simulation of its robot; this subpackage repeats that study on the pybullet backbone and extends
it (gravity, tip payload, model resolution, number of disks, horizontal base):

- :mod:`training.reproduce.study`: the sweeps, the settling check, the CSV/JSON outputs and the
  command line (everything below is re-exported here);
- :mod:`training.reproduce.plots`: the figures (matplotlib, PNG);
- :mod:`training.reproduce.report`: the Markdown report, its numbers computed from the run.
"""

from training.studies.reproduce.study import (
    DEFAULT_OUT,
    HORIZONTAL_BASE,
    PAPER_RESULTS,
    SWEEP_HEADER,
    BackendFactory,
    CCKASweep,
    SettleError,
    SettleInfo,
    StudyConfig,
    StudyResults,
    Sweep,
    backend_configs,
    build_parser,
    bullet_factory,
    cable1_tensions,
    ccka_cable_sweep,
    config_from_args,
    main,
    preflight,
    quick_config,
    robot_mass,
    run_force_sweep,
    run_study,
    settle,
    summary_rows,
    sweep_rows,
    tip_of,
    write_outputs,
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
