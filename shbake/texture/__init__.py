"""Texel-centre rules and bilinear fetch for the parameterisations assets use.

One module per parameterisation (parabolic view hemisphere, octahedral
sphere, 2D look-up table); :mod:`shbake.texture.bilinear` holds the one
clamped bilinear rule they all share. Bakers use the texel → direction
maps, shaders the direction → texel fetches, so both agree by construction.
"""
