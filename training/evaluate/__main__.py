"""``python -m training.evaluate RUN_DIR ...``: the same as ``cdcr-gym evaluate``."""

import sys

from training.evaluate.agent import main

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
