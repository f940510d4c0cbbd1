"""Deprecated alias of :mod:`training.evaluate.video`: keeps ``import training.video`` working."""

from training.deprecated import alias

alias(__name__, "training.video")
