"""The one command-line grammar of docs/CLI.md, checked over every command's --help."""

import os
from collections import namedtuple

import click
import numpy as np
import pytest
from shbake_cli.main import cli, main
from shbake_cli.options import SizeHW

from shbake.brdf.tabulate import FIRST_LEVEL_POINTS, MAX_SAMPLES_LIMIT

COMMANDS = sorted(cli.list_commands(None))  # lazily imported subcommands
RETIRED = ("--exr-maps", "--map-height", "--resolution", "--exr ", "--truth-samples", "--top",
           "--set ")  # fmt: skip
"""Old spellings: hidden deprecated aliases, never shown in --help."""


def visible_options(name: str) -> dict[str, click.Option]:
    command = cli.get_command(None, name)
    out = {}
    for p in command.params:
        if isinstance(p, click.Option) and not p.hidden:
            for opt in p.opts + p.secondary_opts:
                out[opt] = p
    return out


def help_text(name: str) -> str:
    ctx = click.Context(cli.get_command(None, name), info_name=name, parent=click.Context(cli))
    return cli.get_command(None, name).get_help(ctx)


class TestEveryCommand:
    @pytest.mark.parametrize("name", COMMANDS)
    def test_shared_options_present(self, name):
        opts = visible_options(name)
        assert "--json" in opts and "--quiet" in opts and "-q" in opts, name

    @pytest.mark.parametrize("name", COMMANDS)
    def test_every_option_has_help(self, name):
        missing = [o for o, p in visible_options(name).items() if not (p.help or "").strip()]
        assert not missing, missing

    @pytest.mark.parametrize("name", COMMANDS)
    def test_output_is_a_file(self, name):
        opts = visible_options(name)
        if "-o" in opts:
            p = opts["-o"]
            assert "--output" in p.opts and "a file" in p.help, (name, p.opts, p.help)
            folder = name == "export"  # --to webgl writes a folder (docs/SHADERS.md)
            assert isinstance(p.type, click.Path) and p.type.dir_okay == folder

    @pytest.mark.parametrize("name", COMMANDS)
    def test_retired_spellings_hidden(self, name):
        text = help_text(name) + " "
        shown = [r for r in RETIRED if r in text]
        assert not shown, shown

    @pytest.mark.parametrize("name", COMMANDS)
    def test_one_meaning_per_name(self, name):
        opts = visible_options(name)
        if "--size" in opts:
            assert "per side" in opts["--size"].help or "texels" in opts["--size"].help
        if "--samples" in opts:
            assert opts["--samples"].help.startswith("Quadrature samples")
        if "--tol" in opts:
            assert opts["--tol"].help.startswith("Error tolerance")
        if "--roughness" in opts:
            assert "perceptual" in opts["--roughness"].help
        if "--alpha" in opts:
            assert "GGX width" in opts["--alpha"].help
        if "--exr-dir" in opts:
            assert isinstance(opts["--exr-dir"].type, click.Path)
            assert not opts["--exr-dir"].type.file_okay

    @pytest.mark.parametrize("name", COMMANDS)
    def test_scheduler_comes_with_its_timeout(self, name):
        """Every command that runs on Dask takes ``--connect-timeout`` (``scheduler_opt``)."""
        opts = visible_options(name)
        assert ("--scheduler" in opts) == ("--connect-timeout" in opts), name
        if "--scheduler" in opts:
            p = opts["--connect-timeout"]
            assert p.default == 10.0 and p.show_default and "With --scheduler" in p.help

    @pytest.mark.parametrize("name", COMMANDS)
    def test_help_names_only_existing_options(self, name):
        text = help_text(name)
        if "--list-params" in text:
            assert "--list-params" in visible_options(name)


class TestDeprecatedAliases:
    def test_old_spelling_warns_and_works(self, run_cli, tmp_path):
        from tests.helpers import write_test_exr

        src = write_test_exr(tmp_path / "sky.exr", [[[1.0, 1.0, 1.0]] * 8] * 4)
        code, _, err = run_cli("project-env", src, "-o", tmp_path / "a.h5",
                               "--exr-maps", tmp_path / "maps", "--map-height", "4")  # fmt: skip
        assert code == 0, err
        assert "--exr-maps is deprecated; use --exr-dir" in err
        assert "--map-height is deprecated; use --size" in err
        assert (tmp_path / "maps" / "irradiance.exr").exists()

    def test_list_params(self, run_cli):
        code, out, err = run_cli("brdf-table", "ggx", "--list-params")
        assert code == 0, err
        assert "alpha_x=" in out and "F0=" in out

    @pytest.mark.parametrize("order", ["model first", "option first"])
    def test_list_params_lists_the_model_alone(self, run_cli, order):
        """Issue 32: ``brdf-table ggx --list-params`` printed all ten models."""
        from shbake.brdf import MODELS, model_spec

        args = ["ggx", "--list-params"] if order == "model first" else ["--list-params", "ggx"]
        code, out, err = run_cli("brdf-table", *args)
        assert code == 0, err
        headers = [line.split(":")[0] for line in out.splitlines() if not line.startswith(" ")]
        assert headers == ["ggx"], out
        assert len(out.splitlines()) == 1 + len(model_spec("ggx").params) + len(
            model_spec("ggx").aliases
        )
        assert len(MODELS) > 1


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """A small map and its env_sh asset (read-only inputs every run may name)."""
    from tests.helpers import write_test_exr

    folder = tmp_path_factory.mktemp("inputs")
    map_path = write_test_exr(folder / "sky.exr", np.ones((8, 16, 3)))
    assert main(["project-env", str(map_path), "-o", str(folder / "sky.h5"), "-q"]) == 0
    return folder


class TestRangesAreUsageErrors:
    """Every numeric option outside its range is a usage error (exit 2, one line, nothing
    written), also where the range depends on another option, and in-range values pass the
    same checks (docs/CLI.md; issue 27 item 17). The ranges are the documented ones."""

    R = namedtuple("R", "lo hi integer lo_open hi_open extra good", defaults=(False, False, (), ()))
    CPUS = os.cpu_count() or 1
    DASK = ("--scheduler", "127.0.0.1:9")
    """What ``--connect-timeout`` needs (an address; nothing is connected in these tests)."""
    RANGES = {
        ("project-env", "--lmax"): R(0, 128, True),
        ("project-env", "--irradiance-lmax"): R(0, 128, True, extra=("--lmax", "128")),
        ("project-env", "--sun-radius"): R(0.0, 45.0, False, lo_open=True),
        ("project-env", "--size"): R(2, 4096, True),
        ("project-env", "--tol"): R(0.0, 1.0, False, True, True, extra=("--lights", "auto")),
        ("project-env", "--map-height"): R(2, 4096, True),
        ("preview", "--size"): R(8, 4096, True),
        ("preview", "--roughness"): R(0.0, 1.0, False),
        ("preview", "--alpha"): R(0.0, 1.0, False),
        ("preview", "--f0"): R(0.0, 1.0, False),
        ("preview", "--index"): R(0, None, True),  # the upper bound is the probe set's size
        ("preview", "--samples"): R(16, 1 << 20, True),
        ("brdf-table", "--lmax"): R(0, 16, True),
        ("brdf-table", "--size"): R(2, 4096, True, good=("16x4096", "2x2")),
        ("brdf-table", "--resolution"): R(2, 4096, True, good=("16x4096",)),
        ("brdf-table", "--samples"): R(16, 1 << 22, True),
        ("brdf-table", "--tol"): R(0.0, 1.0, False, True, True),
        ("brdf-table", "--max-samples"): R(FIRST_LEVEL_POINTS, MAX_SAMPLES_LIMIT, True),
        ("probe-fit", "--lmax-p"): R(0, 8, True),
        ("probe-fit", "--lmax-q"): R(1, 8, True),
        ("probe-fit", "--normals"): R(4, 4096, True),
        ("probe-fit", "--views"): R(4, 4096, True),
        ("probe-fit", "--alpha-count"): R(3, 64, True),  # at least 2 × --sets − 1
        ("probe-fit", "--roughness-count"): R(3, 64, True),
        ("probe-fit", "--sets"): R(1, 8, True, extra=("--alpha-count", "64")),
        ("probe-fit", "--polish"): R(0, 8, True),
        ("probe-fit", "--alpha-weight"): R(0.0, 4.0, False),
        ("probe-fit", "--samples"): R(16, 1 << 20, True),
        ("probe-fit", "--floor"): R(0.0, 1.0, False, True, True),
        ("probe-fit", "--targets-lmax"): R(1, 24, True),
        ("probe-fit", "--tol"): R(0.0, 1.0, False, True, True),
        ("overview", "--tol"): R(0.0, 1.0, False, True, True),
        ("export", "--lmax"): R(0, 128, True),
        ("probe-fit", "--jobs"): R(1, 4 * CPUS, True),
        ("split-sum", "--size"): R(8, 2048, True, extra=("--min-size", "8")),
        ("split-sum", "--top"): R(8, 2048, True, extra=("--min-size", "8")),
        ("split-sum", "--min-size"): R(8, 2048, True, extra=("--size", "2048")),
        ("split-sum", "--samples"): R(16, 1 << 20, True),
        ("probe-eval", "--size"): R(8, 512, True),
        ("probe-eval", "--samples"): R(16, 1 << 20, True),
        ("probe-eval", "--truth-samples"): R(16, 1 << 20, True),
        ("probe-eval", "--roughness"): R(0.1, 1.0, False),
        ("probe-eval", "--eps"): R(0.0, 1.0, False, True, True),
        # a cube of 289 terms (P 16) must stay within 2 GiB: 6 × 321² × 289 × 12 bytes
        ("probe-eval", "--face-size"): R(4, 321, True),
        ("export", "--rotate"): R(None, None, False, good=("-720", "0.5")),
        ("export", "--size"): R(8, 4096, True, good=("16",)),  # powers of two from gltf's floor 8
        ("export", "--floor"): R(1, 64, True, good=("2",)),  # powers of two up to gltf's size 64
        ("export", "--samples"): R(16, 1 << 20, True),
        ("export", "--sun-radius"): R(0.0, 45.0, False, lo_open=True),
        # the lower end depends on the BRDF: what F 64, P 16 leave out (a Phong lobe: nothing)
        ("shrm", "--eps"): R(0.0, 1.0, False, True, True, extra=("--brdf", "phong-lobe")),
        ("shrm", "--F"): R(0, 64, True),
        ("shrm", "--P"): R(0, 16, True),
        ("shrm", "--face-size"): R(4, 1024, True),
        ("bake", "--jobs"): R(1, 64, True),
        # only with --scheduler; in range, the run goes on to connect (refused at once here)
        ("bake", "--connect-timeout"): R(0.0, 600.0, False, lo_open=True, extra=DASK),
        ("probe-fit", "--connect-timeout"): R(0.0, 600.0, False, lo_open=True, extra=DASK),
        ("project-env", "--jobs"): R(1, 4 * CPUS, True),
        ("split-sum", "--jobs"): R(1, 4 * CPUS, True),
        ("plan", "--maps-per-rule"): R(1, 1024, True),
        ("plan", "--jobs"): R(1, 64, True),
        ("tradeoff", "--tol"): R(0.0, 1.0, False, True, True),
        ("tradeoff", "--samples"): R(16, 1 << 20, True),
    }
    """The documented range of every numeric option (``extra``: other options that widen a
    range depending on them to its limits)."""

    @staticmethod
    def numeric_options():
        for name in COMMANDS:
            for p in cli.get_command(None, name).params:
                numeric = (click.types.IntParamType, click.types.FloatParamType, SizeHW)
                if isinstance(p, click.Option) and isinstance(p.type, numeric):
                    yield name, p.opts[0], p.hidden

    @staticmethod
    def base(command, inputs, out):
        """A run of ``command`` on ``inputs`` writing into ``out`` (a folder)."""
        m, a = str(inputs / "sky.exr"), str(inputs / "sky.h5")
        return {
            "project-env": [m, "-o", out / "a.h5"], "preview": [a, "-o", out / "a.exr"],
            "brdf-table": ["ggx", "-o", out / "a.h5"], "probe-fit": [m, "-o", out / "a.h5"],
            "split-sum": [m, "-o", out / "a.h5"], "probe-eval": [m, "-o", out / "a.md"],
            "export": [a, "--to", "gltf", "-o", out / "a.gltf"], "shrm": [m, "-o", out / "a.h5"],
            "bake": [inputs / "scene.toml"], "plan": [inputs / "scene.toml"],
            "tradeoff": ["env_sh", "--map", m, "-o", out / "a.png"],
            "overview": [inputs, "-o", out / "index.html"],
        }[command]  # fmt: skip

    def values(self, r: R):
        """(out-of-range, in-range) values as typed on a command line."""
        bad, good = ["nan", "inf", "-inf"], list(r.good)
        if r.lo is not None:
            bad += [str(r.lo - 1), str(-(10**30))] + ([str(r.lo)] if r.lo_open else [])
            good.append(str(r.lo + (1 if r.integer else 1e-6) if r.lo_open else r.lo))
        if r.hi is not None:
            bad += [str(r.hi + 1), str(10**30)] + ([str(r.hi)] if r.hi_open else [])
            good.append(str(r.hi - 1e-6 if r.hi_open else r.hi))
        if not r.integer:
            bad += ["1e300"] if r.hi is not None else []
        return bad, good

    def test_every_numeric_option_has_a_range(self):
        assert {(c, o) for c, o, _ in self.numeric_options()} == set(self.RANGES)

    @pytest.mark.parametrize("command,option,hidden", list(numeric_options.__func__()))
    def test_out_of_range_is_a_usage_error(self, run_cli, tmp_path, monkeypatch, inputs,
                                           command, option, hidden):  # fmt: skip
        r = self.RANGES[(command, option)]
        if option == "--connect-timeout":  # no scheduler: refused at once, whatever the timeout
            from shbake.batch import scheduler

            def refused(address, timeout):
                raise ConnectionRefusedError(111, "Connection refused")

            monkeypatch.setattr(scheduler, "_reach", refused)
        before = {p: p.read_bytes() for p in inputs.iterdir()}
        bad, good = self.values(r)
        for value in bad:
            code, out, err = run_cli(command, *self.base(command, inputs, tmp_path), *r.extra,
                                     option, value)  # fmt: skip
            *before_error, error = err.splitlines()  # a deprecated spelling warns first
            assert code == 2 and error.startswith("shbake: error:") and out == "", (value, err)
            assert len(before_error) <= hidden, err
            assert all(line.startswith(f"shbake: warning: {option} is deprecated")
                       for line in before_error), err  # fmt: skip

            assert os.listdir(tmp_path) == [], value
        assert {p: p.read_bytes() for p in inputs.iterdir()} == before
        # in range, the same checks pass: the run goes on to read its (missing) input
        missing = tmp_path / "missing"
        for value in good:
            args = [str(missing / "x") if str(a).startswith(str(inputs)) else a
                    for a in self.base(command, inputs, missing)]  # fmt: skip
            code, _, err = run_cli(command, *args, *r.extra, option, value)
            connected = option == "--connect-timeout" and f"within {float(value):g} s" in err
            assert "no such file" in err or "does not exist" in err or connected, (value, err)

    @pytest.mark.parametrize(
        "command,args",
        [
            ("project-env", ["--irradiance-lmax", "5"]),  # above --lmax 2
            ("project-env", ["--export", "gltf", "--irradiance-lmax", "1"]),
            ("split-sum", ["--min-size", "256"]),  # above --size 128
            ("split-sum", ["--alphas", "0.5,0.1"]),
            ("split-sum", ["--alphas", "0.1,x"]),
            ("probe-fit", ["--alpha-count", "2"]),  # below 2 × --sets − 1
            ("probe-fit", ["--sets", "5"]),  # above (--alpha-count 8 + 1) / 2
            ("probe-fit", ["--alpha-range", "0:5"]),
            ("probe-fit", ["--roughness-range", "0.5:0.2"]),
            ("export", ["--size", "100"]),  # not a power of two
            ("export", ["--floor", "3"]),
            ("export", ["--size", "16", "--floor", "32"]),
            ("shrm", ["--face-size", "1024", "--P", "16"]),  # 20 GiB
            ("shrm", ["--brdf", "phong-lobe", "--P", "2"]),
            ("shrm", ["--view", "0,0,0"]),
            ("shrm", ["--brdf", "kajiya-kay", "-p", "p=32", "--eps", "1e-6"]),  # not reachable
            ("shrm", ["-p", "sigma=-1"]),
            ("probe-eval", ["--face-size", "1024"]),
            ("preview", ["--at", "alpha_x=abc"]),  # was an internal error
            ("preview", ["--at", "alpha_x=nan"]),
            ("brdf-table", ["-p", "alpha_x=5"]),
            ("brdf-table", ["--vary", "alpha_x=0:5:3"]),
            ("brdf-table", ["--vary", "alpha_x=0.1:0.5:1"]),
        ],
    )
    def test_dependent_range_is_a_usage_error(self, run_cli, tmp_path, inputs, command, args):
        code, out, err = run_cli(command, *self.base(command, inputs, tmp_path), *args)
        assert code == 2 and err.count("\n") == 1 and err.startswith("shbake: error:"), err
        assert os.listdir(tmp_path) == []

    @pytest.mark.parametrize("value", ["-5", "0", "nan", "4Q"])
    def test_max_memory(self, run_cli, tmp_path, inputs, value):
        code, _, err = run_cli("--max-memory", value, "project-env", inputs / "sky.exr", "-o",
                               tmp_path / "a.h5")  # fmt: skip
        assert code == 2 and err.count("\n") == 1 and "--max-memory" in err, err
        assert os.listdir(tmp_path) == []

    def test_tradeoff_model_parameters(self, run_cli, tmp_path):
        code, _, err = run_cli("tradeoff", "brdf_table", "--model", "ggx", "-p", "alpha=7", "-o",
                               tmp_path / "a.png")  # fmt: skip
        assert code == 2 and err.count("\n") == 1 and "alpha_x=7" in err, err
