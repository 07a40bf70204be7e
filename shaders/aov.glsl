// aov.glsl: what a pixel stores as colour (pack_rgba8), and the AOVs other
// than colour (layout.h AOV_*): what the first hit shows.

// pack_rgba8 under FLAG_EXPLAIN_ROUND (to nearest) and FLAG_EXPLAIN_NO_CLAMP
// (each channel's value taken modulo 256, as a cast to an 8-bit type wraps).
uint explained_rgba8(vec3 c) {
    bool round_it = (frame.flags & FLAG_EXPLAIN_ROUND) != 0u;
    uint packed = 255u << 24u;
    for (int i = 0; i < 3; i++) {
        float v = 255.0f * c[i] + (round_it ? 0.5f : 0.0f);
        uint u = uint(max(floor(v), 0.0f));
        packed = packed | ((u & 255u) << (8u * uint(i)));
    }
    return packed;
}

// floor(255 c) per channel (truncation, as the official renders), alpha 255.
uint pack_rgba8(vec3 c) {
    if (HAS_EXPLAIN && (frame.flags & (FLAG_EXPLAIN_ROUND | FLAG_EXPLAIN_NO_CLAMP)) != 0u) {
        return explained_rgba8(c);
    }
    precise float r = floor(255.0f * c.x);
    precise float g = floor(255.0f * c.y);
    precise float b = floor(255.0f * c.z);
    return (uint(r) | (uint(g) << 8u)) | ((uint(b) << 16u) | (255u << 24u));
}

// Grey by distance: white at `near`, black at `far` and beyond.
precise float depth_grey(float dist, float near, float far) {
    precise float span = max_f(far - near, 1e-6f);
    return 1.0f - clamp01(div_rn(dist - near, span));
}

// A colour per primitive id: its bits scrambled into three bytes, kept
// away from black (which is a miss).
precise vec3 id_color(uint id) {
    uint h = (id + 1u) * 2654435761u;
    h = h ^ (h >> 15u);
    precise vec3 bytes = vec3(float(h & 255u), float((h >> 8u) & 255u), float((h >> 16u) & 255u));
    precise vec3 c = div_rn(bytes, 255.0f) * 0.75f;
    return c + 0.25f;
}

// x in [0, 1] (clamped) on a heat scale: dark blue, blue, cyan, green,
// yellow, red, dark red ("jet").
precise vec3 heat_color(float x) {
    precise float s = 4.0f * clamp01(x);
    return vec3(clamp01(1.5f - abs(s - 3.0f)), clamp01(1.5f - abs(s - 2.0f)), clamp01(1.5f - abs(s - 1.0f)));
}

// What AOV `aov` (not AOV_COLOR) shows of hit h (a miss only for
// AOV_COST) of camera ray r.
precise vec3 aov_color(uint aov, Ray r, SceneHit h) {
    if (aov == AOV_NORMAL) {
        precise vec3 c = (h.normal + 1.0f) * 0.5f;
        return clamp3(c);
    }
    if (aov == AOV_DEPTH) {
        precise float dist = h.t * sqrt_rn(dot3(r.direction, r.direction));
        precise float g = depth_grey(dist, frame.aov_scale.x, frame.aov_scale.y);
        return vec3(g, g, g);
    }
    if (aov == AOV_COST) {
        return heat_color(div_rn(float(h.passes), frame.aov_scale.z));
    }
    return id_color(h.id);
}
