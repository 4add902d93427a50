"""The peer of ``shbake project-env`` in bench/end_to_end.py: a plain script, no shbake.

Reads a lat-long EXR with OpenImageIO, clamps negative pixels to 0 (what
``--negative clamp`` does), projects onto SH with ducc0 (Fejér-1 ring weights,
the quadrature shbake uses), scales by the Lambert kernel for an irradiance
set, and writes both into an HDF5 file with h5py. Coefficients are left in
ducc0's own complex layout and frame: converting them is the part a plain
script would leave out.

    python bench/plain_project.py IN.exr OUT.h5 LMAX
"""

import sys

import ducc0
import h5py
import numpy as np
import OpenImageIO as oiio


def main(path, out_path, lmax):
    inp = oiio.ImageInput.open(path)
    img = inp.read_image(0, 0, 0, 3, "float")
    inp.close()
    h, w, _ = img.shape
    neg = int((img < 0).sum())
    np.maximum(img, 0.0, out=img)
    theta = np.pi * (np.arange(h) + 0.5) / h
    ringfactor = ducc0.sht.experimental.get_gridweights("F1", h) / w  # per pixel, sr
    flat = img.reshape(1, -1)
    alm = [
        ducc0.sht.experimental.adjoint_synthesis(
            map=flat[:, c:],
            theta=theta,
            lmax=lmax,
            spin=0,
            nphi=np.full(h, w, dtype=np.uintp),
            phi0=np.full(h, np.pi / w),
            ringstart=(np.arange(h) * w * 3).astype(np.uintp),
            pixstride=3,
            ringfactor=ringfactor,
            nthreads=1,
        )[0]
        for c in range(3)
    ]
    alm = np.stack(alm, axis=1)
    lam = np.array([np.pi, 2 * np.pi / 3, np.pi / 4])
    l_of = np.concatenate([np.arange(m, lmax + 1) for m in range(lmax + 1)])
    irr = alm[l_of <= 2] * lam[l_of[l_of <= 2]][:, None]
    with h5py.File(out_path, "w") as f:
        f["lighting_alm_real"] = alm.real
        f["lighting_alm_imag"] = alm.imag
        f["irradiance_alm"] = np.stack([irr.real, irr.imag])
        f.attrs["negative_count"] = neg


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]))
