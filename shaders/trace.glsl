// trace.glsl: the tracing loop: one sample of a pixel, its camera ray, the
// shadow rays and the mirror path through the walk, folded into a colour
// (or an AOV's), each step a TRACE for `raycast trace`.

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
// With refraction (FLAG_REFRACTION) a level may have a second child, the
// refracted ray with weight k_t O_t (refraction.glsl): the levels form a
// tree, walked depth first without recursion. A level keeps its refracted
// ray until the path below it ends; then the levels below are folded as
// above into c = local + weight c_mirror, kept as the level's local colour,
// and the refracted ray is traced as the next level, its weight in the
// mirror's place, so that c_k = clamp((local_k + k_s O_r c_mirror) +
// k_t O_t c_refracted). Mirror and refracted rays share the bounce budget
// (frame.max_depth); without refraction the arithmetic is the chain's.
//
// The camera, mirror and refracted rays go through the walk call at the
// top of the loop, a turn each; a hit's shadow rays through a second call,
// in the light loop, one a light that needs one, any_hit a constant there.
// Lavapipe runs every branch of the loop's body on every turn, masked:
// with one call for every ray, a shadow ray's turn paid for the shading
// of a hit, the light's term and the mirror's set-up too, about 2.6 walk
// passes (BENCHMARKS.md, "A kernel for lanes"); a second copy of the walk
// costs its build instead (lavapipe builds a kernel again at each
// dispatch), and took 4 to 18% off the dispatch at recursive-spheres
// depths 4 to 10. With another AOV than colour, the first hit only
// (aov_color).
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
    // Refraction (refraction.glsl): a level with a refracted ray still to
    // trace has its bit in `refract_pending`, the ray and its weight k_t O_t
    // kept here until its mirror path is folded into local_at.
    bool refraction = HAS_REFRACTION && (frame.flags & FLAG_REFRACTION) != 0u;
    vec3 refract_origin_at[MAX_DEPTH + 1];
    vec3 refract_direction_at[MAX_DEPTH + 1];
    vec3 refract_weight_at[MAX_DEPTH + 1];
    uint refract_pending = 0u;
    bool refracted = false; // the level's ray is a refracted one (TRACE_REFRACT)
    uint levels = 0u;
    uint level = 0u;
    // The ray the turn traces: the level's (camera, mirror or refracted).
    Ray next = ray;
    Surface surface;
    precise vec3 color = vec3(0.0f, 0.0f, 0.0f);
    uint li = 0u;
    // An area light's point lk of ln (sample_dims zw rotates them); other lights have one.
    uint lk = 0u;
    uint ln = 1u;
    uint passes = 0u; // every walk's, for AOV_COST_ALL
    // AOV_LANES: the shadow rays' passes, and the bytes fetched.
    uint shadow_passes = 0u;
    uvec2 fetched = uvec2(0u, 0u);
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
        SceneHit h = walk(next, T_FAR, false);
        s.rays = s.rays + 1u;
        TRACE(level == 0u ? TRACE_CAMERA : (refracted ? TRACE_REFRACT : TRACE_MIRROR), level, li,
              h.id, h.passes, vec4(next.origin, 0.0f), vec4(next.direction, T_FAR), vec4(h.normal, h.t), vec4(0.0f));
        if (HAS_AOVS) {
            passes = passes + h.passes;
            fetched = fetched + uvec2(h.node_bytes, h.prim_bytes);
        }
        bool path_ends = false;
        if (!first_kept) {
            s.hit = h;
            first_kept = true;
        }
        // The AOVs other than colour: the first hit's, black on a miss
        // but for the cost, which a miss has too. AOV_COST_ALL goes on
        // as colour does, its picture made at the end.
        if (HAS_AOVS && frame.aov != AOV_COLOR && frame.aov != AOV_COST_ALL && frame.aov != AOV_LANES && frame.aov != AOV_SAMPLES &&
            (h.id != NO_HIT || frame.aov == AOV_COST)) {
            s.color = aov_color(frame.aov, ray, h);
            break;
        }
        if (h.id == NO_HIT) {
            if (refract_pending == 0u) {
                break;
            }
            path_ends = true;
        } else {
            surface = surface_at(ray, h);
            li = 0u;
            lk = 0u;
            if (refraction && leaves_medium(surface)) {
                surface = passing_out(surface);
                li = frame.light_count;
            }
            color = surface.base;
            TRACE(TRACE_SURFACE, level, 0u, h.id, 0u, vec4(surface.p, 1.0f), vec4(0.0f), vec4(surface.base, 0.0f),
                  vec4(surface.diffuse, 0.0f));
        }
        // The lights in turn: each adds its term, one that needs a shadow
        // ray only when the ray finds nothing in the way.
        while (!path_ends && li < frame.light_count) {
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
                Ray toward;
                toward.origin = shadow_origin;
                toward.direction = to_light;
                precise float t_max = T_FAR;
                if (HAS_POSITIONED_LIGHTS && l.kind != LIGHT_DIRECTIONAL) {
                    precise vec3 rest = at - shadow_origin;
                    t_max = sqrt_rn(dot3(rest, rest));
                }
                SceneHit sh = walk(toward, t_max, true);
                s.rays = s.rays + 1u;
                TRACE(TRACE_SHADOW, level, li, sh.id, sh.passes, vec4(toward.origin, 0.0f), vec4(toward.direction, t_max),
                      vec4(sh.normal, sh.t), vec4(0.0f));
                if (HAS_AOVS) {
                    passes = passes + sh.passes;
                    fetched = fetched + uvec2(sh.node_bytes, sh.prim_bytes);
                    shadow_passes = shadow_passes + sh.passes;
                }
                if (sh.id == NO_HIT) {
                    color = color + lit;
                }
                uvec2 after = next_light_point(li, lk, ln);
                li = after.x;
                lk = after.y;
                continue;
            }
            color = color + lit;
            uvec2 after = next_light_point(li, lk, ln);
            li = after.x;
            lk = after.y;
        }
        if (!path_ends) {
            local_at[level] = color;
            levels = level + 1u;
            precise vec3 w = surface.mirror;
            weight_at[level] = w;
            TRACE(TRACE_LEVEL, level, 0u, 0u, 0u, vec4(surface.transmit, 0.0f), vec4(0.0f), vec4(color, 0.0f), vec4(w, 0.0f));
            precise vec3 d = -surface.v;
            if (refraction && level != depth && !negligible(surface.transmit)) {
                // The refracted ray, from 0.001 (ray_offset) along it, traced
                // once the mirror path below this level is folded.
                precise vec3 bent = refracted_direction(d, surface.n, surface.ior);
                precise vec3 bent_origin = surface.p + ray_offset(surface.p, ray.origin) * bent;
                refract_origin_at[level] = bent_origin;
                refract_direction_at[level] = bent;
                refract_weight_at[level] = surface.transmit;
                refract_pending = refract_pending | (1u << level);
            }
            if (!reflections || level == depth || negligible(w)) {
                if (refract_pending == 0u) {
                    break;
                }
            } else {
                // Mirror direction of the unit ray direction about N, from 0.001
                // (ray_offset) along it.
                precise vec3 mirror = d - (2.0f * dot3(surface.n, d)) * surface.n;
                precise vec3 mirror_origin = surface.p + ray_offset(surface.p, ray.origin) * mirror;
                ray.origin = mirror_origin;
                ray.direction = mirror;
                next = ray;
                level = level + 1u;
                refracted = false;
                continue;
            }
        }
        // The path ends with a refracted ray still to trace: fold the levels
        // below the deepest such level k as the end does, add the result to
        // local_at[k] with its mirror weight, and trace k's refracted ray as
        // level k + 1, its weight taking the mirror's place in the fold.
        uint k = levels - 1u;
        bool folded = false;
        precise vec3 below = vec3(0.0f, 0.0f, 0.0f);
        while ((refract_pending & (1u << k)) == 0u) {
            if (folded) {
                below = clamp3(local_at[k] + weight_at[k] * below);
            } else {
                below = clamp3(local_at[k]);
            }
            folded = true;
            k = k - 1u;
        }
        if (folded) {
            precise vec3 with_mirror = local_at[k] + weight_at[k] * below;
            local_at[k] = with_mirror;
        }
        refract_pending = refract_pending & ~(1u << k);
        weight_at[k] = refract_weight_at[k];
        ray.origin = refract_origin_at[k];
        ray.direction = refract_direction_at[k];
        next = ray;
        level = k + 1u;
        levels = level;
        refracted = true;
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
    if (HAS_AOVS && (frame.aov == AOV_COST_ALL || frame.aov == AOV_LANES)) {
        // Every ray's walk, on the cost's scale; PixelOut.normal's w gets the
        // same sum (pixel_out writes the hit's passes).
        s.color = heat_color(div_rn(float(passes), frame.aov_scale.z));
        if (frame.aov == AOV_LANES) {
            // pixel_out writes the hit's normal, t and id: a hit, whatever
            // the camera ray met. The camera ray's passes are its hit's
            // (s.hit, kept above); the mirror and refracted rays', the rest.
            uint camera_passes = s.hit.passes;
            s.hit.normal = vec3(float(camera_passes), float(shadow_passes), float(passes - camera_passes - shadow_passes));
            s.hit.t = float(fetched.x);
            s.hit.id = fetched.y;
        }
        s.hit.passes = passes;
    }
    TRACE(TRACE_PIXEL, levels, 0u, pack_rgba8(s.color), passes, vec4(0.0f), vec4(0.0f), vec4(s.color, 0.0f), vec4(0.0f));
    return s;
}
