"""The MuJoCo term probes of the FTDCR v4 robot (experiments/ftdcr_v4_mujoco_probes.py)."""

from __future__ import annotations

import pytest

from cdcr_gym.calibration.parameters import expand_names
from cdcr_gym.model.params import RobotParams
from experiments.ftdcr_v4_mujoco_probes import TERMS, _selection_module, candidates


def test_each_term_adds_its_names_to_the_selection_scripts_common_set():
    sel = _selection_module()
    got = candidates(["backbone_friction+k_sections", "mu"])
    assert got == {
        "backbone_friction+k_sections": (f"{sel.COMMON},backbone_friction,k_sections", False),
        "mu": (f"{sel.COMMON},mu", False),
    }
    with pytest.raises(ValueError, match="empty term"):
        candidates(["mu", "+"])


def test_every_probed_name_is_a_fit_name_and_the_zero_gradient_ones_get_a_start():
    """The default terms expand to fit names of the v4 robot; the names a CCKA fit does not
    give (backbone and capstan friction, softening) start away from zero."""
    sel = _selection_module()
    robot = RobotParams.from_yaml(sel.START)
    for fit, _ in candidates(TERMS).values():
        expand_names(fit, robot)  # raises on an unknown name
    assert "friction_coefficient" in expand_names("mu", robot)
    assert all(v > 0 for v in sel.STARTS.values())
    assert set(sel.STARTS) <= set(expand_names("backbone_friction,drive_softening,mu", robot))


def test_a_missing_script_is_a_value_error_naming_it():
    from pathlib import Path

    from experiments._config_script import load_script

    with pytest.raises(ValueError, match="configs/calibration/no_such.py: not found"):
        load_script(Path("configs/calibration/no_such.py"))
