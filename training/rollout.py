"""Deprecated alias of :mod:`training.run.rollout`: keeps ``import training.rollout`` working."""

from training.deprecated import alias

alias(__name__, "training.rollout")
