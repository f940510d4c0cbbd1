"""Studies that use the envs and the pipeline: the paper's reproduction, the cable-friction
hysteresis, sim-to-sim transfer, the actuator step response, the pybullet verification against
closed-form mechanics, and the throughput benchmarks (``cdcr-gym bench``)."""
