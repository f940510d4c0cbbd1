"""Deprecated alias of :mod:`training.sweep.aggregate`: keeps ``python -m training.aggregate`` (now ``cdcr-gym aggregate``) and ``import training.aggregate`` working."""

from training.deprecated import alias

alias(__name__, "training.aggregate")
