// trace.glsl: the tracing loop: one sample of a pixel, its camera ray, the
// shadow rays and the mirror path through the one walk, folded into a
// colour (or an AOV's), each step a TRACE for `raycast trace`.

// One sample of a pixel: the primary ray's nearest hit and the colour it
// gives (the shaded colour with reflections, or an AOV's), each
// channel in [0, 1], and every ray traced for it, the camera ray included.
struct PixelSample {
    SceneHit hit;
    vec3 color;
    uint rays;
};

// The camera ray through (j, i) at `offset` and color(ray, depth) of the
// lighting model without recursion: trace the ray and its mirror path,
// keeping each level's local colour and mirror weight k_s O_r, then fold
// from the deepest level up, clamping at every level:
//   c_k = clamp(local_k + weight_k c_(k+1)).
// A level's local colour is Phong: ambient + emissive, then for each light
// in order that would add something (a light facing away or outside its
// spot adds +-0, and a subnormal term (`negligible`) less than any step
// of a stored colour: neither is added, so neither needs a shadow ray)
// and that no shadow ray finds blocked, its diffuse (textured: blended
// with the texel) and specular term. Not clamped until the fold.
//
// Every ray, camera, shadow or mirror, goes through the one walk call at
// the top of the loop: each pass traces the pixel's next ray, then goes on
// from its answer to the next ray, the next light's shadow ray or the
// level's mirror ray. Lavapipe turns every copy of the walk into code on
// every pipeline build (a copy for shadow rays took a third of
// recursiveSpheres4's), and runs a vector's lanes through a copy together:
// with one, a lane's mirror ray goes beside a neighbour's shadow ray, not
// after it. (Keeping the lanes in step, one pass per light whether its
// shadow ray is needed or not, was 4-8% slower.) With another AOV than
// colour, the first hit only (aov_color).
//
// Each step is also a TRACE (layout.h TraceStep): the CPU build records
// them for `raycast trace`; in a kernel TRACE is nothing.
// The light point after point lk of light li's ln: (light, point).
uvec2 next_light_point(uint li, uint lk, uint ln) {
    if (lk + 1u < ln) {
        return uvec2(li, lk + 1u);
    }
    return uvec2(li + 1u, 0u);
}

#ifndef TRACE
#define TRACE(kind, level, light, id, passes, origin, direction, value, extra)
#endif
PixelSample sample_pixel(uint j, uint i, vec2 offset, vec4 dims) {
    Ray ray = camera_ray(j, i, offset); // the level's ray: the camera's, then the mirror's
    if (HAS_DOF && (frame.flags & FLAG_DOF) != 0u) {
        ray = lens_ray(ray, vec2(dims.x, dims.y));
    }
    PixelSample s;
    s.color = vec3(0.0f, 0.0f, 0.0f);
    s.rays = 0u;
    vec3 local_at[MAX_DEPTH + 1];
    vec3 weight_at[MAX_DEPTH + 1];
    uint depth = min(frame.max_depth, uint(MAX_DEPTH));
    bool reflections = HAS_REFLECTIONS && (frame.flags & FLAG_REFLECTIONS) != 0u;
    bool shadows = HAS_SHADOWS && (frame.flags & FLAG_SHADOWS) != 0u;
    uint levels = 0u;
    uint level = 0u;
    // The ray traced next: the level's ray, or (shadow) the shadow ray of
    // light li, whose term `pending` is added unless something blocks it.
    Ray next = ray;
    float next_t_max = T_FAR;
    bool shadow = false;
    Surface surface;
    precise vec3 color = vec3(0.0f, 0.0f, 0.0f);
    precise vec3 pending = vec3(0.0f, 0.0f, 0.0f);
    uint li = 0u;
    // An area light's point lk of ln (sample_dims zw rotates them); other lights have one.
    uint lk = 0u;
    uint ln = 1u;
    uint passes = 0u; // every walk's, for AOV_COST_ALL
    // Whether s.hit holds the camera ray's hit. Not `level == 0u`: with
    // that test Mesa 22.3's lavapipe stored 0 as the normal of a lane that
    // left the loop while a neighbour went on tracing mirror rays, its t,
    // id and colour right. By every sign it ran the assignment again in the
    // neighbour's later pass, with that pass's walk of the lane's camera ray
    // (the same t and id), whose normal, computed under a branch the lane
    // was masked out of, stayed 0; one invocation alone (check --pixel) was
    // right. Kept by a flag, it is right (found by fuzzing `check`;
    // mirror_depth.xml at 160x120 --no-shadows: 636 pixels; Mesa 25.0 did
    // not). tests/check.rs, "160x120 --no-shadows", over
    // tests/scenes/stress/mirrors_beside_matte.xml.
    bool first_kept = false;
    while (true) {
        SceneHit h = walk(next, next_t_max, shadow);
        s.rays = s.rays + 1u;
        TRACE(shadow ? TRACE_SHADOW : (level == 0u ? TRACE_CAMERA : TRACE_MIRROR), level, li, h.id, h.passes,
              vec4(next.origin, 0.0f), vec4(next.direction, next_t_max), vec4(h.normal, h.t), vec4(0.0f));
        if (HAS_AOVS) {
            passes = passes + h.passes;
        }
        if (shadow) {
            if (h.id == NO_HIT) {
                color = color + pending;
            }
            uvec2 after = next_light_point(li, lk, ln);
            li = after.x;
            lk = after.y;
        } else {
            if (!first_kept) {
                s.hit = h;
                first_kept = true;
            }
            // The AOVs other than colour: the first hit's, black on a miss
            // but for the cost, which a miss has too. AOV_COST_ALL goes on
            // as colour does, its picture made at the end.
            if (HAS_AOVS && frame.aov != AOV_COLOR && frame.aov != AOV_COST_ALL && frame.aov != AOV_SAMPLES &&
                (h.id != NO_HIT || frame.aov == AOV_COST)) {
                s.color = aov_color(frame.aov, ray, h);
                break;
            }
            if (h.id == NO_HIT) {
                break;
            }
            surface = surface_at(ray, h);
            color = surface.base;
            TRACE(TRACE_SURFACE, level, 0u, h.id, 0u, vec4(surface.p, 1.0f), vec4(0.0f), vec4(surface.base, 0.0f),
                  vec4(surface.diffuse, 0.0f));
            li = 0u;
            lk = 0u;
        }
        // The lights from li on: each adds its term, up to the first that
        // needs a shadow ray.
        shadow = false;
        while (li < frame.light_count) {
            Light l = light_at(li);
            precise vec3 to_light = xyz(l.direction_to_light);
            precise float dist = 0.0f;
            // Where the light is: its position, or an area light's point lk.
            precise vec3 at = xyz(l.position);
            ln = 1u;
            if (HAS_AREA_LIGHTS && l.kind == LIGHT_AREA) {
                ln = frame.light_samples;
                at = area_light_point(l, lk, ln, vec2(dims.z, dims.w));
            }
            if (HAS_POSITIONED_LIGHTS && l.kind != LIGHT_DIRECTIONAL) {
                precise vec3 d = at - surface.p;
                dist = sqrt_rn(dot3(d, d));
                to_light = div_rn(d, dist);
            }
            precise vec3 lit = light_term(surface, l, to_light, dist);
            if (negligible(lit)) {
                TRACE(TRACE_LIGHT, level, li, TRACE_LIGHT_NOTHING, 0u, vec4(at, float(lk)), vec4(to_light, dist), vec4(lit, 0.0f), vec4(0.0f));
                uvec2 after = next_light_point(li, lk, ln);
                li = after.x;
                lk = after.y;
                continue;
            }
            TRACE(TRACE_LIGHT, level, li, shadows ? TRACE_LIGHT_SHADOW : TRACE_LIGHT_ADDED, 0u, vec4(at, float(lk)),
                  vec4(to_light, dist), vec4(lit, 0.0f), vec4(0.0f));
            if (shadows) {
                // From 0.001 (ray_offset) along L toward the light: blocked
                // by anything closer than the light (anything at all for a
                // directional light).
                precise vec3 shadow_origin = surface.p + ray_offset(surface.p, ray.origin) * to_light;
                next.origin = shadow_origin;
                next.direction = to_light;
                precise float t_max = T_FAR;
                if (HAS_POSITIONED_LIGHTS && l.kind != LIGHT_DIRECTIONAL) {
                    precise vec3 rest = at - shadow_origin;
                    t_max = sqrt_rn(dot3(rest, rest));
                }
                next_t_max = t_max;
                pending = lit;
                shadow = true;
                break;
            }
            color = color + lit;
            uvec2 after = next_light_point(li, lk, ln);
            li = after.x;
            lk = after.y;
        }
        if (shadow) {
            continue;
        }
        local_at[level] = color;
        levels = level + 1u;
        precise vec3 w = surface.mirror;
        weight_at[level] = w;
        TRACE(TRACE_LEVEL, level, 0u, 0u, 0u, vec4(0.0f), vec4(0.0f), vec4(color, 0.0f), vec4(w, 0.0f));
        if (!reflections || level == depth || negligible(w)) {
            break;
        }
        // Mirror direction of the unit ray direction about N, from 0.001
        // (ray_offset) along it.
        precise vec3 d = -surface.v;
        precise vec3 mirror = d - (2.0f * dot3(surface.n, d)) * surface.n;
        precise vec3 mirror_origin = surface.p + ray_offset(surface.p, ray.origin) * mirror;
        ray.origin = mirror_origin;
        ray.direction = mirror;
        next = ray;
        next_t_max = T_FAR;
        level = level + 1u;
    }
    if (levels > 0u) {
        precise vec3 c = vec3(0.0f, 0.0f, 0.0f);
        for (uint k = levels; k > 0u; k--) {
            if (k == levels) {
                c = clamp3(local_at[k - 1u]);
            } else {
                c = clamp3(local_at[k - 1u] + weight_at[k - 1u] * c);
            }
        }
        s.color = c;
    }
    if (HAS_AOVS && frame.aov == AOV_COST_ALL) {
        // Every ray's walk, on the cost's scale; PixelOut.normal's w gets the
        // same sum (pixel_out writes the hit's passes).
        s.color = heat_color(div_rn(float(passes), frame.aov_scale.z));
        s.hit.passes = passes;
    }
    TRACE(TRACE_PIXEL, levels, 0u, pack_rgba8(s.color), passes, vec4(0.0f), vec4(0.0f), vec4(s.color, 0.0f), vec4(0.0f));
    return s;
}
