"""Bakers: one module per technique (environment → asset arrays)."""
