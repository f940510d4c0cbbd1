"""RobotParams ↔ YAML: the file a calibration writes and every env reads.

The format is a mapping of :class:`~cdcr_gym.model.params.RobotParams` fields in SI units
(m, kg, Pa, N, rad), the geometry as a list of sections::

    youngs_modulus: 28000000000.0
    backbone_diameter: 0.005
    max_tension: 80.0
    backbone_density: 1900.0
    disk_mass: 0.01
    disk_radius: 0.035
    disk_thickness: 0.003
    tendon_stiffness: 20000.0
    tendon_pretension: 2.0
    displacement_range: [-0.045, 0.045]
    sections:
    - length: 0.641
      n_disks: 9
      cable_radius: 0.0295
      cable_angles: [0.0, 2.0943951023931953, 4.1887902047863905]

Instead of ``sections`` a one-section robot may give ``length``, ``n_disks`` and
``cable_radius``; ``preset: paper`` starts from a named robot and the other keys override it.
The robot may also sit under a top-level ``robot:`` key, beside other sections of a larger file
(``cdcr-gym calibrate`` writes ``robot:``, ``backend:`` and ``calibration:``); only ``robot`` is
read here. Unknown keys are an error naming them. Floats are written with ``repr`` (exact round
trip: ``RobotParams.from_yaml(p.to_yaml()) == p``), in a form YAML 1.1 readers parse as floats.

``tendon_stiffness`` and ``tendon_pretension`` are a number or a list of one per cable;
``displacement_range`` is ``[d_min, d_max]`` (m); a stiffness of ``.inf`` (inextensible) round-trips.
``cable_pitch`` (rad/m, helical routing) is written only when it is not 0.
A mapping with a duplicate key (say ``max_tension`` twice) is refused naming the key, and so is a
section of the wrong type (``robot:``, ``backend:``, ``calibration:`` or a ``sections`` entry that
is a list or a string where a mapping is expected).

Reading needs PyYAML (the ``[train]`` extra); writing does not. The conversions live in
:mod:`cdcr_gym.model.params` (so ``RobotParams.to_yaml``/``from_yaml`` need no import back) and
the text I/O in :mod:`cdcr_gym.model.yaml_io`; this module gathers them (imports one way:
``yaml_io`` ← ``params`` ← ``params_yaml``).
"""

from __future__ import annotations

from pathlib import Path

from cdcr_gym.model.params import RobotParams, params_from_dict, params_to_dict
from cdcr_gym.model.yaml_io import dump_yaml, load_yaml

__all__ = ["params_to_dict", "params_from_dict", "dump_yaml", "to_yaml", "from_yaml", "load_yaml"]


def to_yaml(params: RobotParams, path: str | Path | None = None) -> str:
    """The YAML text of ``params``; also written to ``path`` if given."""
    if not isinstance(params, RobotParams):
        raise ValueError(f"params must be a RobotParams, got {params!r}")
    return params.to_yaml(path)


def from_yaml(source: str | Path) -> RobotParams:
    """RobotParams from a YAML file path or a YAML text (see the module docstring)."""
    return RobotParams.from_yaml(source)
