"""What an engine's shader does with each asset, one module per technique.

Each module defines a shader object (:mod:`shbake.shading.shader`: ``from_asset``,
``shade``, ``inputs``) registered under its technique name — ``env_sh`` (``irradiance``,
``tangent``, ``tangent-sh``), ``brdf_table`` (``kautz``), ``shrm`` (``shrm``), ``shexp``
(``shexp``), ``splitsum`` (``splitsum``) — over check-free numba kernels behind thin
validating wrappers; ``dfg`` is the albedo-table look-up they share. The registry
(:mod:`shbake.shading.shader`) imports the modules when first asked, so importing one
shading module loads no other. Imports ``sh``, ``texture``, ``brdf`` and ``format`` (typed
views of assets).
"""
