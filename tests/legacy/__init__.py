"""The one-section model as it was before the n-section refactor (commit 8f29f58), frozen.

Kept only as an independent reference for parity tests (``tests/test_model_*.py``): the new
``cdcr_gym.model`` must give the same results for the paper robot. Not part of the package.
"""
