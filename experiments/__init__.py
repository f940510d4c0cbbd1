"""One-off studies and benchmarks of the models and backends, kept apart from the product.

They are not in the wheel nor in ``cdcr-gym --help``; from a checkout each runs as
``python -m experiments.<name>`` (``--help`` for its options):

* ``verification``: the pybullet backend against closed-form mechanics;
* ``cosserat``: the converged Cosserat-rod reference and the models' errors against it;
* ``hysteresis``, ``friction_chatter``: cable friction (load-unload cycles, settling of holds);
* ``step_response``: the tip step response, physics vs CCKA;
* ``sim2sim``, ``transfer_probe``: zero-shot sim-to-sim evaluations and probes of the gap;
* ``oracle_feedback``: open- vs closed-loop oracles on the same episodes;
* ``bench_compare``, ``bench_realism``, ``bench_single``: one-off throughput measurements.

Experiments may import ``cdcr_gym`` and ``training``; nothing in them imports this package.
"""
