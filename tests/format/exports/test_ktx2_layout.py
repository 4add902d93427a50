"""The KTX2 writer's byte layout against rules of the KTX 2.0 specification.

The engines' reader (ktx-parse, tests/format/exports/test_ktx2.py) accepts any level
offset; libktx's ``ktx validate`` does not (error 4004 when the mip padding
is not exactly ``lcm(texel block size, 4)``, spec §3.9.7). The rules are
written here from the specification, not from the writer.
"""

import math
import struct

import numpy as np
import pytest

from shbake.format.exports.ktx2 import encode_ktx2


def _level_index(data: bytes) -> tuple[int, list[tuple[int, int]]]:
    """(end of the key/value data, [(byteOffset, byteLength)] per level) read from the header."""
    level_count = struct.unpack_from("<I", data, 12 + 4 * 7)[0]
    kvd_off, kvd_len = struct.unpack_from("<2I", data, 12 + 4 * 9 + 8)
    index = [struct.unpack_from("<2Q", data, 80 + 24 * i) for i in range(level_count)]
    return kvd_off + kvd_len, index


class TestEncodeKtx2:
    @pytest.mark.parametrize(
        ("levels", "cube", "texel_bytes"),
        [
            ([np.ones((6, n, n, 4)) for n in (8, 4, 2, 1)], True, 8),  # RGBA16F cube chain
            ([np.ones((5, 7, 2))], False, 4),  # RG16F table (odd sizes)
            ([np.ones((3, 3, 2)), np.ones((1, 1, 2))], False, 4),
        ],
    )
    @pytest.mark.parametrize("kv", [{}, {"a": "x"}, {"shbake.dfg": "yy"}])
    def test_mip_padding_is_exactly_the_spec_alignment(self, levels, cube, texel_bytes, kv):
        data = encode_ktx2(levels, cube, kv)
        align = math.lcm(texel_bytes, 4)
        prev_end, index = _level_index(data)
        for off, length in reversed(index):  # stored smallest level first
            assert off % align == 0
            assert 0 <= off - prev_end < align  # padding is the least that aligns
            prev_end = off + length
        assert prev_end == len(data)

    @pytest.mark.parametrize("layers", [0, 1, 3])
    def test_float32_2d_and_arrays(self, layers):
        """RGBA32F (``VK_FORMAT_R32G32B32A32_SFLOAT`` = 109, ``typeSize`` 4), ``layerCount``
        0 for a 2D texture and the layers of an array (spec §3.4), the level the layers one
        after the other, padded to ``lcm(16, 4)`` = 16 bytes."""
        texels = np.arange((layers or 1) * 5 * 7 * 4, dtype=np.float32)
        texels = texels.reshape(((layers,) if layers else ()) + (5, 7, 4))
        data = encode_ktx2([texels], False, {"a": "x"}, type_size=4, layered=layers > 0)
        header = struct.unpack_from("<9I", data, 12)
        assert header == (109, 4, 7, 5, 0, layers, 1, 1, 0)
        prev_end, [(off, length)] = _level_index(data)
        assert off % 16 == 0 and 0 <= off - prev_end < 16 and off + length == len(data)
        assert data[off:] == texels.astype("<f4").tobytes()
