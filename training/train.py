"""Deprecated alias of :mod:`training.run.train`: keeps ``python -m training.train`` (now ``cdcr-gym train``) and ``import training.train`` working."""

from training.deprecated import alias

alias(__name__, "training.train")
