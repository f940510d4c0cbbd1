"""Deprecated alias of :mod:`training.run.config`: keeps ``import training.config`` working."""

from training.deprecated import alias

alias(__name__, "training.config")
