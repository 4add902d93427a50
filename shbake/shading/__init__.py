"""What an engine's shader does with each asset, one module per technique.

``env_sh`` (SH irradiance plus the sun, the tangent matrix), ``kautz_table``
(rotate–fetch–dot), ``shexp`` (SH exponentials), ``splitsum`` (prefiltered
fetch × DFG), ``dfg`` (the albedo table look-up). Check-free numba kernels
behind thin validating wrappers; imports only ``sh``, ``texture``,
``conventions`` and ``jit``.
"""
