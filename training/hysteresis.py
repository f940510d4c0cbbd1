"""Deprecated alias of :mod:`training.studies.hysteresis`: keeps ``python -m training.hysteresis`` (now ``cdcr-gym hysteresis``) and ``import training.hysteresis`` working."""

from training.deprecated import alias

alias(__name__, "training.hysteresis")
