"""Deprecated alias of :mod:`training.run.from_zoo`: keeps ``python -m training.from_zoo`` (now ``cdcr-gym from-zoo``) and ``import training.from_zoo`` working."""

from training.deprecated import alias

alias(__name__, "training.from_zoo")
