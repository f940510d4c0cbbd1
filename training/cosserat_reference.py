"""Deprecated alias of :mod:`training.studies.cosserat`: keeps ``python -m training.cosserat_reference`` (now ``cdcr-gym cosserat-reference``) and ``import training.cosserat_reference`` working."""

from training.deprecated import alias

alias(__name__, "training.cosserat_reference")
