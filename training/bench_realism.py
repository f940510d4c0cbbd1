"""Deprecated alias of :mod:`training.studies.bench_realism`: keeps ``python -m training.bench_realism`` (now ``cdcr-gym bench-realism``) and ``import training.bench_realism`` working."""

from training.deprecated import alias

alias(__name__, "training.bench_realism")
