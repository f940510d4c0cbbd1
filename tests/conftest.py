"""The test tree mirrors the package (model/, backends/, tasks/, envs/, and top-level files for
the top-level modules). This file's directory is on ``sys.path`` (pytest's rootdir conftest), so
the helpers here (``pinned_trajectories``, ...) import from every subdirectory."""
