"""Sensor models, each sampled at its own sim-time rate for every due robot at once."""
