"""Texel-centre rules and bilinear fetch for the parameterisations assets use.

One module per parameterisation (parabolic view hemisphere, octahedral
sphere, cube map); :mod:`shbake.texture.bilinear` holds the one clamped
bilinear rule they all share (the DFG look-up table reads it too). Bakers use the texel → direction
maps, shaders the direction → texel fetches, so both agree by construction.
"""
