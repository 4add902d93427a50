"""What every export reads from an ``env_sh`` asset, turned into the target's frame.

Frames (SPEC §3: shbake's world is right-handed, +Y up):

``y-up``
    the world frame itself (glTF, three.js, Babylon's glTF scenes).
``z-up``
    right-handed, +Z up: ``(x, y, z)_target = (x, −z, y)_world`` (+90° about X;
    Blender's glTF importer convention).

``rotate_deg`` then turns the environment about the target's up axis,
counter-clockwise seen from above (right-hand rule). Directions map as
``d_t = R d_w``; SH coefficients as ``c_t = M(R) c_w``
(:func:`shbake.sh.rotation.rotate`), so ``E_t(R d) = E_w(d)``.
"""

import os
from dataclasses import dataclass, field

import numpy as np

from shbake.envmap.turn import turn_matrix
from shbake.errors import InputError, ParameterError
from shbake.messages import warn
from shbake.sh.rotation import rotate

FRAMES = ("y-up", "z-up")
_FRAME_MATRICES = {
    "y-up": np.eye(3),
    "z-up": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
}
_UP_AXIS = {"y-up": 1, "z-up": 2}
LIGHT_SHORTFALL_WARNING = 0.01
"""Fraction of the fitted lights' energy missing near them in the map above which an
export with cube maps warns (that energy is then in both the lights and the cubes)."""


def frame_matrix(frame: str = "y-up", rotate_deg: float = 0.0) -> np.ndarray:
    """Rotation ``R`` (target ← shbake world) for ``frame`` and a turn about its up axis."""
    if frame not in FRAMES:
        raise ParameterError(f"unknown frame {frame!r}; choose one of {', '.join(FRAMES)}")
    T = turn_matrix(rotate_deg, _UP_AXIS[frame])
    return T @ _FRAME_MATRICES[frame]


@dataclass
class ExportSource:
    """An ``env_sh`` asset's lighting in the target frame.

    Attributes
    ----------
    irradiance9 : (9, 3) or None (a split-sum probe: cube targets only)
        Lambert irradiance SH ``E_i`` (``Â_l`` folded in), shbake basis, target frame:
        ``E(n) = Σ_i E_i y_i(n)`` (radiance × sr; a Lambert albedo ρ shows ``ρ E / π``).
    lighting9 : (9, 3)
        Radiance SH ``L_lm`` (raw projection), shbake basis, target frame.
    sun_direction : (3,) or None
        Unit vector toward the extracted sun, target frame.
    sun_irradiance : (3,) or None
        Sun irradiance at normal incidence, ``radiance × solid_angle``.
    light_directions, light_irradiance : (K, 3) or None
        The asset's fitted lights (``/lights``, ``project-env --lights``): unit vectors
        toward them, target frame, and their irradiance at normal incidence.
    position : (3,) or None
        The probe's position (the asset's ``probe_position``, scene units) in the
        target frame: the frame's axes only — ``rotate_deg`` turns the environment,
        not the scene. ``None`` when the asset records none.
    """

    name: str
    irradiance9: np.ndarray
    lighting9: np.ndarray
    rotation: np.ndarray
    frame: str
    sun_direction: np.ndarray | None = None
    sun_irradiance: np.ndarray | None = None
    sun_solid_angle: float | None = None
    light_directions: np.ndarray | None = None
    light_irradiance: np.ndarray | None = None
    env_path: str | None = None
    """The source map given (``--env``); ``None``: the one the asset records."""
    attrs: dict = field(default_factory=dict)
    """The asset's root attributes (its provenance block, :meth:`environment`)."""
    asset_path: str = ""
    position: np.ndarray | None = None
    map_rotation: np.ndarray | None = None
    """Target ← map rotation of the cube maps: ``rotation`` times the probe's turn
    (``probe_rotation_deg``, :mod:`shbake.envmap.turn`) when the asset's SH were turned
    from the map's; ``None``: ``rotation``."""

    @property
    def lights(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """``(direction, irradiance)`` of every light an export carries: the sun, or each
        fitted light (brightest first); empty without."""
        if self.sun_direction is not None:
            return [(self.sun_direction, np.asarray(self.sun_irradiance, dtype=np.float64))]
        if self.light_directions is None:
            return []
        return list(zip(self.light_directions, self.light_irradiance, strict=True))

    @property
    def cube_rotation(self) -> np.ndarray:
        """The rotation the cube maps are resampled with (:attr:`map_rotation`)."""
        return self.rotation if self.map_rotation is None else self.map_rotation

    def environment(self, sun_radius_deg: float = 10.0):
        """The map the SH came from, world frame (its sun removed if the asset's was; with
        fitted lights, their energy taken from the map around each, :func:`remove_lights`).

        Read as the bake read it (:func:`shbake.format.provenance.reload_source`): the
        asset's recorded input path or ``env_path`` (``--env``), checked by SHA-256, with
        every input policy the asset records.
        """
        from shbake.envmap.sun import extract_sun
        from shbake.format.provenance import reload_source

        env = reload_source(self, self.asset_path, self.env_path, "--env")
        if self.light_directions is not None:
            from shbake.envmap.sun import remove_lights

            residual, report = remove_lights(
                env, self.light_directions @ self.cube_rotation, self.light_irradiance,
                radius_deg=sun_radius_deg,
            )  # fmt: skip
            short = float(report["shortfall_fraction"])
            if short > LIGHT_SHORTFALL_WARNING:
                warn(f"{self.name}: {short:.1%} of the lights' energy is not within "
                     f"{sun_radius_deg:g}° of them in the map; the cube maps keep it too (the "
                     "lights were fitted to the diffuse irradiance)")  # fmt: skip
            return residual
        if self.sun_irradiance is None:
            return env
        sun, residual, _ = extract_sun(env, radius_deg=sun_radius_deg)
        if sun is None or not np.allclose(sun.energy, self.sun_irradiance, rtol=1e-6):
            raise InputError(
                f"{self.name}: re-extracting the sun with radius {sun_radius_deg}° does not give "
                "the asset's sun; pass the radius the asset was baked with"
            )
        return residual


def load_source(
    path: str, frame: str = "y-up", rotate_deg: float = 0.0, env_path: str | None = None
) -> ExportSource:
    """Read an ``env_sh`` asset and express its lighting in the target frame.

    A ``splitsum_probe`` asset is read too, for the cube-map targets only: it
    holds no SH, and its cube chain is prefiltered anew from its source map
    (:meth:`ExportSource.environment`).
    """
    from shbake.format.asset import read_asset

    R = frame_matrix(frame, rotate_deg)
    asset = read_asset(path, kinds=("env_sh", "splitsum_probe"))
    turned = R @ turn_matrix(float(asset.attrs.get("probe_rotation_deg", 0.0)))
    position = (
        _FRAME_MATRICES[frame] @ np.asarray(asset.attrs["probe_position"], dtype=np.float64)
        if "probe_position" in asset.attrs
        else None
    )
    E = L = None  # a split-sum probe carries no SH
    if asset.kind != "splitsum_probe":
        if "/irradiance/sh" not in asset or asset["/irradiance/sh"].shape[0] < 9:
            raise InputError(f"{path}: exports need /irradiance/sh with irradiance lmax >= 2")
        E = rotate(np.asarray(asset["/irradiance/sh"][:9], dtype=np.float64), R)
        L = rotate(np.asarray(asset["/lighting/sh"][:9], dtype=np.float64), R)
    src = ExportSource(
        name=os.path.splitext(os.path.basename(path))[0],
        irradiance9=E,
        lighting9=L,
        rotation=R,
        frame=frame,
        env_path=env_path,
        attrs=asset.attrs,
        asset_path=path,
        position=position,
        map_rotation=turned,
    )
    if asset.kind == "splitsum_probe":
        return src
    if "/sun/direction" in asset:
        d = R @ np.asarray(asset["/sun/direction"], dtype=np.float64)
        src.sun_direction = d / np.linalg.norm(d)
        omega = float(asset["/sun/solid_angle"])
        src.sun_solid_angle = omega
        src.sun_irradiance = np.asarray(asset["/sun/radiance"], dtype=np.float64) * omega
    if "/lights/angular_radius" in asset and np.any(np.asarray(asset["/lights/angular_radius"])):
        raise InputError(f"{path}: its lights are spheres (project-env --light-shape sphere) and "
                         "engines shade lights as points: bake with --light-shape point, or "
                         "export --to webgl (shbake's shaders)")  # fmt: skip
    if "/lights/direction" in asset:
        d = np.asarray(asset["/lights/direction"], dtype=np.float64).reshape(-1, 3) @ R.T
        src.light_directions = d / np.linalg.norm(d, axis=1, keepdims=True)
        src.light_irradiance = np.asarray(asset["/lights/irradiance"], dtype=np.float64)
    return src


def require_sh(src: ExportSource, target: str) -> None:
    """Refuse a source without SH (a split-sum probe) for an SH target."""
    if src.irradiance9 is None:
        raise InputError(f"{src.name}: --to {target} needs an env_sh asset (SH lighting)")


def shbake_irradiance(src: ExportSource, dirs: np.ndarray) -> np.ndarray:
    """``E(n)`` of the source in its (target) frame at unit ``dirs`` (…, 3): SH plus lights."""
    from shbake.sh.basis import real_sh

    E = real_sh(dirs, 2) @ src.irradiance9
    for direction, irradiance in src.lights:
        E = E + np.maximum(np.asarray(dirs) @ direction, 0.0)[..., None] * irradiance
    return E
