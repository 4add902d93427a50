"""KTX 2.0 files: half-float cube mip chains and 2D tables, float32 2D and 2D-array textures
(Khronos KTX 2.0 specification).

libktx's Python binding (``pyktx``) ships only as a source package that needs
libktx installed; Debian has no libktx package and nothing may be downloaded at
run time, so this is a small writer of uncompressed KTX2 (no supercompression),
checked against an independent reader: ``ktx-parse`` (Don McCurdy), the KTX2
parser three.js vendors (``three/examples/jsm/libs/ktx-parse.module.js``),
run under node by ``tests/format/exports/test_ktx2.py`` and ``tests/system/test_webgl_shaders.py``;
libktx itself (pyktx, ``ktx validate``) by hand with ``bench/ktx2_libktx.py``.

Layout written (KTX 2.0 spec §3): identifier, header (``vkFormat`` of
:data:`VK_FORMAT`: 97 ``R16G16B16A16_SFLOAT``, 83 ``R16G16_SFLOAT`` with
``typeSize`` 2; 109 ``R32G32B32A32_SFLOAT``, 103 ``R32G32_SFLOAT`` with
``typeSize`` 4; faces 6 or 1, ``layerCount`` 0 or the array's layers,
``levelCount``), level index, a Basic Data Format Descriptor (``RGBSDA``
colour model, BT.709 primaries, linear transfer, one sample per channel
flagged float|signed with lower −1.0f / upper 1.0f, KDFS 1.3 §5.6), key/value
data sorted by key (``KTXwriter``, ``shbake.*``), then the mip levels from the
smallest to the largest (spec §3.9), each at the first offset that is a
multiple of ``lcm(texel block size, 4)`` (spec §3.9.7: 8 bytes for RGBA16F, 4
for RG16F, 16 for RGBA32F; ``ktx validate`` rejects any other padding), layers
then faces +X, −X, +Y, −Y, +Z, −Z inside a level, rows top first.

The ``ktx2`` export target writes the GGX prefiltered cube chain of
:mod:`shbake.bakers.cube_prefilter` (level 0 = mirror map, α = 0) and, beside
it, the DFG table ``(A0, A1)`` of :mod:`shbake.bakers.dfg` as a 2D
RG16F KTX2 and an EXR (what cmgen ``--ibl-dfg`` provides): column ``j`` is
``n·v``, row ``i`` perceptual roughness, node-centred from (1e-3, 0.02) to
(1, 1); the axes are recorded in the key/value data and EXR attributes. The
``webgl`` target writes its textures as float32 2D and 2D-array KTX2
(:mod:`shbake.format.exports.webgl`).
"""

import json
import math
import os
import struct

import numpy as np

from shbake.errors import FormatError, OutputError, ParameterError
from shbake.format.atomic import atomic_path
from shbake.format.exports.cube_chain import FIT_MAX_SIZE
from shbake.format.exports.source import ExportSource
from shbake.format.images import clamp_to_half

EXTENSION = ".ktx2"
OUTPUT_ENDINGS = (".ktx2",)
IDENTIFIER = bytes([0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A])
VK_FORMAT = {
    (2, 4): 97,  # R16G16B16A16_SFLOAT
    (2, 2): 83,  # R16G16_SFLOAT
    (4, 4): 109,  # R32G32B32A32_SFLOAT
    (4, 2): 103,  # R32G32_SFLOAT
}
"""``(typeSize in bytes, channels)`` → ``vkFormat`` (Vulkan ``VkFormat`` numbers)."""
_CHANNEL_IDS = {4: (0, 1, 2, 15), 2: (0, 1)}  # KHR_DF_CHANNEL_RGBSDA_R, G, B, ALPHA
HALF_MAX = 65504.0
_TYPES = {2: ("<f2", HALF_MAX, "half floats"), 4: ("<f4", float(np.finfo("<f4").max), "float32")}
"""typeSize → (numpy type, largest finite value, name)."""


def _dfd(channels: int, type_size: int) -> bytes:
    n = channels
    bits = 8 * type_size
    block = 24 + 16 * n
    out = struct.pack("<I", 0)  # vendorId 0 (Khronos), descriptorType 0 (basic)
    out += struct.pack("<HH", 2, block)  # versionNumber 2 (KDFS 1.3), descriptorBlockSize
    out += bytes(
        [1, 1, 1, 0]
    )  # colorModel RGBSDA, primaries BT709, transfer LINEAR, flags straight
    out += bytes([0, 0, 0, 0])  # texelBlockDimension 1x1x1x1 (stored minus one)
    out += bytes([type_size * n, 0, 0, 0, 0, 0, 0, 0])  # bytesPlane0
    for k, cid in enumerate(_CHANNEL_IDS[n]):
        # bitOffset, bitLength - 1, channel | KHR_DF_SAMPLE_DATATYPE_FLOAT | _SIGNED
        out += struct.pack("<HBB", bits * k, bits - 1, cid | 0x80 | 0x40)
        out += bytes([0, 0, 0, 0])
        out += struct.pack("<II", 0xBF800000, 0x3F800000)  # -1.0f, 1.0f
    return struct.pack("<I", 4 + len(out)) + out


def _kvd(kv: dict) -> bytes:
    out = b""
    for k in sorted(kv):
        entry = k.encode() + b"\0" + kv[k].encode() + b"\0"
        out += struct.pack("<I", len(entry)) + entry
        out += b"\0" * (-len(entry) % 4)
    return out


def encode_ktx2(
    levels: list[np.ndarray],
    cube: bool,
    kv: dict | None = None,
    *,
    type_size: int = 2,
    layered: bool = False,
) -> bytes:
    """KTX2 bytes; ``levels[i]``: ``(6, n, n, C)`` (``cube``), ``(L, h, w, C)`` (``layered``:
    a 2D array of ``L`` layers) or ``(h, w, C)``, C in {2, 4}; ``type_size``: bytes a
    channel, 2 (half floats) or 4 (float32)."""
    if not levels:
        raise ParameterError("a KTX2 file needs at least one level")
    if cube and layered:
        raise ParameterError("the KTX2 writer takes a cube or a 2D array, not a cube array")
    c = levels[0].shape[-1]
    if (type_size, c) not in VK_FORMAT:
        raise ParameterError(
            f"KTX2 writer takes 2 or 4 channels of 2 or 4 bytes, got {c} of {type_size}"
        )
    np_type, largest, type_name = _TYPES[type_size]
    data = []
    for lv in levels:
        a = np.asarray(lv, dtype=np.float64)
        if not np.all(np.isfinite(a)) or np.abs(a).max() > largest:
            raise OutputError(f"KTX2 level has values that {type_name} cannot hold")
        data.append(a.astype(np_type).tobytes())
    h, w = levels[0].shape[-3], levels[0].shape[-2]
    layers = levels[0].shape[0] if layered else 0  # spec §3.4: 0 when not an array
    n_levels = len(levels)
    kv = {"KTXwriter": "shbake", **(kv or {})}
    dfd = _dfd(c, type_size)
    kvd = _kvd(kv)
    header_end = 12 + 4 * 9 + 4 * 4 + 8 * 2 + 24 * n_levels
    dfd_off = header_end
    kvd_off = dfd_off + len(dfd)
    pos = kvd_off + len(kvd)
    offsets = [0] * n_levels
    body = b""
    align = math.lcm(type_size * c, 4)  # texel block size, spec §3.9.7 mip padding
    for i in reversed(range(n_levels)):  # smallest level first (spec §3.9)
        pad = -pos % align
        body += b"\0" * pad
        pos += pad
        offsets[i] = pos
        body += data[i]
        pos += len(data[i])
    out = IDENTIFIER
    vk_format, faces = VK_FORMAT[type_size, c], 6 if cube else 1
    out += struct.pack("<9I", vk_format, type_size, w, h, 0, layers, faces, n_levels, 0)
    out += struct.pack("<4I", dfd_off, len(dfd), kvd_off, len(kvd))
    out += struct.pack("<2Q", 0, 0)
    for i in range(n_levels):
        out += struct.pack("<3Q", offsets[i], len(data[i]), len(data[i]))
    out += dfd + kvd + body
    return out


def write_ktx2(
    path: str,
    levels: list[np.ndarray],
    cube: bool,
    kv: dict | None = None,
    *,
    type_size: int = 2,
    layered: bool = False,
) -> None:
    """Write :func:`encode_ktx2` atomically (its arguments)."""
    payload = encode_ktx2(levels, cube, kv, type_size=type_size, layered=layered)
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        f.write(payload)


def read_ktx2_header(data: bytes) -> dict:
    """Header fields of a KTX2 file (a sanity check; tests read files with ``ktx-parse``)."""
    if data[:12] != IDENTIFIER:
        raise FormatError("not a KTX2 file")
    keys = (
        "vkFormat",
        "typeSize",
        "pixelWidth",
        "pixelHeight",
        "pixelDepth",
        "layerCount",
        "faceCount",
        "levelCount",
        "supercompressionScheme",
    )
    return dict(zip(keys, struct.unpack_from("<9I", data, 12), strict=True))


def _rgba(level: np.ndarray) -> np.ndarray:
    return np.concatenate([level, np.ones(level.shape[:-1] + (1,))], axis=-1)


CUBES = {"size": 128, "floor": 1, "samples": 512, "mapping": "gltf-ibl-sampler"}
"""The cube chain this target wants by default: a full mip chain to 1×1."""
CUBE_LOOKUP = (
    "texel of GL cube direction g shows world direction (-g.x, g.y, g.z) "
    "(x mirrored, as three.js samples cube textures)"
)


def write_cube_chain(
    path: str,
    src: ExportSource,
    levels: list[np.ndarray],
    roughness: list[float],
    mapping: str,
    note: str = "",
) -> None:
    """The prefiltered cube chain as an RGBA16F KTX2 cube (half-float overflow clamped),
    each level's roughness and the LOD mapping in the key/value data (``note`` ends the
    ``shbake.content`` line)."""
    kv = {
        "shbake.roughness": json.dumps([round(r, 9) for r in roughness]),
        "shbake.lodMapping": mapping,
        "shbake.cubeLookup": CUBE_LOOKUP,
        "shbake.frame": src.frame,
        "shbake.content": "GGX split-sum prefiltered radiance, level 0 = mirror (alpha 0), "
        f"filtered importance sampling; levels of at most {FIT_MAX_SIZE}^2 texels hold the "
        "least-squares fit of their bilinear read" + note,
    }
    write_ktx2(path, [_rgba(lv) for lv in clamp_to_half(levels, path)], cube=True, kv=kv)


def write(
    src: ExportSource,
    out: str,
    levels: list[np.ndarray],
    roughness: list[float],
    mapping: str = "gltf-ibl-sampler",
    dfg_table: np.ndarray | None = None,
    **_ignored,
) -> list[str]:
    """Write the prefiltered cube chain ``out`` (.ktx2) and, given ``dfg_table``, the DFG beside it.

    ``levels``/``roughness``: the chain in the target frame and each level's
    perceptual roughness; ``dfg_table``: ``(n_μ, n_r, 2)`` of :mod:`shbake.bakers.dfg`.
    """
    write_cube_chain(out, src, levels, roughness, mapping)
    written = [out]
    if dfg_table is not None:
        written += write_dfg(os.path.splitext(out)[0] + "_dfg", dfg_table)
    return written


def write_dfg(stem: str, table: np.ndarray) -> list[str]:
    """The DFG table ``(A0, A1)`` (``(n_μ, n_r, 2)``, node-centred axes of
    ``shbake.bakers.dfg.dfg_axes``) as ``stem.ktx2`` (RG16F) and ``stem.exr`` (float32)."""
    from shbake.conventions import DFG_MU_MIN as MU_MIN
    from shbake.conventions import ROUGHNESS_MIN
    from shbake.format.images import write_exr

    img = np.transpose(np.asarray(table, dtype=np.float64), (1, 0, 2))  # rows r, columns n.v
    mu = np.linspace(MU_MIN, 1.0, table.shape[0])
    r = np.linspace(ROUGHNESS_MIN, 1.0, table.shape[1])
    axes = {
        "shbake.dfg": "R = A0 = int f_DV (n.l) dl, G = A1 = int f_DV (1 - v.h)^5 (n.l) dl; "
        "split-sum scale F0*A0 + (1-F0)*A1",
        "shbake.dfgAxes": f"column j: n.v = {MU_MIN} + j*(1-{MU_MIN})/{len(mu) - 1} "
        "(node-centred); "
        f"row i: perceptual roughness = {r[0]} + i*(1-{r[0]})/{len(r) - 1}",
    }
    write_ktx2(stem + ".ktx2", [img], cube=False, kv=axes)
    exr_attrs = {k.replace("shbake.", "shbake:"): v for k, v in axes.items()}
    exr_attrs["DateTime"] = ""  # OpenImageIO writes no capDate then: identical bytes
    write_exr(stem + ".exr", img, half=False, channel_names=("A0", "A1"), attrs=exr_attrs)
    return [stem + ".ktx2", stem + ".exr"]


__all__ = [
    "encode_ktx2",
    "read_ktx2_header",
    "write",
    "write_cube_chain",
    "write_dfg",
    "write_ktx2",
]
