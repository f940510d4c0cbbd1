"""What users run beside training and evaluation: the paper's reproduction (``cdcr-gym
reproduce``), the throughput benchmark (``cdcr-gym bench``), the physics backends' benchmark
(``cdcr-gym bench-physics``) and the calibration from measured tip positions (``cdcr-gym
calibrate``). One-off studies live in the checkout's ``experiments/`` package."""
