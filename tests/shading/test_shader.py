"""The shader protocol and registry (shbake/shading/shader.py): every technique names the
inputs the format registry declares, shades to radiance, and matches its ground truth."""

import numpy as np
import pytest

from shbake.envmap import load_environment
from shbake.errors import ParameterError
from shbake.format import registry
from shbake.format.brdf_table import BRDFTable
from shbake.reference.truth import TRUTHS, truth
from shbake.sh.point_sets import fibonacci_sphere
from shbake.shading.shader import (
    DEFAULT_OF_KIND,
    LAYOUTS,
    SHADERS,
    Texture,
    Uniform,
    shader,
    shader_class,
    shaders_of_kind,
)
from tests.assets_examples import example, write_map
from tests.helpers import write_test_exr


def _tokens(cls, source):
    """``(kind, dataset)`` pairs an input's ``source`` names."""
    kind = cls.kinds[0] if cls.kinds else None
    if ": " in source:
        kind, source = source.split(": ")
    return [(kind, t) for t in source.replace(" × ", " + ").split(" + ") if t.startswith("/")]


class TestRegistry:
    def test_names_and_defaults(self):
        for name in SHADERS:
            cls = shader_class(name)
            assert cls.name == name and cls.truth in TRUTHS
            assert set(cls.material) <= {"albedo", "kd", "alpha", "f0"}
        for kind, name in DEFAULT_OF_KIND.items():
            assert shader_class(name).kinds[0] == kind and shaders_of_kind(kind)[0] == name
            registry.kind_of(kind)

    @pytest.mark.parametrize("name", list(SHADERS))
    def test_inputs_are_what_the_format_declares(self, name):
        """What an exporter writes and a GLSL file declares: every dataset an input names
        is declared by the asset kind's format, with the same shape for a texture."""
        cls = shader_class(name)
        assert cls.inputs
        for inp in cls.inputs:
            assert isinstance(inp, Texture | Uniform) and inp.name.isidentifier()
            if isinstance(inp, Texture):
                assert inp.layout in LAYOUTS
            else:
                assert inp.units
            sources = _tokens(cls, inp.source)
            if inp.source in ("material", "baked"):
                continue
            assert sources, inp
            for kind, path in sources:
                declared = registry.kind_of(kind).dataset(path)
                if isinstance(inp, Texture) and len(sources) == 1:
                    assert tuple(declared.shape) == tuple(inp.shape), (inp.name, declared.shape)

    def test_unknown_technique_names_those_of_the_kind(self, tmp_path):
        asset = example("env_sh", write_map(tmp_path / "m.exr"))
        with pytest.raises(ParameterError, match="irradiance, tangent, tangent-sh, kautz"):
            shader(asset, "shexp")


@pytest.fixture(scope="module")
def sky(tmp_path_factory):
    """A white dome (L ≡ 1), lat-long 16 × 32, and its env_sh asset."""
    from shbake.bakers.env_sh import bake_env_sh

    path = write_test_exr(tmp_path_factory.mktemp("sky") / "white.exr", np.ones((16, 32, 3)))
    env = load_environment(str(path), quiet=True)
    asset, _ = bake_env_sh(env, lmax=4, irradiance_lmax=4)
    return env, asset


class TestShade:
    """Analytic values (SPEC §5): a white dome shades a Lambert albedo ρ to ρ, a Kajiya–Kay
    fibre to k_d, whatever the normal or tangent; the ground truth agrees."""

    @pytest.mark.parametrize("name", ["irradiance", "tangent", "tangent-sh"])
    def test_white_dome(self, sky, name):
        env, asset = sky
        n = fibonacci_sphere(50)
        sh = shader(asset, name)
        tangents = {"tangents": n} if sh.tangents else {}
        colour = {"albedo": 0.5} if "albedo" in sh.material else {"kd": 0.5}
        got = sh.shade(n, np.broadcast_to([0.0, 0.0, 1.0], n.shape), **tangents, **colour)
        np.testing.assert_allclose(got, 0.5, rtol=2e-3)
        ref = truth(sh, env, n, np.broadcast_to([0.0, 0.0, 1.0], n.shape), n, **colour)
        np.testing.assert_allclose(ref, 0.5, rtol=1e-2)

    def test_kautz_lambert_table_is_the_irradiance(self, sky):
        """A Lambert BRDF table (ρ = 0.8, the model's default) under the dome shades like the
        irradiance shader of the same albedo."""
        from shbake.brdf import make_brdf
        from shbake.brdf.tabulate import tabulate

        _, asset = sky
        brdf = make_brdf("lambert")
        coeffs, _ = tabulate(brdf, 4, (16, 16), samples=256)
        kautz = shader(asset, "kautz", table=BRDFTable(coeffs, 4, "lambert", {}, "", {}))
        n = fibonacci_sphere(40)
        n = n[n[:, 1] < 0.9]  # tangents from +Y: away from the pole
        t = np.cross(np.cross(n, [0.0, 1.0, 0.0]), n)
        t /= np.linalg.norm(t, axis=1, keepdims=True)
        v = n  # seen head-on
        got = kautz.shade(n, v, tangents=t)
        np.testing.assert_allclose(got, shader(asset).shade(n, v, albedo=0.8), rtol=0.02)
        modes = kautz.modes(n, v, tangents=t)
        assert list(modes) == ["full", "fixed_light", "fixed_view"]
        for run in modes.values():
            np.testing.assert_allclose(run(), got, rtol=1e-9)

    @pytest.mark.parametrize("kind", ["shexp_probe", "splitsum_probe", "shrm"])
    def test_probe_kinds_shade_finite_radiance(self, tmp_path, kind):
        asset = example(kind, write_map(tmp_path / "m.exr"))
        sh = shader(asset)
        n = fibonacci_sphere(30)
        n = n[n[:, 2] > 0.2]
        v = np.broadcast_to([0.0, 0.0, 1.0], n.shape)
        material = {"alpha": 0.5, "f0": 0.04} if "alpha" in sh.material else {}
        out = sh.shade(n, v, **material)
        assert out.shape == (len(n), 3) and np.all(np.isfinite(out))
        if "alpha" in sh.material:
            assert not sh.covers(alpha=0.01) and sh.covers(alpha=0.5)
            with pytest.raises(ParameterError, match="outside"):
                sh.shade(n, v, alpha=0.01)
