"""GLSL ES 3.00 twins of the :mod:`shbake.shading` evaluators, shipped as package data.

One file per technique (``irradiance.glsl``, ``tangent_irradiance.glsl``, ``kautz.glsl``,
``shexp.glsl``,
``shrm.glsl``, ``splitsum.glsl`` with ``dfg.glsl``), each after ``common.glsl`` (the SH basis,
the bilinear rule); ``shbake_webgl.mjs`` loads an ``export --to webgl`` folder and
draws the passes; ``viewer.*`` is that folder's page. No Python code:
``docs/SHADERS.md`` documents the inputs.
"""
