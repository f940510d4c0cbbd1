"""Deprecated alias of :mod:`training.evaluate.plots`: keeps ``import training.plots`` working."""

from training.deprecated import alias

alias(__name__, "training.plots")
