"""Deprecated alias of :mod:`training.evaluate.results`: keeps ``python -m training.results`` (now ``cdcr-gym results``) and ``import training.results`` working."""

from training.deprecated import alias

alias(__name__, "training.results")
