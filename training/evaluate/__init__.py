"""Evaluation: one pipeline for every task — fixed-seed rollouts of any policy beside its task's
oracle and baselines, results tables, figures and episode videos.

``cdcr-gym evaluate RUN_DIR`` (:mod:`training.evaluate.agent`; ``python -m training.evaluate``
runs it too) evaluates a trained run; ``cdcr-gym oracles``, ``results`` and
``demo`` are the other commands of this room. The episodes themselves are run by
:mod:`training.run.rollout` and :mod:`training.run.metrics` (the periodic evaluation during
training uses the same functions).
"""
