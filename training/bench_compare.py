"""Moved to ``training/studies/bench_compare.py``; this path still runs it as a script."""

import runpy
from pathlib import Path

if __name__ == "__main__":  # pragma: no cover
    runpy.run_path(str(Path(__file__).parent / "studies" / "bench_compare.py"), run_name="__main__")
