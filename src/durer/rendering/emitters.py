"""Emitters of the path tracer: area lights (every shape whose material slot emits), point, spot and directional
lights and a constant environment, with light sampling (next-event estimation) and the pdf of reaching an emitter by a
BSDF-sampled ray (for multiple importance sampling).

As in Mitsuba 3, an emitter is picked uniformly, then sampled: a triangle mesh emitter (all triangles of one
emissive material slot) by area, a sphere by the solid angle of the cone it subtends (by area from inside it), a disk
or cylinder by area through its parametrisation, the environment uniformly over the sphere of directions. Area lights
emit from the front side of their (possibly flipped) normals only.

An area light's radiance may be a Mitsuba texture (bitmap or checkerboard): it is looked up at the UV of the point a
path hits (the BSDF row's textured emission, kernels/path/textures.resolve_row) and at the UV of the point light
sampling chose (kernels/path/emitters.py). The emitter is still picked uniformly and its point sampled by area (a
sphere's by solid angle), not by the texture's brightness as Mitsuba 3 samples a spatially varying radiance, so both
strategies' pdfs stay the texture-free ones (the same estimate, with more noise where the texture is very uneven).

Course scenes: a course light's colour is scaled by pi (point lights keep their a + b d + c d^2 attenuation), so
that a diffuse surface of colour kd lit by it looks as in the ray caster (kd * colour * cos); the ambient light
becomes a constant environment (a white diffuse surface open to the sky reflects the ambient colour), and camera
rays that escape show the background colour instead.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..accel.compile import CompiledScene
from ..kernels.path.emitters import (
    AREA,
    AREA_MESH,
    AREA_SHAPE,
    AREA_SPHERE,
    AREA_TEX,
    ATTENUATION,
    AXIS,
    CENTER,
    COS_INNER,
    COS_OUTER,
    DIRECTION,
    DIRECTIONAL,
    ENVIRONMENT,
    ENVMAP,
    FALLOFF,
    FIRST_CDF,
    FIRST_TRI,
    INNER,
    O2W,
    OBJECT_CENTER,
    OUTER,
    PARAMS,
    POINT,
    POSITION,
    RADIUS,
    RIGHT,
    SHAPE_CODE,
    SHAPE_FLIP,
    SPHERE_FLIP,
    SPOT,
    SPOT_TEX,
    TAN_OUTER,
    TRI_COUNT,
    UP,
    W2O,
    light_pdf_kernel,
    sample_lights_kernel,
)
from ..scene.graph import Scene
from ..scene.lights import ConstantEnvironment, DirectionalLight, EnvironmentMap, PointLight, SpotLight
from .bsdfs import TEXTURED_PARAMS, BSDFTable
from .envmap import EnvMapLight, no_envmap
from .textures import TextureTable


@dataclass
class Emitters:
    """Every emitter of a scene as arrays; `count` of them, picked uniformly."""

    kind: list = field(default_factory=list)                # per emitter: AREA_MESH, ... ENVIRONMENT
    radiance: list = field(default_factory=list)            # per emitter: (3,) radiance / intensity / irradiance
    data: list = field(default_factory=list)                # per emitter: kind-specific parameters (below)
    triangle_emitter: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # virtual triangle -> id
    sphere_emitter: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))    # sphere -> id or -1
    environment: np.ndarray | None = None                   # constant radiance of escaping rays (lighting)
    envmap: EnvMapLight | None = None                       # or an environment map
    environment_id: int = -1
    textures: TextureTable = field(default_factory=TextureTable)  # the BSDFs' table (area lights' textured
    # radiance among them), with spots' textures
    _packed: tuple | None = None
    _env: tuple | None = None

    @property
    def has_environment(self) -> bool:
        return self.environment_id >= 0

    @property
    def count(self) -> int:
        return len(self.kind)

    @classmethod
    def build(cls, scene: Scene, cs: CompiledScene, table: BSDFTable) -> Emitters:
        e = cls(textures=table.textures)
        flat = cs.flat
        n_tri = len(flat.triangles)
        tri_slot = flat.triangle_material if n_tri else np.zeros(0, np.int32)
        e.triangle_emitter = np.full(n_tri, -1, np.int64)
        emits = table.emission.max(axis=1) > 0 if len(table.emission) else np.zeros(0, bool)
        tex = table.tex[:, TEXTURED_PARAMS.index("emission")] if len(table.tex) else np.zeros(0, np.int64)
        uvs = np.asarray(flat.triangle_uv, dtype=np.float64).reshape(-1, 6)
        for slot in np.flatnonzero(emits):
            ids = np.flatnonzero(tri_slot == slot)
            if not len(ids):
                continue
            v = flat.triangles[ids]
            cross = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
            area = 0.5 * np.linalg.norm(cross, axis=1)
            normal = cross / np.maximum(2.0 * area, 1e-300)[:, None]
            if table.flip[slot]:
                normal = -normal
            uv = uvs[ids] if len(uvs) else np.zeros((len(ids), 6))  # zeros without UVs, as the hit's uv_at
            e.triangle_emitter[ids] = e.count
            cdf = np.concatenate([[0.0], np.cumsum(area)])
            e._add(AREA_MESH, table.emission[slot], dict(v=v, normal=normal, uv=uv, cdf=cdf / cdf[-1], area=cdf[-1],
                                                         texture=tex[slot]))
        e.sphere_emitter = np.full(len(cs.sphere_radius), -1, np.int64)
        for k in range(len(cs.sphere_radius)):
            slot = int(cs.sphere_material[k])
            if not (slot < len(emits) and emits[slot]):
                continue
            e.sphere_emitter[k] = e.count
            if cs.sphere_radius[k] <= 0:  # a disk or cylinder (kernels/common.py's codes)
                w2o = np.vstack([cs.sphere_world_to_object[k], [0, 0, 0, 1.0]])
                e._add(AREA_SHAPE, table.emission[slot], dict(o2w=np.linalg.inv(w2o)[:3], w2o=w2o[:3],
                                                              code=cs.sphere_radius[k], flip=bool(table.flip[slot]),
                                                              texture=tex[slot]))
                continue
            center, radius = _world_sphere(cs, k)
            e._add(AREA_SPHERE, table.emission[slot], dict(center=center, radius=radius, flip=bool(table.flip[slot]),
                                                           w2o=cs.sphere_world_to_object[k],
                                                           object_center=cs.sphere_center[k], texture=tex[slot]))
        scale = 1.0 if scene.radiometric_lights else np.pi
        for light in scene.lights or []:
            if isinstance(light, PointLight):
                e._add(POINT, scale * light.color, dict(position=light.position, attenuation=light.attenuation))
            elif isinstance(light, SpotLight):
                tex = -1 if light.texture is None else e.textures.add(light.texture)
                e._add(SPOT, scale * light.color, dict(position=light.position, attenuation=light.attenuation,
                                                       light=light, texture=tex))
            elif isinstance(light, DirectionalLight):
                e._add(DIRECTIONAL, scale * light.color, dict(direction=light.direction))
        env = scene.environment
        if env is None and not scene.radiometric_lights and np.any(scene.ambient_light > 0):
            env = ConstantEnvironment(scene.ambient_light)
        if isinstance(env, ConstantEnvironment) and env.radiance.max() > 0:
            e.environment = env.radiance
            e.environment_id = e.count
            e._add(ENVIRONMENT, env.radiance, {})
        elif isinstance(env, EnvironmentMap):
            e.envmap = EnvMapLight(env)
            e.environment_id = e.count
            e._add(ENVMAP, np.zeros(3), {})
        return e

    def _add(self, kind: int, radiance, data: dict) -> None:
        self.kind.append(kind)
        self.radiance.append(np.asarray(radiance, dtype=np.float64))
        self.data.append(data)

    def pack(self) -> tuple:
        """The emitters as the arrays of kernels/path/emitters.py: (kinds, radiance, parameters, triangles,
        triangle normals and corner UVs, per-emitter area cdfs, triangle -> emitter, sphere -> emitter); made
        once."""
        if self._packed is None:
            F = np.zeros((self.count, PARAMS))
            tri_v, tri_n, cdf = [np.zeros((0, 9))], [np.zeros((0, 9))], [np.zeros(0)]
            first_tri = first_cdf = 0
            for e, (kind, data) in enumerate(zip(self.kind, self.data, strict=True)):
                F[e, AREA_TEX] = data["texture"] if kind in (AREA_MESH, AREA_SPHERE, AREA_SHAPE) else -1
                if kind == AREA_MESH:
                    n = len(data["v"])
                    F[e, [AREA, FIRST_TRI, TRI_COUNT, FIRST_CDF]] = data["area"], first_tri, n, first_cdf
                    tri_v.append(data["v"].reshape(n, 9))
                    tri_n.append(np.hstack([data["normal"], data["uv"]]))
                    cdf.append(data["cdf"])
                    first_tri, first_cdf = first_tri + n, first_cdf + n + 1
                elif kind == AREA_SPHERE:
                    F[e, CENTER:CENTER + 3] = data["center"]
                    F[e, RADIUS], F[e, SPHERE_FLIP] = data["radius"], data["flip"]
                    F[e, W2O:W2O + 12], F[e, OBJECT_CENTER:OBJECT_CENTER + 3] = (data["w2o"].reshape(12),
                                                                               data["object_center"])
                elif kind == AREA_SHAPE:
                    F[e, O2W:O2W + 12], F[e, W2O:W2O + 12] = data["o2w"].reshape(12), data["w2o"].reshape(12)
                    F[e, SHAPE_CODE], F[e, SHAPE_FLIP] = data["code"], data["flip"]
                elif kind in (POINT, SPOT):
                    F[e, POSITION:POSITION + 3] = data["position"]
                    F[e, ATTENUATION:ATTENUATION + 3] = data["attenuation"]
                    if kind == SPOT:
                        s = data["light"]
                        outer, inner = np.radians(s.outer_angle), np.radians(s.inner_angle)
                        F[e, AXIS:AXIS + 3] = s.direction
                        F[e, [COS_OUTER, COS_INNER, OUTER, INNER]] = np.cos(outer), np.cos(inner), outer, inner
                        F[e, FALLOFF] = s.falloff == "angle"
                        F[e, SPOT_TEX], F[e, TAN_OUTER] = data["texture"], np.tan(outer)
                        if s.right is not None and s.up is not None:
                            F[e, RIGHT:RIGHT + 3], F[e, UP:UP + 3] = s.right, s.up
                elif kind == DIRECTIONAL:
                    F[e, DIRECTION:DIRECTION + 3] = data["direction"]
            radiance = np.array(self.radiance).reshape(self.count, 3)
            self._packed = tuple(np.ascontiguousarray(a) for a in (
                np.array(self.kind, np.int64), radiance, F, np.concatenate(tri_v), np.concatenate(tri_n),
                np.concatenate(cdf), self.triangle_emitter, self.sphere_emitter))
        return self._packed

    def env_tables(self) -> tuple[np.ndarray, ...]:
        """The environment map's tables as kernels/path/envmap.py takes them (empty without a map)."""
        if self._env is None:
            self._env = self.envmap.tables if self.envmap is not None else no_envmap()
        return self._env

    def sample(self, p: np.ndarray, u_pick: np.ndarray, u: np.ndarray):
        """Next-event estimation from points p (N,3), an emitter picked uniformly: returns unit directions (N,3),
        distances (N,; inf for lights at infinity), weights = emitted radiance / pdf (N,3; 0 where the sample is
        invalid), solid-angle pdfs (N,; inf for delta lights)."""
        n = len(p)
        d, dist, w, pdf = np.zeros((n, 3)), np.full(n, np.inf), np.zeros((n, 3)), np.zeros(n)
        if self.count and n:
            u = np.ascontiguousarray(u, dtype=np.float64)
            sample_lights_kernel(np.ascontiguousarray(p, dtype=np.float64), np.asarray(u_pick, dtype=np.float64),
                                 u, self.pack(), self.env_tables(), self.textures.packed(), d, dist,
                                 w, pdf)
        return d, dist, w, pdf

    def pdf_hit(self, em: np.ndarray, p_prev: np.ndarray, y: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """Solid-angle pdf (N,) with which `sample` from p_prev would have chosen point y (with emitting normal
        `normal`) on area emitter em (N,), or the environment direction y - p_prev when em is environment_id."""
        em = np.ascontiguousarray(em, dtype=np.int64)
        out = np.zeros(len(em))
        packed = self.pack()
        c64 = [np.ascontiguousarray(a, dtype=np.float64) for a in (p_prev, y, normal)]
        light_pdf_kernel(em, *c64, packed[0], packed[2], out)
        if self.envmap is not None:
            sel = np.flatnonzero(em == self.environment_id)
            out[sel] = self.envmap.pdf(y[sel] - p_prev[sel]) / self.count
        return out


def _world_sphere(cs: CompiledScene, k: int) -> tuple[np.ndarray, float]:
    """World centre and radius of sphere k; an emitting sphere must not be squashed into an ellipsoid."""
    inv = np.eye(4)
    inv[:3, :] = cs.sphere_world_to_object[k]
    m = np.linalg.inv(inv)
    scales = np.linalg.norm(m[:3, :3], axis=0)
    if not np.allclose(scales, scales[0], rtol=1e-6):
        raise ValueError("an emitting sphere must be scaled uniformly (its transform makes an ellipsoid)")
    return m[:3, :3] @ cs.sphere_center[k] + m[:3, 3], float(cs.sphere_radius[k] * scales[0])
