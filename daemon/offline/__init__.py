"""Offline tools: station reference data, calibration of R, comparison and reports."""
