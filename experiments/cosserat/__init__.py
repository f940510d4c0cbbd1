"""A converged Cosserat-rod reference for the physics backends (``python -m experiments.cosserat``).

* :mod:`~experiments.cosserat.rod` — the robot as a Cosserat rod with cable point loads at
  the disks, and its static solver by shooting (also with capstan-decayed segment tensions);
* :mod:`~experiments.cosserat.pyelastica_solver` — PyElastica 1.0 as the cross-check;
* :mod:`~experiments.cosserat.reference` — the committed JSON (cases, writing, reading) and
  the comparison of the package's models with it.

JSON schema (``docs/figures/physics/cosserat_reference.json``)
    Top level: ``generator`` (the command that wrote the file), ``package_version``
    (``cdcr_gym.__version__``), ``date`` (UTC, ISO 8601), ``frame`` (a sentence: R0, base disk
    centre, backbone +Z0, cable 1 at +X0, metres), ``model`` (a sentence: the load model
    above), ``cases`` (a list). Each case:

    * ``name`` (str), ``robot`` (preset name for ``RobotParams.preset``), ``gravity`` (bool),
      ``tensions`` (list of N, package cable order: section by section, within a section the
      order of its ``cable_angles``);
    * ``tip`` ([x, y, z] m, R0): the reference tip (the tip-disk centre), from ``solver``;
    * ``disk_centres`` ([[x, y, z], …] m, R0): the base disk then every spacer disk;
    * ``solver`` (``"cosserat_shooting"``), ``mesh`` (``null``: adaptive ODE, no mesh),
      ``rtol`` (its tolerance), ``convergence_delta`` (m: tip change when the tolerance is
      divided by 100);
    * ``pyelastica`` (``null`` or a dict): ``tip`` (m), ``elements_per_span`` (the mesh of that
      tip), ``convergence_delta`` (m: tip change from half that mesh), ``difference_to_reference``
      (m: |tip − reference tip|), ``final_velocity`` (m/s, max node speed at the end of the
      relaxation), ``seconds`` (CPU wall time of the run).
    * ``command`` (str): the command that made this case.

Regenerate (static solver only, ~1 min; add ``--pyelastica`` to rerun the cross-check cases,
~3–7 min per case on a shared 2-core machine)::

    python -m experiments.cosserat --write docs/figures/physics/cosserat_reference.json

Compare the package's models with it::

    python -m experiments.cosserat --study
"""

from experiments.cosserat.pyelastica_solver import solve_pyelastica
from experiments.cosserat.reference import (
    CASES,
    REFERENCE_PATH,
    load_reference,
    main,
    model_tips,
    reference_cases,
    refine_pyelastica,
    study,
    write_reference,
)
from experiments.cosserat.rod import (
    POISSON_RATIO,
    SHEAR_FACTOR,
    RodModel,
    StaticSolution,
    capstan_segment_tensions,
    solve_static,
    solve_static_capstan,
)

__all__ = [
    "CASES",
    "POISSON_RATIO",
    "REFERENCE_PATH",
    "SHEAR_FACTOR",
    "RodModel",
    "StaticSolution",
    "capstan_segment_tensions",
    "load_reference",
    "main",
    "model_tips",
    "reference_cases",
    "refine_pyelastica",
    "solve_pyelastica",
    "solve_static",
    "solve_static_capstan",
    "study",
    "write_reference",
]
