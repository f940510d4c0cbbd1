"""Deprecated alias of :mod:`training.evaluate.task_results`: keeps ``python -m training.task_results`` (now ``cdcr-gym task-results``) and ``import training.task_results`` working."""

from training.deprecated import alias

alias(__name__, "training.task_results")
