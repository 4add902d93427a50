"""Bakers: one module per technique, each turning inputs into an asset (``shbake.format``).

``env_sh`` (SH lighting and irradiance), ``shexp`` (SH-exponential probe fit)
with its targets, ``splitsum`` (prefiltered mip chain), ``dfg`` (the shared
albedo table), ``brdf_table_report``/``shexp_report`` (what a setting costs).
Nothing downstream (shading, preview, evaluation) imports a baker.
"""
