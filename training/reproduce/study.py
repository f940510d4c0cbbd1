"""Deprecated alias of :mod:`training.studies.reproduce.study`: keeps ``import training.reproduce.study`` working."""

from training.deprecated import alias

alias(__name__, "training.reproduce.study")
