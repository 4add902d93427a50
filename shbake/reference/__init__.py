"""Brute-force integrators: the independent reference for previews, reports and tests."""
