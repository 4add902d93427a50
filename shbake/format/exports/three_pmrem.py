"""three.js glossy export: the GGX prefiltered cube chain as the PMREM texture three samples as is.

three r187 has no CubeUV layout any more: its PMREM is a cube texture with one mip level
per roughness, and ``WebGLEnvironments.getPMREM`` filters every environment again with
``PMREMGenerator`` unless the texture has ``isPMREMTexture``. ``--to threejs-pmrem``
writes shbake's chain (:mod:`shbake.bakers.cube_prefilter`) for that: a KTX2 RGBA16F cube
(:func:`.ktx2.write_cube_chain`), which ``KTX2Loader`` reads as a 2D ``DataTexture``
holding each level's six faces, turned into a ``CompressedCubeTexture`` with
``isPMREMTexture = true`` by the snippet of ``docs/EXPORTS.md`` (run verbatim by
``tests/engines/pages/three.mjs``).

* Levels at three's roughness: ``PMREMGenerator.lodToRoughness`` ``r = 1 − √(1 − lod/maxLod)``,
  inverted by ``roughnessToMip`` (``envmap_common_pars_fragment``): Filament's rule
  (``mapping = "filament"``, fixed), ``maxLod`` = the file's levels − 1.
* Faces in shbake's cube convention: three samples a cube texture at ``(−x, y, z)``
  (``WebGLMaterials``), as every shbake cube expects.
* The last level, ``α = 1``, is also three's diffuse (``getIBLIrradiance = π ×`` that level
  at the normal): GGX at ``α = 1`` has ``D = 1/π``, so it holds ``E(n)/π``.
"""

from shbake.format.exports.cube_chain import BLEND_MAX_ROUGHNESS
from shbake.format.exports.ktx2 import write_cube_chain
from shbake.format.exports.source import ExportSource, require_sh

EXTENSION = "_pmrem.ktx2"
OUTPUT_ENDINGS = (".ktx2",)
MIN_ROUGHNESS = 0.045
"""three's floor on roughness (``lights_physical_fragment``: ``max(roughnessFactor, 0.045)``):
it never reads the chain below ``lod = maxLod · 0.045 (2 − 0.045)``, so the levels it reads
only blended are refitted to that blend (:mod:`shbake.bakers.lod_blend`)."""

CUBES = {"size": 256, "floor": 4, "samples": 512, "mapping": "filament",
         "min_roughness": MIN_ROUGHNESS}  # fmt: skip
"""Seven levels, 256² to 4² faces, three's roughness↔LOD rule and roughness floor.

three blends linearly between the two levels around ``lod = maxLod · r(2 − r)``; with
seven levels (``maxLod`` 6) the blend stays within 3 % (median) of the true lobe at r 0.3
and 0.6 on the shared maps, where three's own six (256² to 8²) reach 17 % on studio; 128²
to 2² leaves the rough levels too coarse (4² faces at r 0.59: 9 % median)."""


BLENDED_NOTE = (
    f"; levels below r {BLEND_MAX_ROUGHNESS} hold the combination of the chain's lobes "
    f"whose linear blend fits three's reads (roughness floor {MIN_ROUGHNESS})"
)
"""How the ``shbake.content`` note names the refitted levels (:mod:`shbake.bakers.lod_blend`)."""


def write(src: ExportSource, out: str, levels, roughness, mapping: str = "filament", **_ignored):
    """Write the chain ``levels`` (three's mapping) to ``out`` (``…_pmrem.ktx2``)."""
    require_sh(src, "threejs-pmrem")
    write_cube_chain(out, src, levels, roughness, mapping, BLENDED_NOTE)
    return [out]


__all__ = ["CUBES", "EXTENSION", "MIN_ROUGHNESS", "OUTPUT_ENDINGS", "write"]
