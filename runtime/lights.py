"""Light reaching a surface: every light's direction and shadowed colour at the hits of a
wave (`light_colours`), shadow rays (`shadow`: POV-Ray's adaptive area-light sampling;
`shadow_filter`: light let through transparent objects, with faked caustics) and the
interior fade of light that crossed an object's inside. The media along a shadow ray are
reached through the context (`ctx.media`), not imported: the media import this module."""

from __future__ import annotations

import numpy as np

from lang import ir
from runtime import patterns, shading, uvmap
from runtime.context import Context, Hit, LightColours, resolve_textures
from runtime.fog import apply_fogs, scene_fogs

# A shadow ray crosses at most this many transparent surfaces before it counts as blocked
# (bounds the loop for pathological stacks of glass; each crossing is one batch query).
MAX_SHADOW_CROSSINGS: int = 32


# POV-Ray's faked caustics brighten light through a transparent surface by
# 1 + |N.L|^(45 caustics): near head-on light is focused, oblique light is not.
CAUSTICS_SCALE: float = 45.0


def light_colours(ctx: Context, hit: Hit) -> LightColours:
    """Every light as seen from every hit: direction and shadowed colour (once per hit,
    shared by all texture layers, like POV-Ray's light colour cache)."""
    dirs_out, cols_out = [], []
    lit = ctx.lit[hit.tex]
    origins = _shadow_origins(ctx, hit)
    # A bumpy normal may face a light the smooth one does not: test those hits too.
    any_side = ctx.double_illuminate[hit.obj] | ctx.back_lit[hit.tex] | ctx.bumpy[hit.tex]
    fogs = scene_fogs(ctx.scene)
    projected = getattr(ctx.prepared, "projected", None) or [None] * len(ctx.scene.lights)
    receivers = getattr(ctx.prepared, "receivers", None) or [None] * len(ctx.scene.lights)
    # Point-light shadow rays of every light go through the tracer in one batch (a shadow
    # ray's answer depends on its own ray only): a scene's objects are then visited once
    # per wave instead of once per light, which is most of the tracing of many-object
    # scenes lit by several lights. Area lights sample adaptively, light by light.
    pending: list[tuple[int, np.ndarray, np.ndarray]] = []  # (light, rows, reach[rows])
    states = []
    for k, (light, through_node, lights_them) in enumerate(
        zip(ctx.scene.lights, projected, receivers, strict=True)
    ):
        ls = shading.sample_light(light, hit.point)
        col = ls.colour
        facing = np.einsum("ij,ij->i", hit.normal, ls.direction) >= shading.EPSILON
        need = lit & (facing | any_side)
        if lights_them is not None:  # a light group's light, or a group the scene's miss
            need &= lights_them[hit.obj]
        need &= np.abs(col).max(axis=1) > shading.EPSILON
        col = np.where(need[:, None], col, 0.0)
        reach = ls.distance  # how far the shadow test looks
        if light.projected_through is not None:
            rows = np.nonzero(need)[0]
            through = _through(through_node, origins[rows], ls.direction[rows])
            col[rows] *= (through < ls.distance[rows])[:, None]
            # only what lies before the object casts a shadow (the object itself does not)
            reach = ls.distance.copy()
            reach[rows] = np.minimum(reach[rows], through - _SMALL_TOLERANCE)
        states.append((light, ls, col, need))
        if not light.shadowless:
            rows = np.nonzero(need)[0]
            if len(rows) and _point_shadow(light):
                pending.append((k, rows, reach[rows]))
            elif len(rows):
                col[rows] *= shadow(ctx, light, origins[rows], ls.direction[rows], reach[rows])
    if pending:
        rows_all = np.concatenate([rows for _, rows, _ in pending])
        dirs = np.concatenate([states[k][1].direction[rows] for k, rows, _ in pending])
        reach_all = np.concatenate([reach for _, _, reach in pending])
        through_all = shadow_filter(ctx, origins[rows_all], dirs, reach_all)
        start = 0
        for k, rows, _ in pending:
            states[k][2][rows] *= through_all[start : start + len(rows)]
            start += len(rows)
    for light, ls, col, need in states:
        if not light.shadowless and ctx.media is not None:
            rows = np.nonzero(need)[0]
            if len(rows):
                col[rows] *= ctx.media.transmittance(
                    ctx,
                    origins[rows],
                    ls.direction[rows],
                    ls.distance[rows],
                    light.media_attenuation,
                )
        if light.media_attenuation and light.media_interaction and fogs:
            # POV-Ray's ComputeShadowMedia: the fog between the surface and the light
            # dims it (a shadow ray's fog adds no colour of its own)
            rows = np.nonzero(np.abs(col).max(axis=1) >= shading.EPSILON)[0]
            if len(rows):
                col[rows] = apply_fogs(
                    fogs, ls.distance[rows], col[rows], origins[rows], ls.direction[rows], True
                )
        dirs_out.append(ls.direction)
        cols_out.append(col)
    return LightColours(dirs_out, cols_out)


def _point_shadow(light: ir.Light) -> bool:
    """Is the light's shadow one ray per point (not an area light's adaptive samples)?"""
    area = light.area
    return area is None or area.size1 * area.size2 <= 1


# POV-Ray's SMALL_TOLERANCE, by which the projected_through shadow test stops short
_SMALL_TOLERANCE = 1e-3


def _through(node, origins: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """(N,) how far each ray travels to the first crossing of a light's projected_through
    object (`node`, from prepare; None: it has no surface strala can cross, warned there;
    inf: no crossing): POV-Ray's TracePointLightShadowRay lets the light through only where
    the way to it meets the object, shadows still applying."""
    if node is None or not len(origins):
        return np.full(len(origins), np.inf)
    t = node.crossings(origins, dirs).t
    t = np.where(t > shading.EPSILON, t, np.inf)
    return t.min(axis=1) if t.shape[1] else np.full(len(origins), np.inf)


def _shadow_origins(ctx: Context, hit: Hit) -> np.ndarray:
    """Where shadow rays start: the hit points, except on meshes tessellated from curved
    surfaces, whose points move onto the surface their smooth normals describe."""
    curved = getattr(ctx.prepared, "curved", None)
    triangles = ctx.tracer.triangles
    if curved is None or not curved.any() or hit.prim is None or triangles is None:
        return hit.point
    sel = np.nonzero((hit.prim >= 0) & curved[hit.obj])[0]
    if len(sel) == 0:
        return hit.point
    out = hit.point.copy()
    out[sel] = triangles.terminator_points(
        hit.obj[sel], hit.prim[sel], hit.point[sel], hit.normal[sel]
    )
    return out


def shadow(ctx: Context, light: ir.Light, points, ldir, ldist) -> np.ndarray:
    """(N,3) fraction of the light that reaches the points. Area lights follow POV-Ray's
    adaptive sampling, vectorised over (point, grid region) pairs: sample a region's four
    corner sub-lights; split it into quarters (sharing their middle row/column) while its
    level is below `adaptive` or its corners differ by more than 0.1; a region that is not
    split contributes the mean of its corners. Each round of splitting is one batch of
    shadow rays, and no sub-light is traced twice for the same point."""
    area = light.area
    if area is None or area.size1 * area.size2 <= 1:
        return shadow_filter(ctx, points, ldir, ldist)
    n1, n2 = max(1, area.size1), max(1, area.size2)
    n = len(points)
    centres = shading.area_centres(light, points).reshape(n, n1, n2, 3)
    cache = np.full((n, n1, n2, 3), np.nan)
    out = np.zeros((n, 3))
    pt = np.arange(n)
    u1 = np.zeros(n, dtype=np.int64)
    v1 = np.zeros(n, dtype=np.int64)
    u2 = np.full(n, n1 - 1, dtype=np.int64)
    v2 = np.full(n, n2 - 1, dtype=np.int64)
    level = np.zeros(n, dtype=np.int64)
    weight = np.ones(n)
    while len(pt):
        corners = ((u1, v1), (u2, v1), (u1, v2), (u2, v2))
        cp = np.concatenate([pt] * 4)
        cu = np.concatenate([c[0] for c in corners])
        cv = np.concatenate([c[1] for c in corners])
        key = np.unique((cp * n1 + cu) * n2 + cv)
        kp, rest = np.divmod(key, n1 * n2)
        ku, kv = np.divmod(rest, n2)
        todo = np.isnan(cache[kp, ku, kv, 0])
        kp, ku, kv = kp[todo], ku[todo], kv[todo]
        if len(kp):
            f = _sub_light_filter(ctx, light, points[kp], ldir[kp], centres[kp, ku, kv][:, None])
            cache[kp, ku, kv] = f[:, 0]
        s = [cache[pt, u, v] for u, v in corners]
        divisible = (u2 - u1 > 1) | (v2 - v1 > 1)
        differ = level < area.adaptive
        for a, b in ((0, 1), (1, 3), (3, 2), (2, 0)):
            differ = differ | (np.abs(s[a] - s[b]).sum(axis=1) > 0.1)
        split = divisible & differ
        leaf = ~split
        np.add.at(out, pt[leaf], (weight[leaf] / 4.0)[:, None] * (s[0] + s[1] + s[2] + s[3])[leaf])
        if not split.any():
            break
        pt, u1, v1, u2, v2 = pt[split], u1[split], v1[split], u2[split], v2[split]
        level, weight = level[split] + 1, weight[split] / 4.0
        mu, mv = (u1 + u2) / 2.0, (v1 + v2) / 2.0
        lo_u, hi_u = np.floor(mu).astype(np.int64), np.ceil(mu).astype(np.int64)
        lo_v, hi_v = np.floor(mv).astype(np.int64), np.ceil(mv).astype(np.int64)
        quads = (
            (u1, v1, lo_u, lo_v),
            (hi_u, v1, u2, lo_v),
            (u1, hi_v, lo_u, v2),
            (hi_u, hi_v, u2, v2),
        )
        u1 = np.concatenate([q[0] for q in quads])
        v1 = np.concatenate([q[1] for q in quads])
        u2 = np.concatenate([q[2] for q in quads])
        v2 = np.concatenate([q[3] for q in quads])
        pt = np.concatenate([pt] * 4)
        level = np.concatenate([level] * 4)
        weight = np.concatenate([weight] * 4)
    return out


def _sub_light_filter(ctx: Context, light: ir.Light, points, ldir, centres) -> np.ndarray:
    """(N,K,3) shadow filter toward K sub-light positions (N,K,3) per point, one batch."""
    n, k, _ = centres.shape
    pts = np.repeat(points, k, axis=0)
    to = centres.reshape(-1, 3) - pts
    if light.kind == "parallel" or light.kind == "cylinder":
        # Parallel and cylinder area lights keep their beam direction; only the start moves.
        d = np.repeat(ldir, k, axis=0)
        depth = np.einsum("ij,ij->i", to, d)
    else:
        depth = np.linalg.norm(to, axis=1)
        d = to / np.where(depth > 0, depth, 1.0)[:, None]
    return shadow_filter(ctx, pts, d, depth).reshape(n, k, 3)


def shadow_filter(ctx: Context, points, ldir, ldist) -> np.ndarray:
    """(N,3) light let through between the points and the light: 0 behind an opaque
    object, filter*colour + transmit through each transparent one."""
    n = len(points)
    tmax = ldist * (1.0 - 1e-9) - np.minimum(shading.SHADOW_TOLERANCE, 1e-6 * ldist)
    ctx.count("shadow_rays", n)
    if not ctx.transmits.any():
        blocked = ctx.tracer.occluded(points, ldir, tmax)
        return np.where(blocked[:, None], 0.0, np.ones((n, 3)))
    mult = np.ones((n, 3))
    active = np.arange(n)
    o = points.copy()
    remaining = tmax.copy()
    for _ in range(MAX_SHADOW_CROSSINGS):
        if len(active) == 0:
            break
        h = ctx.tracer.closest(o[active], ldir[active], tmax=remaining[active], skip="no_shadow")
        hit = h.obj >= 0
        active_hit = active[hit]
        if len(active_hit) == 0:
            break
        pts = h.point[hit]
        objs = h.obj[hit]
        rd = ldir[active_hit]
        # Light that crosses an object leaves it where the raw normal points along the ray.
        leaving = np.einsum("ij,ij->i", h.normal[hit], rd) > 0
        tex = ctx.texture_of(objs, h.prim[hit] if h.prim is not None else None, leaving)
        f = np.zeros((len(active_hit), 3))
        # POV-Ray turns the normal against the shadow ray (for slope patterns)
        nrm_all = h.normal[hit]
        nrm_all = np.where((np.einsum("ij,ij->i", nrm_all, rd) > 0)[:, None], -nrm_all, nrm_all)
        prim = h.prim[hit] if h.prim is not None else None
        bary = h.bary[hit] if h.bary is not None else None
        uv = uvmap.hit_uv(ctx, objs, tex, pts, prim, bary)
        resolved = resolve_textures(ctx, tex, pts, nrm_all, uv)
        if resolved is None:
            src, leaf, share = np.arange(len(tex)), tex, np.ones(len(tex))
        else:
            src, leaf, share = resolved
        for tid in np.unique(leaf):
            if not ctx.transmits[tid]:
                continue  # opaque: the light is blocked
            sel_e = np.nonzero(leaf == tid)[0]
            sel = src[sel_e]
            t = np.ones((len(sel), 3))
            caustics = np.array([ctx.interiors[int(o)].caustics for o in objs[sel]])
            nrm = nrm_all[sel]  # for faked caustics and slope patterns
            uv_sel = None if uv is None else uv[sel]
            for layer in ctx.textures[tid]:
                at = uv_sel if layer.uv_mapping and uv_sel is not None else pts[sel]
                colour = patterns.evaluate(layer.pigment, at, ctx.gamma, nrm, uv=uv_sel)
                t *= shading.rgb_transmit(colour)
                if (caustics != 0).any():
                    ln = nrm
                    if layer.normal is not None:
                        ln = patterns.perturb_normal(
                            layer.normal, at, nrm, layer.no_bump_scale, uv=uv_sel
                        )
                    cdot = np.abs(np.einsum("ij,ij->i", ln, rd[sel]))
                    # POV-Ray stores `caustics c` as the exponent 45 c.
                    k = np.where(
                        caustics != 0, 1.0 + np.power(cdot, CAUSTICS_SCALE * caustics), 1.0
                    )
                    t *= k[:, None]
            np.add.at(f, sel, share[sel_e, None] * t)
        # Light that crossed an object's inside fades with the distance it travelled there.
        f *= interior_fade(ctx, objs, h.t[hit], leaving)
        mult[active_hit] *= f
        o[active_hit] = pts
        remaining[active_hit] -= h.t[hit]
        keep = np.abs(mult[active_hit]).max(axis=1) > shading.EPSILON
        active = active_hit[keep]
    else:
        mult[active] = 0.0
    return mult


def interior_fade(
    ctx: Context, obj: np.ndarray, depth: np.ndarray, inside: np.ndarray, view: bool = False
):
    """(N,3) POV-Ray's interior attenuation of light that travelled `depth` inside the
    object (only where `inside`): fade_colour + (1 - fade_colour) / (1 + (d/fade_distance)
    ^ fade_power), or exp(-(1 - fade_colour) d / fade_distance) for fade_power >= 1000.
    A ray seen through the surface (`view`) is faded whatever fade_power is (0 halves it,
    as POV-Ray's trace.cpp has it); a shadow ray only for a positive power."""
    out = np.ones((len(obj), 3))
    for oid in np.unique(obj[inside]):
        it = ctx.interiors[int(oid)]
        if (it.fade_power <= 0 and not view) or abs(it.fade_distance) <= shading.EPSILON:
            continue
        rows = np.nonzero(inside & (obj == oid))[0]
        fc = np.asarray(it.fade_color, dtype=np.float64)
        d = depth[rows] / it.fade_distance
        if it.fade_power >= 1000:
            out[rows] = np.exp(-(1.0 - fc) * d[:, None])
        else:
            att = 1.0 + np.power(np.abs(d), it.fade_power)
            out[rows] = fc + (1.0 - fc) / att[:, None]
    return out
