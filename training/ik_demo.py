"""Deprecated alias of :mod:`training.evaluate.ik_demo`: keeps ``python -m training.ik_demo`` (now ``cdcr-gym demo``) and ``import training.ik_demo`` working."""

from training.deprecated import alias

alias(__name__, "training.ik_demo")
