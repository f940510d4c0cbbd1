"""Deprecated alias of :mod:`training.studies.sim2sim`: keeps ``python -m training.sim2sim`` (now ``cdcr-gym sim2sim``) and ``import training.sim2sim`` working."""

from training.deprecated import alias

alias(__name__, "training.sim2sim")
