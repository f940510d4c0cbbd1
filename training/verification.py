"""Deprecated alias of :mod:`training.studies.verification`: keeps ``python -m training.verification`` (now ``cdcr-gym verification``) and ``import training.verification`` working."""

from training.deprecated import alias

alias(__name__, "training.verification")
