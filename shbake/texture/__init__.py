"""Texel-centre rules and filtered fetches, one module per parameterisation."""
