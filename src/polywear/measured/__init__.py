"""Measured data in: run-ups and their Campbell maps, calibration of parameters to
observations, and tyre property files (.tir). Stands on the dynamics and the wear."""
