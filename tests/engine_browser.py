"""Rendering in real engines: the Python side of ``tests/engines/harness.mjs``.

:class:`EngineBrowser` runs the harness (one headless Chromium, WebGL2 on SwiftShader, and a
localhost server) for a whole test session and asks an engine page to render; the page returns
float32 RGBA images, rows top first, of a perspective camera (vertical field of view
``fov_deg``, square images) looking from ``eye`` at ``target``. :func:`pixel_rays` gives the
world ray of each pixel centre, so the view vector of every covered pixel is known exactly
(``v = −ray``), and the normal pass gives the normal the engine actually drew.

Chromium is Debian's ``chromium`` (``make test`` installs it when missing and run as root);
:func:`chromium_or_reason` says why it cannot run otherwise.
"""

import base64
import json
import os
import shutil
import subprocess
from dataclasses import dataclass

import numpy as np

ENGINES = os.path.join(os.path.dirname(__file__), "engines")
CHROMIUM = os.environ.get("SHBAKE_CHROMIUM", "/usr/bin/chromium")
INSTALL_HINT = "apt-get install chromium (Debian's package; make test installs it as root)"


def chromium_or_reason() -> str | None:
    """``None`` when the rendered tests can run, else the one-line reason they cannot."""
    if shutil.which("node") is None:
        return "node is not installed"
    if not os.path.isdir(os.path.join(ENGINES, "node_modules", "puppeteer-core")):
        return "engine packages missing: run `npm ci --prefix tests/engines` (make test does)"
    if not os.access(CHROMIUM, os.X_OK):
        return f"{CHROMIUM} not found: {INSTALL_HINT}"
    return None


@dataclass(frozen=True)
class View:
    """A camera: eye, the point looked at and the up vector, shbake's world frame."""

    eye: tuple
    target: tuple = (0.0, 0.0, 0.0)
    up: tuple = (0.0, 1.0, 0.0)

    def as_json(self) -> dict:
        return {"eye": list(self.eye), "target": list(self.target), "up": list(self.up)}


def pixel_rays(view: View, size: int, fov_deg: float) -> np.ndarray:
    """Unit world directions ``(size, size, 3)`` of the rays through the pixel centres.

    Row 0 is the top of the image; a right-handed camera looking down its −z axis
    (``lookAt``), vertical field of view ``fov_deg``, aspect 1.
    """
    eye, target, up = (np.asarray(a, dtype=np.float64) for a in (view.eye, view.target, view.up))
    back = eye - target
    back /= np.linalg.norm(back)
    right = np.cross(up, back)
    right /= np.linalg.norm(right)
    true_up = np.cross(back, right)
    t = np.tan(np.radians(fov_deg) / 2.0)
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x = c[None, :] * t
    y = -c[:, None] * t
    d = x[..., None] * right + y[..., None] * true_up - back
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def decode(b64: str, size: int) -> np.ndarray:
    """A page's base64 float32 RGBA image → ``(size, size, 4)``."""
    return np.frombuffer(base64.b64decode(b64), dtype="<f4").reshape(size, size, 4)


class EngineBrowser:
    """One harness process (Chromium + server) serving files under ``data_root``."""

    def __init__(self, data_root: str):
        self.data_root = os.path.abspath(data_root)
        self.proc = subprocess.Popen(
            ["node", os.path.join(ENGINES, "harness.mjs"), self.data_root],
            cwd=ENGINES,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        hello = json.loads(self.proc.stdout.readline() or "{}")
        if not hello.get("ready"):
            self.close()
            raise RuntimeError("the engine harness did not start (see its stderr)")
        self.chromium = hello["chromium"]
        self._next = 0

    def url(self, path: str) -> str:
        """The URL a page loads ``path`` (a file under ``data_root``) from."""
        rel = os.path.relpath(os.path.abspath(path), self.data_root)
        if rel.startswith(".."):
            raise ValueError(f"{path} is outside the harness's data root {self.data_root}")
        return "/data/" + rel.replace(os.sep, "/")

    def call(self, page: str, params: dict) -> dict:
        """Run ``window.shbakeRender(params)`` in a fresh tab of ``page``: the answer
        (``result``, ``console`` lines); raises with the page's error and console."""
        answer = self._ask({"page": page, "params": params})
        if not answer.get("ok"):
            console = "\n".join(answer.get("console", []))
            raise RuntimeError(f"{page}: {answer.get('error', 'harness died')}\n{console}")
        return answer

    def _ask(self, request: dict) -> dict:
        self._next += 1
        self.proc.stdin.write(json.dumps({"id": self._next, **request}) + "\n")
        self.proc.stdin.flush()
        return json.loads(self.proc.stdout.readline() or "{}")

    def screenshot(self, path: str, selector: str | None = None, viewport=(640, 720),
                   measure=()) -> dict:  # fmt: skip
        """Open the page ``path`` (a file under ``data_root``: an export's own viewer, the
        overview) in a ``viewport`` of (width, height) CSS pixels, wait until its body's
        ``data-state`` leaves ``loading`` and capture it (the element ``selector`` alone, if
        given): ``state``, ``png`` (bytes), ``console``, the page's lines before the
        capture, and ``layout``: ``scrollWidth``, ``clientWidth``, ``innerHeight``,
        ``rects`` (the box of each selector in ``measure``) and ``overflowing`` (elements
        reaching past the right edge)."""
        answer = self._ask({"screenshot": self.url(path), "selector": selector,
                            "width": viewport[0], "height": viewport[1],
                            "measure": list(measure)})  # fmt: skip
        if not answer.get("ok"):
            raise RuntimeError(f"{path}: {answer.get('error', 'harness died')}")
        r = answer["result"]
        return {"state": r.get("state"), "png": base64.b64decode(r["png"]), "console": r["console"],
                "layout": r["layout"]}  # fmt: skip

    def render(self, page: str, views: list[View], size: int, fov_deg: float, **params) -> dict:
        """Render ``params['materials']`` on the unit sphere from ``views``: a dict with
        ``normal`` ``(V, size, size, 4)``, ``radiance[name]`` likewise, ``rays``
        ``(V, size, size, 3)`` and the page's ``console`` lines."""
        answer = self.call(
            page,
            {
                **params,
                "size": size,
                "fov_deg": fov_deg,
                "views": [v.as_json() for v in views],
            },
        )
        r = answer["result"]
        return {
            "normal": np.stack([decode(b, size) for b in r["normal"]]),
            "radiance": {
                k: np.stack([decode(b, size) for b in imgs]) for k, imgs in r["radiance"].items()
            },
            "rays": np.stack([pixel_rays(v, size, fov_deg) for v in views]),
            "console": answer["console"],
        }

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.stdin.close()
            try:
                self.proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def inner_pixels(normal: np.ndarray) -> np.ndarray:
    """Pixels ``(V, H, W)`` the sphere covers with all four neighbours covered (no rim pixel,
    whose normal differences reach past the silhouette)."""
    cov = normal[..., 3] > 0.5
    inner = cov.copy()
    for axis in (1, 2):
        for step in (1, -1):
            inner &= np.roll(cov, step, axis)
    return inner


def quad_derivatives(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``dFdx``, ``dFdy`` of an image ``(V, H, W, C)`` (``H``, ``W`` even) as a GPU takes
    them on 2×2 pixel quads, "fine": the difference across the quad's two columns in each
    of its rows, and across its two rows in each column. SwiftShader's (three's page writes
    its own ``getGeometryRoughness`` from them: :class:`TestHarness`)."""
    v, h, w, c = image.shape
    q = image.reshape(v, h // 2, 2, w // 2, 2, c)
    dx = np.repeat(q[:, :, :, :, 1:] - q[:, :, :, :, :1], 2, axis=4)
    dy = np.repeat(q[:, :, 1:] - q[:, :, :1], 2, axis=2)
    return dx.reshape(image.shape), dy.reshape(image.shape)


def reflect(rays: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Mirror directions of the view rays about unit ``normals``."""
    return rays - 2.0 * (rays * normals).sum(-1, keepdims=True) * normals


def signed_permutations() -> list[np.ndarray]:
    """The 48 axis flips and swaps (3×3 signed permutation matrices), the identity first."""
    import itertools

    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            m = np.zeros((3, 3))
            m[range(3), perm] = signs
            out.append(m)
    out.sort(key=lambda m: not np.array_equal(m, np.eye(3)))
    return out


def latlong_bilinear(pixels: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """A lat-long map (SPEC §3: ``u = atan2(x, −z)/2π``, ``v = acos(y)/π``) at unit ``dirs``,
    texel-centred bilinear, columns wrapping: the radiance a mirror shows (test-side code)."""
    img = np.asarray(pixels, dtype=np.float64)
    h, w = img.shape[:2]
    u = (np.arctan2(dirs[:, 0], -dirs[:, 2]) / (2.0 * np.pi)) % 1.0
    v = np.arccos(np.clip(dirs[:, 1], -1.0, 1.0)) / np.pi
    x = u * w - 0.5
    y = np.clip(v * h - 0.5, 0.0, h - 1.0)
    x0 = np.floor(x).astype(int)
    y0 = np.floor(y).astype(int)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    y1, x1, x0 = np.minimum(y0 + 1, h - 1), (x0 + 1) % w, x0 % w
    top = (1 - fx) * img[y0, x0] + fx * img[y0, x1]
    bottom = (1 - fx) * img[y1, x0] + fx * img[y1, x1]
    return (1 - fy) * top + fy * bottom


def write_sphere_gltf(path: str, kind: str, lon: int = 256, lat: int = 128) -> str:
    """A unit UV sphere (``lon × lat`` quads, analytic normals) as a glTF with an embedded
    buffer, for engines that draw glTF materials only (Filament's gltfio ubershaders):
    ``kind`` ``lit`` (metallic-roughness, factors set by the page), ``diffuse`` (the same
    with ``KHR_materials_specular`` factor 0: no specular lobe) or ``normal`` (unlit,
    vertex colour ``0.5 + 0.5 n``, the normal pass)."""
    theta = np.linspace(0.0, np.pi, lat + 1)
    phi = np.linspace(0.0, 2.0 * np.pi, lon + 1)
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    n = np.stack([st * np.sin(phi), np.broadcast_to(ct, st.shape * np.array([1, 1]))
                  * np.ones_like(phi), st * np.cos(phi)], -1).reshape(-1, 3)  # fmt: skip
    n = (n / np.linalg.norm(n, axis=-1, keepdims=True)).astype("<f4")
    i = np.arange(lat)[:, None] * (lon + 1) + np.arange(lon)[None, :]
    quads = np.stack([i, i + lon + 1, i + 1, i + 1, i + lon + 1, i + lon + 2], -1)
    idx = quads.reshape(-1).astype("<u4")
    attrs = [n, n] + ([(0.5 + 0.5 * n).astype("<f4")] if kind == "normal" else [])
    blobs = [a.tobytes() for a in attrs] + [idx.tobytes()]
    offsets = np.cumsum([0] + [len(b) for b in blobs])
    views = [{"buffer": 0, "byteOffset": int(o), "byteLength": len(b)}
             for o, b in zip(offsets, blobs, strict=False)]  # fmt: skip
    accessors = [{"bufferView": k, "componentType": 5126, "count": len(n), "type": "VEC3"}
                 for k in range(len(attrs))]  # fmt: skip
    accessors[0].update(min=[-1.0, -1.0, -1.0], max=[1.0, 1.0, 1.0])
    accessors.append({"bufferView": len(attrs), "componentType": 5125, "count": len(idx),
                      "type": "SCALAR"})  # fmt: skip
    prim = {"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": len(attrs), "material": 0}
    material = {"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1]}}
    used = []
    if kind == "normal":
        prim["attributes"]["COLOR_0"] = 2
        material["extensions"] = {"KHR_materials_unlit": {}}
        used.append("KHR_materials_unlit")
    elif kind == "diffuse":
        material["extensions"] = {"KHR_materials_specular": {"specularFactor": 0.0}}
        used.append("KHR_materials_specular")
    data = b"".join(blobs)
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64,"
                     + base64.b64encode(data).decode()}],
        "bufferViews": views, "accessors": accessors, "materials": [material],
        "meshes": [{"primitives": [prim]}], "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}],
        "scene": 0, **({"extensionsUsed": used} if used else {}),
    }  # fmt: skip
    with open(path, "w", encoding="utf-8") as f:
        json.dump(doc, f)
    return path
