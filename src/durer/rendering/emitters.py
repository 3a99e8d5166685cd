"""Emitters of the path tracer: area lights (every shape whose material slot emits), point and directional lights
and a constant environment, with light sampling (next-event estimation) and the pdf of reaching an emitter by a
BSDF-sampled ray (for multiple importance sampling).

As in Mitsuba 3, an emitter is picked uniformly, then sampled: a triangle mesh emitter (all triangles of one
emissive material slot) by area, a sphere by the solid angle of the cone it subtends (by area from inside it), the
environment uniformly over the sphere of directions. Area lights emit from the front side of their (possibly
flipped) normals only.

Course scenes: a course light's colour is scaled by pi (point lights keep their a + b d + c d^2 attenuation), so
that a diffuse surface of colour kd lit by it looks as in the ray caster (kd * colour * cos); the ambient light
becomes a constant environment (a white diffuse surface open to the sky reflects the ambient colour), and camera
rays that escape show the background colour instead.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..accel.compile import CompiledScene
from ..scene.graph import Scene
from ..scene.lights import ConstantEnvironment, DirectionalLight, EnvironmentMap, PointLight
from .bsdfs import BSDFTable
from .envmap import EnvMapLight
from .sampling import dot, frame, length, to_world, uniform_cone, uniform_cone_pdf, uniform_sphere, uniform_triangle

AREA_MESH, AREA_SPHERE, POINT, DIRECTIONAL, ENVIRONMENT, ENVMAP = range(6)


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

    @property
    def has_environment(self) -> bool:
        return self.environment_id >= 0

    def environment_radiance(self, d: np.ndarray) -> np.ndarray:
        """Radiance (N,3) of the environment seen along directions d (N,3)."""
        if self.envmap is not None:
            return self.envmap.eval(d)
        return np.tile(self.environment, (len(d), 1))

    @property
    def count(self) -> int:
        return len(self.kind)

    @classmethod
    def build(cls, scene: Scene, cs: CompiledScene, table: BSDFTable) -> Emitters:
        e = cls()
        flat = cs.flat
        n_tri = len(flat.triangles)
        tri_slot = flat.triangle_material if n_tri else np.zeros(0, np.int32)
        e.triangle_emitter = np.full(n_tri, -1, np.int64)
        emits = table.emission.max(axis=1) > 0 if len(table.emission) else np.zeros(0, bool)
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
            e.triangle_emitter[ids] = e.count
            cdf = np.concatenate([[0.0], np.cumsum(area)])
            e._add(AREA_MESH, table.emission[slot], dict(v=v, normal=normal, cdf=cdf / cdf[-1], area=cdf[-1]))
        e.sphere_emitter = np.full(len(cs.sphere_radius), -1, np.int64)
        for k in range(len(cs.sphere_radius)):
            slot = int(cs.sphere_material[k])
            if slot < len(emits) and emits[slot]:
                center, radius = _world_sphere(cs, k)
                e.sphere_emitter[k] = e.count
                e._add(AREA_SPHERE, table.emission[slot],
                       dict(center=center, radius=radius, flip=bool(table.flip[slot])))
        scale = 1.0 if scene.radiometric_lights else np.pi
        for light in scene.lights or []:
            if isinstance(light, PointLight):
                e._add(POINT, scale * light.color, dict(position=light.position, attenuation=light.attenuation))
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

    def sample(self, p: np.ndarray, u_pick: np.ndarray, u: np.ndarray):
        """Next-event estimation from points p (N,3): returns unit directions (N,3), distances (N,; inf for lights
        at infinity), weights = emitted radiance / pdf (N,3; 0 where the sample is invalid), solid-angle pdfs (N,;
        inf for delta lights)."""
        n = len(p)
        d, dist, w, pdf = np.zeros((n, 3)), np.full(n, np.inf), np.zeros((n, 3)), np.zeros(n)
        if not self.count or not n:
            return d, dist, w, pdf
        if self.count == 1:  # one emitter: no picking, no copies
            d, dist, w, pdf = self._sample_one(0, p, u)
        else:
            pick = np.minimum((u_pick * self.count).astype(np.int64), self.count - 1)
            for em in np.unique(pick):
                sel = np.flatnonzero(pick == em)
                d[sel], dist[sel], w[sel], pdf[sel] = self._sample_one(int(em), p[sel], u[sel])
        finite = np.isfinite(pdf)
        pdf[finite] /= self.count
        w *= self.count
        return d, dist, w, pdf

    def _sample_one(self, em: int, p: np.ndarray, u: np.ndarray):
        kind, le, data = self.kind[em], self.radiance[em], self.data[em]
        n = len(p)
        if kind == POINT:
            to = data["position"] - p
            dist = length(to)
            a, b, c = data["attenuation"]
            w = le[None, :] / (a + b * dist + c * dist * dist)[:, None]
            return to / dist[:, None], dist, w, np.full(n, np.inf)
        if kind == DIRECTIONAL:
            return np.tile(-data["direction"], (n, 1)), np.full(n, np.inf), np.tile(le, (n, 1)), np.full(n, np.inf)
        if kind == ENVMAP:
            d, pdf = self.envmap.sample(u)
            w = self.envmap.eval(d) / np.maximum(pdf, 1e-300)[:, None]
            return d, np.full(n, np.inf), np.where((pdf > 0)[:, None], w, 0.0), pdf
        if kind == ENVIRONMENT:
            d = uniform_sphere(u)
            return d, np.full(n, np.inf), np.tile(le * 4.0 * np.pi, (n, 1)), np.full(n, 1.0 / (4.0 * np.pi))
        if kind == AREA_MESH:
            cdf = data["cdf"]
            tri = np.clip(np.searchsorted(cdf, u[:, 0], side="right") - 1, 0, len(cdf) - 2)
            lo, hi = cdf[tri], cdf[tri + 1]
            u0 = np.clip((u[:, 0] - lo) / np.maximum(hi - lo, 1e-300), 0.0, 1.0 - 1e-16)
            b = uniform_triangle(np.column_stack([u0, u[:, 1]]))
            v = data["v"][tri]
            y = (1.0 - b[:, 0] - b[:, 1])[:, None] * v[:, 0] + b[:, :1] * v[:, 1] + b[:, 1:] * v[:, 2]
            normal = data["normal"][tri]
            area_pdf = np.full(n, 1.0 / data["area"])
        else:  # AREA_SPHERE
            y, normal, pdf, inside = self._sphere_point(data, p, u)
            area_pdf = pdf
        to = y - p
        dist = length(to)
        d = to / np.maximum(dist, 1e-300)[:, None]
        cos_l = -dot(d, normal)
        ok = (cos_l > 0) & (dist > 0)
        if kind == AREA_SPHERE:
            pdf = np.where(inside, area_pdf * dist * dist / np.maximum(cos_l, 1e-300), area_pdf)
        else:
            pdf = area_pdf * dist * dist / np.maximum(cos_l, 1e-300)
        pdf = np.where(ok, pdf, 0.0)
        w = np.where(ok[:, None], le[None, :] / np.maximum(pdf, 1e-300)[:, None], 0.0)
        return d, dist, w, pdf

    @staticmethod
    def _sphere_point(data: dict, p: np.ndarray, u: np.ndarray):
        """A point on the sphere seen from p: by solid angle (cone) from outside (pdf per solid angle), uniformly by
        area from inside (pdf per area). Returns point, its emitting normal, pdf and the inside mask."""
        c, r = data["center"], data["radius"]
        to_c = c - p
        dc = length(to_c)
        inside = dc <= r * (1.0 + 1e-9)
        axis = to_c / np.maximum(dc, 1e-300)[:, None]
        sin2 = np.minimum((r / np.maximum(dc, 1e-300)) ** 2, 1.0)
        cos_max = np.sqrt(1.0 - sin2)
        s, t = frame(axis)
        d = to_world(uniform_cone(u, cos_max), s, t, axis)
        # nearest intersection of p + x d with the sphere (the tangent ray when rounding misses it)
        b = dot(d, to_c)
        disc = np.maximum(b * b - (dc * dc - r * r), 0.0)
        x = b - np.sqrt(disc)
        y_out = p + x[:, None] * d
        y_in = c + r * uniform_sphere(u)
        y = np.where(inside[:, None], y_in, y_out)
        normal = (y - c) / r
        if data["flip"]:
            normal = -normal
        pdf = np.where(inside, 1.0 / (4.0 * np.pi * r * r), uniform_cone_pdf(cos_max))
        return y, normal, pdf, inside

    def pdf_hit(self, em: np.ndarray, p_prev: np.ndarray, y: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """Solid-angle pdf (N,) with which `sample` from p_prev would have chosen point y (with emitting normal
        `normal`) on area emitter em (N,), or the environment direction y - p_prev when em is environment_id."""
        out = np.zeros(len(em))
        for e in np.unique(em):
            sel = np.flatnonzero(em == e)
            kind, data = self.kind[e], self.data[e]
            if kind == ENVIRONMENT:
                out[sel] = 1.0 / (4.0 * np.pi)
                continue
            if kind == ENVMAP:
                out[sel] = self.envmap.pdf(y[sel] - p_prev[sel])
                continue
            to = y[sel] - p_prev[sel]
            dist2 = dot(to, to)
            cos_l = np.abs(dot(to, normal[sel])) / np.sqrt(np.maximum(dist2, 1e-300))
            if kind == AREA_MESH:
                out[sel] = dist2 / np.maximum(data["area"] * cos_l, 1e-300)
            else:
                c, r = data["center"], data["radius"]
                dc = length(c - p_prev[sel])
                inside = dc <= r * (1.0 + 1e-9)
                cos_max = np.sqrt(1.0 - np.minimum((r / np.maximum(dc, 1e-300)) ** 2, 1.0))
                out[sel] = np.where(inside, dist2 / np.maximum(4.0 * np.pi * r * r * cos_l, 1e-300),
                                    uniform_cone_pdf(cos_max))
        return out / max(self.count, 1)


def _world_sphere(cs: CompiledScene, k: int) -> tuple[np.ndarray, float]:
    """World centre and radius of sphere k; an emitting sphere must not be squashed into an ellipsoid."""
    inv = np.eye(4)
    inv[:3, :] = cs.sphere_world_to_object[k]
    m = np.linalg.inv(inv)
    scales = np.linalg.norm(m[:3, :3], axis=0)
    if not np.allclose(scales, scales[0], rtol=1e-6):
        raise ValueError("an emitting sphere must be scaled uniformly (its transform makes an ellipsoid)")
    return m[:3, :3] @ cs.sphere_center[k] + m[:3, 3], float(cs.sphere_radius[k] * scales[0])
