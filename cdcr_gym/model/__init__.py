"""The robot model: pure numpy math, no Gymnasium and no simulator.

``params`` describes the robot (sections, cables, material); the other modules compute with it.
"""
