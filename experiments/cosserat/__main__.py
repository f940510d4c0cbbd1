"""``python -m experiments.cosserat``: the Cosserat reference generator (see its ``--help``)."""

from experiments.cosserat.reference import main

raise SystemExit(main())
