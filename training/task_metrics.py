"""Deprecated alias of :mod:`training.run.metrics`: keeps ``import training.task_metrics`` working."""

from training.deprecated import alias

alias(__name__, "training.task_metrics")
