"""Deprecated alias of :mod:`training.studies.step_response`: keeps ``python -m training.step_response`` (now ``cdcr-gym step-response``) and ``import training.step_response`` working."""

from training.deprecated import alias

alias(__name__, "training.step_response")
