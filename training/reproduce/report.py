"""Deprecated alias of :mod:`training.studies.reproduce.report`: keeps ``import training.reproduce.report`` working."""

from training.deprecated import alias

alias(__name__, "training.reproduce.report")
