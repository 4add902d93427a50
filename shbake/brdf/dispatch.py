"""One entry point per kernel operation, switching on the model id (check-free).

The tabulation and preview kernels call :func:`brdf_eval`, :func:`lobe_sample`,
:func:`lobe_pdf`, :func:`brdf_eval_pdf` (value and density at once) and
:func:`lobe_line` / :func:`lobe_sample_on_line` (a sample's per-line part once) with a
model id, the packed parameter vector and, for measured data, the data array; a
plain integer switch keeps every kernel a single cached compilation.
"""

from shbake.brdf import (
    ashikhmin_shirley,
    blinn_phong,
    ggx,
    kajiya_kay,
    lafortune,
    lambert,
    merl,
    microfacet,
    phong,
    ward,
)
from shbake.jit import jit


@jit
def brdf_eval(model, prm, data, sx, sy, sz, vx, vy, vz, out):
    """``out[0:3] = f(s, v)`` (1/sr) in the local frame, ``s_z, v_z > 0``."""
    if model == 0:
        lambert.evaluate(prm, sx, sy, sz, vx, vy, vz, out)
    elif model == 1:
        phong.evaluate(prm, sx, sy, sz, vx, vy, vz, out)
    elif model == 2:
        blinn_phong.evaluate(prm, sx, sy, sz, vx, vy, vz, out)
    elif model == 3:
        ashikhmin_shirley.evaluate(prm, sx, sy, sz, vx, vy, vz, out)
    elif model == 4:
        ward.evaluate(prm, sx, sy, sz, vx, vy, vz, out)
    elif model == 5:
        ggx.evaluate(prm, sx, sy, sz, vx, vy, vz, out)
    elif model == 6:
        kajiya_kay.evaluate(prm, sx, sy, sz, vx, vy, vz, out)
    elif model == 8:
        microfacet.evaluate(prm, sx, sy, sz, vx, vy, vz, out)
    elif model == 9:
        lafortune.evaluate(prm, sx, sy, sz, vx, vy, vz, out)
    else:
        merl.evaluate_data(data, sx, sy, sz, vx, vy, vz, out)


@jit
def brdf_eval_pdf(model, prm, data, sx, sy, sz, vx, vy, vz, out):
    """:func:`brdf_eval` into ``out`` and return :func:`lobe_pdf`, ``s_z, v_z > 0``.

    Models whose value and density share a power term (Phong, Blinn–Phong,
    Ashikhmin–Shirley) compute it once: the tabulation's mixture weights need both at
    every node, and the power (an ``exp`` and a ``log``) is most of a node's cost.
    """
    if model == 1:
        return phong.evaluate_pdf(prm, sx, sy, sz, vx, vy, vz, out)
    if model == 2:
        return blinn_phong.evaluate_pdf(prm, sx, sy, sz, vx, vy, vz, out)
    if model == 3:
        return ashikhmin_shirley.evaluate_pdf(prm, sx, sy, sz, vx, vy, vz, out)
    brdf_eval(model, prm, data, sx, sy, sz, vx, vy, vz, out)
    return lobe_pdf(model, prm, sx, sy, sz, vx, vy, vz)


@jit
def lobe_sample(model, prm, vx, vy, vz, ur, ua):
    """Lobe direction from ``ur`` (radial), ``ua`` (azimuthal) in ``[0, 1)``; may be below."""
    if model == 1:
        return phong.sample(prm, vx, vy, vz, ur, ua)
    if model == 2:
        return blinn_phong.sample(prm, vx, vy, vz, ur, ua)
    if model == 3:
        return ashikhmin_shirley.sample(prm, vx, vy, vz, ur, ua)
    if model == 4:
        return ward.sample(prm, vx, vy, vz, ur, ua)
    if model == 5:
        return ggx.sample(prm, vx, vy, vz, ur, ua)
    if model == 6:
        return kajiya_kay.sample(prm, vx, vy, vz, ur, ua)
    if model == 8:
        return microfacet.sample(prm, vx, vy, vz, ur, ua)
    if model == 9:
        return lafortune.sample(prm, vx, vy, vz, ur, ua)
    return merl.sample(prm, vx, vy, vz, ur, ua)


@jit
def lobe_line(model, prm, ua):
    """The part of :func:`lobe_sample` fixed by ``ua``, as two numbers for
    :func:`lobe_sample_on_line` (``(ua, 0)`` for models without such a part).

    The tabulation's lobe rule samples along lines of constant ``ua``; models whose
    sample separates (Phong, Blinn–Phong: ``cos, sin`` of the azimuth;
    Ashikhmin–Shirley: of its eq. 9 azimuth, an ``arctan``/``tan``) compute it once per line.
    """
    if model == 1 or model == 2:  # Phong, Blinn–Phong: the same azimuth 2π u_a
        return phong.line(ua)
    if model == 3:
        return ashikhmin_shirley.line(prm, ua)
    return ua, 0.0


@jit
def lobe_sample_on_line(model, prm, vx, vy, vz, ur, la, lb):
    """:func:`lobe_sample` with ``(la, lb) = lobe_line(model, prm, ua)`` (bit-identical)."""
    if model == 1:
        return phong.sample_on_line(prm, vx, vy, vz, ur, la, lb)
    if model == 2:
        return blinn_phong.sample_on_line(prm, vx, vy, vz, ur, la, lb)
    if model == 3:
        return ashikhmin_shirley.sample_on_line(prm, vx, vy, vz, ur, la, lb)
    return lobe_sample(model, prm, vx, vy, vz, ur, la)


@jit
def lobe_pdf(model, prm, sx, sy, sz, vx, vy, vz):
    """Solid-angle density of :func:`lobe_sample` at ``s`` (1/sr)."""
    if model == 1:
        return phong.pdf(prm, sx, sy, sz, vx, vy, vz)
    if model == 2:
        return blinn_phong.pdf(prm, sx, sy, sz, vx, vy, vz)
    if model == 3:
        return ashikhmin_shirley.pdf(prm, sx, sy, sz, vx, vy, vz)
    if model == 4:
        return ward.pdf(prm, sx, sy, sz, vx, vy, vz)
    if model == 5:
        return ggx.pdf(prm, sx, sy, sz, vx, vy, vz)
    if model == 6:
        return kajiya_kay.pdf(prm, sx, sy, sz, vx, vy, vz)
    if model == 8:
        return microfacet.pdf(prm, sx, sy, sz, vx, vy, vz)
    if model == 9:
        return lafortune.pdf(prm, sx, sy, sz, vx, vy, vz)
    return merl.pdf(prm, sx, sy, sz, vx, vy, vz)
