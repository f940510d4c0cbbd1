"""Deprecated alias of :mod:`training.studies.bench_physics`: keeps ``python -m training.bench_physics`` (now ``cdcr-gym bench-physics``) and ``import training.bench_physics`` working."""

from training.deprecated import alias

alias(__name__, "training.bench_physics")
