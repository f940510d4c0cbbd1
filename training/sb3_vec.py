"""Deprecated alias of :mod:`training.run.sb3_vec`: keeps ``import training.sb3_vec`` working."""

from training.deprecated import alias

alias(__name__, "training.sb3_vec")
