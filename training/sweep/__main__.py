"""``python -m training.sweep SWEEP.yaml ...``: the same as ``cdcr-gym sweep``."""

import sys

from training.sweep.tune import main

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
