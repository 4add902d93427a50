"""shbake — offline baking of spherical-harmonic lighting assets.

The conventions every part shares (SH basis, frames, image layouts) are in
``shbake.conventions`` and ``docs/CONVENTIONS.md``; the asset format is in
``docs/FORMAT.md``.
"""

__version__ = "0.1.0"
