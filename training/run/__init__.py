"""Training runs: the experiment config, the run directory and its checkpoints, provenance,
the algorithms' constructor arguments, the callbacks and the training loop.

``cdcr-gym train CONFIG`` (:mod:`training.run.train`) is the command; ``cdcr-gym from-zoo``
(:mod:`training.run.from_zoo`) turns an RL Baselines3 Zoo run into a run directory.
"""
