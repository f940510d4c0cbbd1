"""Deprecated alias of :mod:`training.studies.transfer_probe`: keeps ``python -m training.transfer_probe`` (now ``cdcr-gym transfer-probe``) and ``import training.transfer_probe`` working."""

from training.deprecated import alias

alias(__name__, "training.transfer_probe")
