"""Deprecated alias of :mod:`training.studies.bench`: keeps ``python -m training.bench`` (now ``cdcr-gym bench``) and ``import training.bench`` working."""

from training.deprecated import alias

alias(__name__, "training.bench")
