"""``python -m training.studies.cosserat`` = ``cdcr-gym cosserat-reference``."""

from training.studies.cosserat.reference import main

raise SystemExit(main())
