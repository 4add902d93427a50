"""``shbake shrm``: Spherical Harmonic Reflection Maps (Ramamoorthi & Hanrahan 2002)."""

import click
from shbake_cli.options import (
    FiniteRange,
    also_wrote,
    colorspace_opt,
    emit_json,
    exr_dir_opt,
    fix_nonfinite_opt,
    info,
    json_opt,
    layout_opt,
    negative_opt,
    output_opt,
    png_opt,
    quiet_opt,
    report_opt,
    usage_errors,
)

from shbake.bakers.shrm import FACE_AUTO_MAX, FACE_AUTO_MIN, FACE_MAX, FACE_MIN
from shbake.batch.shrm import bake_shrm_file, shrm_settings
from shbake.brdf.reflection import F_LIMIT, P_LIMIT


def _params(values) -> dict:
    out = {}
    for item in values:
        if "=" not in item:
            raise click.UsageError(f"-p expects NAME=VALUE, got {item!r}")
        k, v = item.split("=", 1)
        out[k.strip()] = v.strip()
    return out


def _view(ctx, param, text) -> tuple[float, float, float]:
    """``--view X,Y,Z``: three numbers (the library checks the vector and normalises it)."""
    try:
        v = tuple(float(x) for x in str(text).split(","))
    except ValueError:
        v = ()
    if len(v) != 3:
        raise click.BadParameter(f"expected X,Y,Z numbers, got {text!r}", ctx, param)
    return v


@click.command("shrm")
@click.argument("env", type=click.Path(dir_okay=False))
@output_opt("The SHRM asset (.h5)")
@click.option(
    "--brdf",
    default="microfacet",
    show_default=True,
    help="Isotropic BRDF: microfacet (RH02 eq. 11), phong-lobe (radially symmetric, P=0), "
    "kajiya-kay (tangent), lafortune, or a brdf-table model (ggx, phong, ward, merl, ...).",
)
@click.option(
    "-p",
    "--param",
    "params",
    multiple=True,
    metavar="NAME=VALUE",
    help="BRDF parameter (repeatable), e.g. -p sigma=0.2, -p alpha=0.16.",
)
@click.option(
    "--merl",
    "merl_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="MERL .binary file (--brdf merl).",
)
@click.option(
    "--eps",
    "--tol",
    "eps",
    type=FiniteRange(0.0, 1.0, min_open=True, max_open=True),
    default=0.03,
    show_default=True,
    help="Error tolerance in (0, 1): the fraction of BRDF energy left out; chooses F and P "
    "(RH02 §5.1); one that no F, P within the limits reaches is refused unless --F/--P are "
    "given.",
)
@click.option(
    "--F",
    "F",
    type=click.IntRange(0, F_LIMIT),
    default=None,
    help=f"Light × BRDF band limit F (0…{F_LIMIT}), instead of choosing it from --eps.",
)
@click.option(
    "--P",
    "P",
    type=click.IntRange(0, P_LIMIT),
    default=None,
    help=f"View band limit P (0…{P_LIMIT}), instead of choosing it from --eps.",
)
@click.option(
    "--face-size",
    type=click.IntRange(FACE_MIN, FACE_MAX),
    default=None,
    help=f"Cube face size in texels ({FACE_MIN}…{FACE_MAX}) [default: power of two nearest "
    f"5F, {FACE_AUTO_MIN}…{FACE_AUTO_MAX}].",
)
@exr_dir_opt("the B_pq cubes shrm_p<p>.exr and reflection.exr (eq. 12 for --view)")
@click.option(
    "--view",
    default="0,0,1",
    show_default=True,
    metavar="X,Y,Z",
    callback=_view,
    help="World view direction (toward the viewer) of reflection.exr.",
)
@png_opt
@report_opt
@layout_opt
@colorspace_opt
@negative_opt
@fix_nonfinite_opt
@json_opt
@quiet_opt
def shrm(env, output, brdf, params, merl_path, eps, F, P, face_size, exr_dir, view, png, report,
         layout, colorspace, negative, fix_nonfinite, as_json, quiet):  # fmt: skip
    """Bake ENV into a Spherical Harmonic Reflection Map for an isotropic BRDF."""
    with usage_errors():
        settings = shrm_settings(brdf=brdf, params=_params(params), merl_path=merl_path,
                                 eps=eps, F=F, P=P, face_size=face_size, view=view)  # fmt: skip
    summary = bake_shrm_file(env_path=env, output=output, settings=settings, exr_dir=exr_dir,
                             report=report, layout=layout, colorspace=colorspace,
                             negative=negative, fix_nonfinite=fix_nonfinite,
                             png=png)  # fmt: skip
    info(
        f"shrm: {output}: {brdf} F={summary['F']} P={summary['P']} face {summary['face_size']} "
        f"BRDF energy left out {summary['eps_brdf']:.4f} (bound {summary['eps_bound']:.2e}), "
        f"{summary['bytes']} bytes, {summary['seconds']['total']:.3f} s"
        + also_wrote(summary.get("exr", [])),
        quiet,
    )
    if report and not as_json:
        click.echo(
            "F\tP\tpredicted\tbound\tmeasured_energy\tmeasured_rel_rms\tseconds\tbytes", err=True
        )
        for r in summary["report"]:
            m = "-\t-"
            if r["measured_rel_rms"] is not None:
                m = f"{r['measured_rel_energy']:.2e}\t{r['measured_rel_rms']:.4f}"
            click.echo(
                f"{r['F']}\t{r['P']}\t{r['eps_brdf']:.4f}\t{r['eps_bound']:.2e}\t{m}\t"
                f"{r['seconds']:.3f}\t{r['bytes']}",
                err=True,
            )
    if as_json:
        emit_json(summary)
