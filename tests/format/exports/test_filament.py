"""Filament exports (:mod:`shbake.format.exports.filament`): cmgen's ``sh.txt`` and KTX 1.1
``sh`` metadata evaluated by Filament's ``irradianceSH`` polynomial, the skybox read by a
KTX 1.1 reader written from the specification.
"""

import numpy as np

from shbake.batch.export import export_assets
from shbake.format.exports.source import load_source
from shbake.sh.windows import fibonacci_sphere
from tests.export_checks import N_DIRS
from tests.export_checks import sh9_polynomials as _poly


class TestFilament:
    """filament.write: cmgen's sh.txt / KTX ``sh`` metadata read by Filament's ``irradianceSH``.

    Not Filament's own code (no CPU build of it runs here): the shader's polynomial
    (``irradianceSH``, quoted in the module docstring) evaluated on the parsed text.
    """

    @staticmethod
    def _parse_sh_txt(path: str) -> np.ndarray:
        rows = []
        for line in open(path):
            inner = line.split("(", 1)[1].split(")", 1)[0]
            rows.append([float(v) for v in inner.split(",")])
        return np.array(rows)

    def test_sh_txt_gives_e_over_pi(self, sky_asset):
        out = str(sky_asset["dir"] / "f_sh.txt")
        files = export_assets([sky_asset["h5"]], "filament", out, size=8, floor=1, samples=16)
        sh = self._parse_sh_txt(files[0])
        d = fibonacci_sphere(N_DIRS)
        src = load_source(sky_asset["h5"])
        from shbake.sh.basis import real_sh

        want = real_sh(d, 2) @ src.irradiance9 / np.pi
        got = _poly(d) @ sh
        assert np.abs(got - want).max() < 1e-12 * np.abs(want).max() + 1e-14
        assert np.abs(_poly(d * [-1, 1, 1]) @ sh - want).max() > 1e-3 * np.abs(want).max()
        assert np.abs(np.pi * got - want).max() > 1e-3 * np.abs(want).max()
        assert any(f.endswith("_sun.json") for f in files)

    def test_ktx1_metadata_and_levels(self, sky_asset):
        """A KTX 1.1 reader written from the spec (§2) and GL's packed-float rule reads back
        the sh, cmgen's R11F_G11F_B10F header and the mirror level in Filament's orientation
        (mirrored in x: Filament samples world d at GL d)."""
        import struct

        from shbake.bakers.cube_prefilter import cube_directions, mirror_cube, mirror_supersample

        out = str(sky_asset["dir"] / "k_sh.txt")
        export_assets([sky_asset["h5"]], "filament", out, size=8, floor=1, samples=16)
        data = open(str(sky_asset["dir"] / "k_skybox.ktx"), "rb").read()
        assert data[:12] == bytes.fromhex("ab4b5458203131bb0d0a1a0a")
        h = struct.unpack_from("<13I", data, 12)
        assert h[0] == 0x04030201 and (h[1], h[3], h[4], h[5]) == (0x8C3A, 0x1907, 0x8C3A, 0x1907)
        assert (h[6], h[10], h[11]) == (8, 6, 1)
        pos, kv = 64, {}
        while pos < 64 + h[12]:
            (n,) = struct.unpack_from("<I", data, pos)
            key, value = data[pos + 4 : pos + 4 + n].split(b"\0", 1)
            kv[key.decode()] = value.rstrip(b"\0").decode()
            pos += 4 + n + (-n % 4)
        sh_meta = np.array([[float(v) for v in ln.split()] for ln in kv["sh"].strip().split("\n")])
        np.testing.assert_allclose(sh_meta, self._parse_sh_txt(out), rtol=1e-8, atol=1e-12)
        (size,) = struct.unpack_from("<I", data, pos)
        assert size == 8 * 8 * 4
        packed = np.frombuffer(data[pos + 4 : pos + 4 + 6 * size], "<u4").reshape(6, 8, 8)

        def unpack(bits, mbits):  # unsigned float, 5-bit exponent (GL ES 3.0 §2.1.3)
            e, m = bits >> mbits, (bits & ((1 << mbits) - 1)) / 2.0**mbits
            return np.where(e == 0, m * 2.0**-14, (1 + m) * 2.0 ** (e.astype(float) - 15))

        faces = np.stack([unpack(packed & 0x7FF, 6), unpack((packed >> 11) & 0x7FF, 6),
                          unpack(packed >> 22, 5)], -1)  # fmt: skip
        # Filament's texel at GL direction g shows world g: shbake's mirror cube (texel at GL g
        # shows world (-g_x, g_y, g_z)) looked up at GL (-g_x, g_y, g_z)
        residual = load_source(sky_asset["h5"]).environment()
        shbake_cube = mirror_cube(residual, 8, mirror_supersample(residual, 8))
        d = cube_directions(8)[0]  # world directions of shbake's texels
        gl_of_filament_texel = d * [-1, 1, 1]  # Filament's texel (k, i, j) shows world = its GL g
        want = np.empty_like(shbake_cube)
        for k in range(6):  # the shbake texel whose world direction is that g
            for i in range(8):
                for j in range(8):
                    g = gl_of_filament_texel[k, i, j]
                    match = np.argmax(d.reshape(-1, 3) @ g)
                    want[k, i, j] = shbake_cube.reshape(-1, 3)[match]
        np.testing.assert_allclose(faces, want, rtol=2**-5, atol=1e-6)  # 5-bit mantissa (B)
        assert np.abs(faces - shbake_cube).max() > 0.1 * shbake_cube.max()  # really mirrored
