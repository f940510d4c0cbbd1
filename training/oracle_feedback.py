"""Deprecated alias of :mod:`training.evaluate.oracle_feedback`: keeps ``python -m training.oracle_feedback`` (now ``cdcr-gym oracle-feedback``) and ``import training.oracle_feedback`` working."""

from training.deprecated import alias

alias(__name__, "training.oracle_feedback")
