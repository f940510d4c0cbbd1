"""Deprecated alias of :mod:`training.evaluate.oracles`: keeps ``python -m training.oracles`` (now ``cdcr-gym oracles``) and ``import training.oracles`` working."""

from training.deprecated import alias

alias(__name__, "training.oracles")
