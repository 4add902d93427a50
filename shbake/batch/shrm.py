"""``shbake shrm`` as one unit of work: check the settings, load the map, bake, write the asset
(and the EXR cubes), and the ``--report`` table."""

from dataclasses import dataclass

import numpy as np

from shbake.bakers.shrm import bake_shrm, check_face_size
from shbake.brdf.reflection import (
    F_LIMIT,
    P_LIMIT,
    BRDFCoefficients,
    ReflectionBRDF,
    brdf_coefficients,
    check_eps,
    check_F,
    check_P,
    make_reflection_brdf,
    search_orders,
)
from shbake.conventions import unit_vectors
from shbake.errors import ParameterError
from shbake.evaluation.shrm import ShrmCheck
from shbake.format.shrm import build_shrm_asset
from shbake.resources import path_arguments


def report_rows(env, rb: ReflectionBRDF, F_values, P_values, face_size: int = 32,
                sphere: int = 24) -> list[dict]:  # fmt: skip
    """The ``--report`` table: per ``(F, P)`` the predicted error (BRDF energy left out and
    the appendix-B bound, both energy fractions), the error measured against brute force on
    a sphere seen from +Z (:class:`~shbake.evaluation.shrm.ShrmCheck`: relative RMS, and its
    square, the relative energy; surface and lobe kinds), the bake time and the bytes."""
    F_values, P_values = list(F_values), list(P_values)
    if rb.radially_symmetric:
        P_values = [0]
    co = brdf_coefficients(rb, max(F_values), max(P_values))
    check = ShrmCheck(env, rb, sphere)
    rows = []
    for F in F_values:
        for P in P_values:
            b = bake_shrm(env, rb, eps=0.5, F=F, P=P, face_size=face_size, coeffs_full=co)
            row = {"F": F, "P": P, "eps_brdf": b.orders.eps_brdf,
                   "eps_bound": b.bound["eps_bound_max"], "seconds": b.timings["total"],
                   "bytes": int(b.cube.nbytes), "measured_rel_rms": None,
                   "measured_rel_energy": None}  # fmt: skip
            if check.ref is not None:
                e2 = check.rel_energy(build_shrm_asset(b, env.meta))
                row["measured_rel_rms"] = float(np.sqrt(e2))
                row["measured_rel_energy"] = e2  # comparable with eps_brdf and the bound
            rows.append(row)
    return rows


@dataclass
class ShrmSettings:
    """The checked settings of one ``shrm`` bake (:func:`shrm_settings`); ``search``: the
    coefficients to the limits the orders are chosen from (``None`` when ``F`` or ``P`` is
    given)."""

    rb: ReflectionBRDF
    eps: float
    F: int | None
    P: int | None
    face_size: int | None
    view: np.ndarray
    search: BRDFCoefficients | None


@path_arguments("merl_path")
def shrm_settings(brdf: str = "microfacet", params: dict | None = None,
                  merl_path: str | None = None, eps: float = 0.03, F=None, P=None,
                  face_size=None, view=(0.0, 0.0, 1.0)) -> ShrmSettings:  # fmt: skip
    """Every setting of the ``shrm`` command checked before a map is read; a
    :class:`~shbake.errors.ParameterError` names the first bad one (the CLI's usage error).
    ``view``: the world view direction of ``reflection.exr`` (normalised here).

    With neither ``F`` nor ``P`` given, an ``eps`` no ``F ≤ F_LIMIT``, ``P ≤ P_LIMIT``
    reaches is refused (:func:`~shbake.brdf.reflection.search_orders`, as the planner
    refuses it), naming the best reachable.

    >>> s = shrm_settings("phong-lobe", {"s": 8}, F=4)
    >>> s.rb.kind, s.F, s.P, s.view.tolist()
    ('lobe', 4, None, [0.0, 0.0, 1.0])
    """
    eps = check_eps(eps)
    F, P = check_F(F), check_P(P)
    rb = make_reflection_brdf(brdf, params, merl_path)
    if rb.radially_symmetric and P not in (None, 0):
        raise ParameterError(f"{rb.name} is radially symmetric: P must be 0, got {P}")
    if face_size is not None:
        check_face_size(face_size, P or 0, rb.kind)
    v = unit_vectors(view, "view")  # any finite non-zero magnitude (1e-320, 1e308)
    if v.shape != (3,):
        raise ParameterError(f"view must be one x,y,z vector, got shape {v.shape}")
    search = None
    if F is None and P is None:
        orders, search = search_orders(rb, eps)
        if not orders.reached:
            raise ParameterError(
                f"eps {eps:g} is not reachable for {rb.name} within F ≤ {F_LIMIT}, P ≤ "
                f"{P_LIMIT}: the best leaves {orders.eps_brdf:.3g} of the BRDF energy out; "
                "give a larger --eps, or --F/--P to bake at given orders"
            )
    return ShrmSettings(rb, eps, F, P, face_size, v, search)


@path_arguments("env_path", "output", "exr_dir")
def bake_shrm_file(env_path: str, output: str, settings: ShrmSettings,
                   exr_dir: str | None = None, report: bool = False, layout=None,
                   colorspace=None, negative: str | None = None, fix_nonfinite=None,
                   quiet: bool = False, png: bool = False) -> dict:  # fmt: skip
    """The ``shbake shrm`` command: load the map, bake at ``settings`` (checked before, by
    :func:`shrm_settings`), write the asset (and the EXR cubes: the ``B_pq`` cubes and the
    eq. 12 reflection cube for ``settings.view``, with ``png`` a PNG beside each),
    optionally build the report; the summary dict."""
    from shbake.envmap import load_environment
    from shbake.format.atomic import check_output_dir, check_writable_dir
    from shbake.format.shrm import write_exr_cubes, write_shrm
    from shbake.shading.shrm import reflection_cube

    check_writable_dir(output)
    if exr_dir:
        check_output_dir(exr_dir, "--exr-dir")
    rb, eps, F, P = settings.rb, settings.eps, settings.F, settings.P
    env = load_environment(env_path, layout, colorspace, negative, fix_nonfinite, quiet)
    bake = bake_shrm(env, rb, eps, F, P, settings.face_size, coeffs_full=settings.search)
    asset = build_shrm_asset(bake, env.meta)
    write_shrm(output, asset)
    summary = {
        "output": output, "brdf": rb.describe(), "F": bake.F, "P": bake.P, "eps": eps,
        "eps_brdf": bake.orders.eps_brdf, "eps_reached": bake.orders.reached,
        "eps_bound": bake.bound["eps_bound_max"], "face_size": bake.face_size,
        "bytes": int(bake.cube.nbytes), "seconds": bake.timings,
    }  # fmt: skip
    if exr_dir:
        tangent = rb.kind == "tangent"
        reflection = reflection_cube(bake.cube, settings.view, "tangent" if tangent else "surface")
        summary["exr"] = write_exr_cubes(exr_dir, bake.cube, tangent, reflection, png)
    if report:
        Fs = sorted({max(1, bake.F // 2), max(1, (3 * bake.F) // 4), bake.F,
                     min(F_LIMIT, bake.F + bake.F // 2)})  # fmt: skip
        Ps = sorted({0, max(0, bake.P - 1), bake.P, min(P_LIMIT, bake.P + 1)})
        summary["report"] = report_rows(env, rb, Fs, Ps, face_size=min(bake.face_size, 64))
    return summary
