"""``python -m training.studies.reproduce``: run the study (see :mod:`training.studies.reproduce.study`)."""

import sys

from training.studies.reproduce.cli import main

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
