"""Evaluation: shading from assets against brute-force references, as numbers.

Reads assets (``shbake.format``), shades them (``shbake.shading``) and
compares with ``shbake.reference``; never imports a baker.
"""
