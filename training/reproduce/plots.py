"""Deprecated alias of :mod:`training.studies.reproduce.plots`: keeps ``import training.reproduce.plots`` working."""

from training.deprecated import alias

alias(__name__, "training.reproduce.plots")
