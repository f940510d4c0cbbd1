"""Sweeps: grids of experiments run as Ray Tune trials (:mod:`training.sweep.tune`,
``cdcr-gym sweep``), and their aggregation with IQMs, bootstrap confidence intervals and
performance profiles (:mod:`training.sweep.aggregate`, :mod:`training.sweep.statistics`,
``cdcr-gym aggregate``)."""
