"""The one command-line grammar of docs/CLI.md, checked over every command's --help."""

import click
import pytest
from shbake_cli.main import cli

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
            assert isinstance(p.type, click.Path) and not p.type.dir_okay

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
    def test_help_names_only_existing_options(self, name):
        text = help_text(name)
        if "--list-params" in text:
            assert "--list-params" in visible_options(name)


class TestDeprecatedAliases:
    def test_old_spelling_warns_and_works(self, run_cli, tmp_path):
        from helpers import write_test_exr

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
