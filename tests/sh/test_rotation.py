"""SH rotation (SPEC §2): re-projection, composition, orthogonality at lmax 30."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from shbake.errors import ParameterError
from shbake.sh.basis import real_sh
from shbake.sh.rotation import SHRotation, rotate
from tests.helpers import gauss_legendre_sphere

LMAX = 30


def rot(seed):
    return Rotation.random(random_state=seed).as_matrix()


class TestSHRotation:
    def test_agrees_with_reprojection_at_lmax_30(self, random_coeffs):
        # Rotate a function by sampling f(Rᵀ d) and projecting it by exact quadrature.
        c = random_coeffs(LMAX, 1, seed=1)[:, 0]
        R = rot(2)
        d, w = gauss_legendre_sphere(LMAX + 1)
        g = real_sh(d @ R, LMAX) @ c  # f(Rᵀ d): rows d @ R = (Rᵀ d)ᵀ
        projected = real_sh(d, LMAX).T @ (g * w)
        np.testing.assert_allclose(rotate(c, R), projected, atol=1e-10)

    def test_composes(self):
        A, B = rot(3), rot(4)
        MA, MB, MAB = (SHRotation(m, LMAX).dense() for m in (A, B, A @ B))
        assert np.abs(MA @ MB - MAB).max() < 1e-10

    def test_orthogonal_to_1e10(self):
        M = SHRotation(rot(5), LMAX).dense()
        assert np.abs(M @ M.T - np.eye(M.shape[0])).max() < 1e-10

    def test_orthogonal_to_1e10_at_lmax_64_and_finite_at_128(self):
        r = SHRotation(rot(6), 128)
        b = r.block(64)
        assert np.abs(b @ b.T - np.eye(129)).max() < 1e-10
        b = r.block(128)
        assert np.all(np.isfinite(b)) and np.abs(b @ b.T - np.eye(257)).max() < 1e-4

    def test_identity_and_axis_permutation(self):
        np.testing.assert_allclose(SHRotation(np.eye(3), 6).dense(), np.eye(49), atol=1e-15)
        # 90° about +Z maps x→y: y_1 (∝ y) of R d equals y_3 (∝ x) of d.
        Rz = Rotation.from_euler("z", 90, degrees=True).as_matrix()
        d = np.array([0.3, -0.5, 0.81])
        d /= np.linalg.norm(d)
        np.testing.assert_allclose(
            real_sh(Rz @ d, 4), SHRotation(Rz, 4).dense() @ real_sh(d, 4), atol=1e-14
        )

    def test_rejects_non_rotations(self):
        with pytest.raises(ParameterError):
            SHRotation(np.diag([1.0, 1.0, -1.0]), 2)
        with pytest.raises(ParameterError):
            SHRotation(np.eye(3) * 2, 2)


class TestRotationBlocksMany:
    """Many rotations at once, vectorised across them (the per-pixel rotations of previews)."""

    def test_each_satisfies_the_defining_identity(self):
        # y(R d) = M(R) y(d) for every rotation of a partial block (37 of 64), lmax 8:
        # checked with real_sh, independent of the recurrence.
        from shbake.sh.rotation import (
            block_offsets,
            p_rows,
            rotation_blocks_many,
            rotation_coefficients,
        )

        lmax, nb, width = 8, 37, 64
        off = block_offsets(lmax)
        uvw = np.empty(3 * off[-1])
        rotation_coefficients(lmax, off, uvw)
        Rs = Rotation.random(nb, random_state=7).as_matrix()
        r1 = np.zeros((3, 3, width))
        perm = [1, 2, 0]
        for k in range(nb):
            r1[:, :, k] = Rs[k][np.ix_(perm, perm)]
        out = np.full((off[-1], width), np.nan)
        rotation_blocks_many(r1, lmax, off, uvw, np.empty((p_rows(lmax), width)), out, nb)
        d = Rotation.random(5, random_state=8).as_matrix()[:, :, 0]
        y = real_sh(d, lmax)
        for k in range(nb):
            M = np.zeros(((lmax + 1) ** 2,) * 2)
            for l in range(lmax + 1):
                s = slice(l * l, (l + 1) ** 2)
                M[s, s] = out[off[l] : off[l + 1], k].reshape(2 * l + 1, 2 * l + 1)
            np.testing.assert_allclose(y @ M.T, real_sh(d @ Rs[k].T, lmax), atol=1e-12)
        assert np.isnan(out[:, nb:]).all()  # columns past nb untouched

    def test_one_rotation_is_the_same_code(self):
        # SHRotation (B = 1) and a block of many give the same bytes.
        from shbake.sh.rotation import (
            block_offsets,
            p_rows,
            rotation_blocks_many,
            rotation_coefficients,
        )

        lmax = 6
        off = block_offsets(lmax)
        uvw = np.empty(3 * off[-1])
        rotation_coefficients(lmax, off, uvw)
        Rs = Rotation.random(9, random_state=3).as_matrix()
        r1 = np.stack([R[np.ix_([1, 2, 0], [1, 2, 0])] for R in Rs], axis=-1).copy()
        out = np.empty((off[-1], 9))
        rotation_blocks_many(r1, lmax, off, uvw, np.empty((p_rows(lmax), 9)), out, 9)
        for k, R in enumerate(Rs):
            single = SHRotation(R, lmax)
            for l in range(lmax + 1):
                assert single.block(l).tobytes() == out[off[l] : off[l + 1], k].tobytes()
