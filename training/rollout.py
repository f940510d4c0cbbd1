"""Deprecated alias of :mod:`training.evaluate.rollout`: keeps ``import training.rollout`` working."""

from training.deprecated import alias

alias(__name__, "training.rollout")
