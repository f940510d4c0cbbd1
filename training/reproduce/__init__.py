"""Deprecated alias of :mod:`training.studies.reproduce` (``cdcr-gym reproduce``): keeps
``python -m training.reproduce`` and ``from training.reproduce import ...`` working."""

import warnings

from training.studies.reproduce import *  # noqa: F403
from training.studies.reproduce import __all__  # noqa: F401

warnings.warn(
    "training.reproduce moved to training.studies.reproduce", DeprecationWarning, stacklevel=2
)
