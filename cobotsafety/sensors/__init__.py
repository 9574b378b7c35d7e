"""Sensor pipelines: the 2D laser (legs -> torso) and the IMU limb chain."""
