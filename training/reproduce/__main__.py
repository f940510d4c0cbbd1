"""``python -m training.reproduce``: deprecated alias of ``cdcr-gym reproduce``."""

from training.deprecated import alias

alias(__name__, "training.reproduce")
