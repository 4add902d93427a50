"""Preview: emulates the GPU shading passes from asset files alone.

Imports :mod:`shbake.format` and the SH basis, never a baker. Its
``reference`` passes integrate the original map by brute force
(:mod:`shbake.reference`) so every asset can be seen next to the truth.
"""
