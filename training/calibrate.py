"""Deprecated alias of :mod:`training.studies.calibrate`: keeps ``python -m training.calibrate`` (now ``cdcr-gym calibrate``) and ``import training.calibrate`` working."""

from training.deprecated import alias

alias(__name__, "training.calibrate")
