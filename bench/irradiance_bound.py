"""A lower bound, by branch and bound, on the least error any three lights + L2 can give.

Usage: ``python bench/irradiance_bound.py [--family directional|rect] [--workers 2] [MAP …]``
(default studio; ``--out PREFIX``, default ``bench/results/irradiance_bound``). The
bound itself is :mod:`tests.light_bound` (checked in ``tests/system/test_light_bound.py``).

Issue 33's diffuse acceptance asks, from the three.js export, for a mean relative luminance
irradiance error ≤ 1 % with every error ≤ 10 % at the 2048 acceptance normals
(:func:`irradiance_lights.acceptance_inputs`), from 9 SH coefficients per channel + ≤ 3
lights. Every light three.js has shades a diffuse probe as a sum of these terms:

* ``DirectionalLight``, ``PointLight``, ``SpotLight`` (at one shading point, a direction and
  a scale): ``s max(0, n·d)``;
* ``RectAreaLight`` (:func:`irradiance_lights.rect_kernel`): ``s max(0, n·d + f)``,
  ``f = |F|`` in [0, 1]; ``f ≥ 1`` is linear in ``n``, in the span of the SH part;
* ``HemisphereLight``, ``AmbientLight``, ``LightProbe``: polynomials of degree ≤ 2 in ``n``,
  in the span of the 9 coefficients.

The luminance of an RGB model is such a model (light luminances ≥ 0), so the least
luminance error over ``c`` (9 coefficients, free: neither held non-negative nor the
constant held by the map's energy, which only lowers the bound) and three lights bounds
every export. With ``v = s d`` and ``t = s f``, each light is ``max(0, n·v + t)``: convex
in ``(v, t)``. The directions are split into the cells of a cube's faces (each cell's cone
is polyhedral: four planes through the origin), the form factor into intervals
(``τ = t / (v·a)``, ``a`` the face's axis, in [0, √3] covers ``f`` in [0, 1] on any face).
Over a cell each normal's term ``u`` is held between linear bounds:
``u ≥ 0``, ``u ≥ n·v + t``, ``u ≤`` the upper hull of the term's values at the cell's
corners (two planes in ``(x, y)``, with which a directional light's bounds are the term's
exact convex hull; with ``τ``: those at ``τ_hi``, and those at ``τ_lo`` plus ``τ − τ_lo``,
the term being non-decreasing and 1-Lipschitz in ``τ``); a normal whose term
keeps one sign over the cell is exact (``n·v + t`` or 0). The linear programme — least mean
``w_i`` with ``|model_i − E_i| ≤ w_i E_i ≤`` :data:`ACCEPT_MAX` ``E_i`` — then bounds every
three lights in those cells from below. A cell triple is discarded when the bound exceeds
1 % (or no point of it keeps every error ≤ 10 %, infeasible: first tried on every eighth
normal, a relaxation too, by the dual simplex); otherwise its coarsest cell is split. When no
triple is left, no three lights + 9 coefficients meet the acceptance on that map: studio,
for directional lights (docs/BENCHMARKS.md, issue 33).

Directional lights: a light at ``d`` equals one at ``−d`` plus the linear ``s n·d``
(``max(0, x) − max(0, −x) = x``), so the three cube faces about +x, +y, +z cover them.
Rectangle lights (``--family rect``, which includes ``f = 0``) need all six.

Writes ``PREFIX.json`` and ``PREFIX.md``: each generation's triples, how many were
discarded by the bound and by infeasibility, the finest cells, the seconds.
"""

import sys

import irradiance_lights as lights
from irradiance_lights import ACCEPT_MAX, ACCEPT_MEAN, ROOT

sys.path.insert(0, str(ROOT))  # the tests package, as pytest sees it

from tests.light_bound import branch_and_bound  # noqa: E402

LIGHTS = 3
"""The acceptance's most lights."""


def measure(name: str, family: str, workers: int) -> dict:
    normals, ref, _, _ = lights.acceptance_inputs(name)
    return branch_and_bound(normals, ref, family, LIGHTS, (ACCEPT_MEAN, ACCEPT_MAX), workers,
                            log=lambda g: print(name, family, g, flush=True))  # fmt: skip


def markdown(results: dict) -> str:
    lines = ["| map | lights | no fit with mean ≤ 1 % and max ≤ 10 % | cell triples solved "
             "| discarded by the bound / as infeasible | finest cell level | seconds |",
             "|---|---|---|---|---|---|---|"]  # fmt: skip
    for m, fams in results.items():
        for family, r in fams.items():
            g = r["generations"]
            lines.append(f"| {m} | 3 {family} | {'proved' if r['proved'] else 'not proved'} "
                         f"| {sum(x['triples'] for x in g)} | {sum(x['bound'] for x in g)} / "
                         f"{sum(x['infeasible'] for x in g)} | {g[-1]['finest_level']} "
                         f"| {r['seconds']} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def main():
    ap = lights.missed_maps_parser(__doc__, "irradiance_bound")
    ap.set_defaults(maps=["studio"])
    ap.add_argument("--family", choices=("directional", "rect"), action="append")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    families = args.family or ["directional"]
    results = {m: {f: measure(m, f, args.workers) for f in families}
               for m in args.maps}  # fmt: skip
    lights.write_results(args.out, results, markdown(results))


if __name__ == "__main__":
    main()
