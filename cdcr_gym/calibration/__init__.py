"""Calibrating a simulated robot to measured tip positions (``cdcr-gym calibrate``).

* :mod:`~cdcr_gym.calibration.data` — the measurement CSV (tensions, hanging masses or tendon
  displacements, tips, loading direction, σ, timestamps), the published real-robot format, and
  their readers;
* :mod:`~cdcr_gym.calibration.drive` — the CCKA model of a displacement-driven robot (drive law
  with slack, base frame, marker), batched over rows and parameter sets;
* :mod:`~cdcr_gym.calibration.parameters` — what can be fitted (E, cable radius and angles,
  friction, payload, base tilt), scaled and bounded;
* :mod:`~cdcr_gym.calibration.simulate` — the forward models: the batched CCKA/PCC model, or a
  physics backend replayed through the rows in order (friction hysteresis);
* :mod:`~cdcr_gym.calibration.fit` — ``scipy.optimize.least_squares`` and the confidence
  intervals;
* :mod:`~cdcr_gym.calibration.report` — ``params.yaml``, ``report.md``, ``report.json`` and the
  residual figure (written atomically).

Usage::

    from cdcr_gym.calibration import read_csv, calibrate, write_outputs
    from cdcr_gym.params import RobotParams

    data = read_csv("configs/calibration/paper_cable1.csv")
    result = calibrate(data, RobotParams(), "E,mu,payload", backend="bullet")
    write_outputs(result, "runs/calib")     # params.yaml, report.md, residuals.png
"""

from cdcr_gym.calibration.data import Measurements, read_csv, read_published, write_csv
from cdcr_gym.calibration.drive import TendonDrive
from cdcr_gym.calibration.fit import CalibrationResult, calibrate
from cdcr_gym.calibration.report import (
    backend_kwargs_from_yaml,
    load_fitted,
    plot_residuals,
    report_json,
    report_markdown,
    twin_kwargs_from_yaml,
    write_outputs,
    write_params_yaml,
)

__all__ = [
    "Measurements",
    "read_csv",
    "read_published",
    "write_csv",
    "TendonDrive",
    "report_json",
    "CalibrationResult",
    "calibrate",
    "write_outputs",
    "write_params_yaml",
    "report_markdown",
    "plot_residuals",
    "load_fitted",
    "backend_kwargs_from_yaml",
    "twin_kwargs_from_yaml",
]
