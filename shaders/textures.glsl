// textures.glsl: texture mapping (docs/scene-format.md#texture-coordinates: UV per shape, v = 0
// at the top row): a hit's (u, v) and the texel, nearest or bilinear.

// u in [0, 1) around the y axis: (-atan2(z, x) / 2 pi) mod 1.
precise float around_y(vec3 p) {
    precise float u = -atan2_portable(p.z, p.x) * 0.159154937f;
    if (u < 0.0f) {
        u = u + 1.0f;
    }
    return u;
}

// (u, v) of an object-space hit point p with the shape test's normal n.
precise vec2 surface_uv(uint shape, vec3 p, vec3 n) {
    if (HAS_MESHES && shape == SHAPE_MESH) {
        return vec2(p.x, p.y); // the mesh's own coordinates (traversal.glsl, primitive_hit)
    }
    if (HAS_CUBES && shape == SHAPE_CUBE) {
        if (n.x > 0.0f) {
            return vec2(0.5f - p.z, 0.5f - p.y);
        }
        if (n.x < 0.0f) {
            return vec2(p.z + 0.5f, 0.5f - p.y);
        }
        if (n.y > 0.0f) {
            return vec2(p.x + 0.5f, p.z + 0.5f);
        }
        if (n.y < 0.0f) {
            return vec2(p.x + 0.5f, 0.5f - p.z);
        }
        if (n.z > 0.0f) {
            return vec2(p.x + 0.5f, 0.5f - p.y);
        }
        return vec2(0.5f - p.x, 0.5f - p.y);
    }
    if (HAS_SPHERES && shape == SHAPE_SPHERE) {
        return vec2(around_y(p), 0.5f - asin_portable(2.0f * p.y) * 0.318309873f);
    }
    if (HAS_TORI && shape == SHAPE_TORUS) {
        // u around y; v around the tube, from its inner equator (v = 0)
        // over the top (1/4) and the outer equator (1/2) to the bottom (3/4).
        precise float rho = sqrt_rn(p.x * p.x + p.z * p.z);
        return vec2(around_y(p), 0.5f - atan2_portable(p.y, rho - 0.375f) * 0.159154937f);
    }
    // Cylinder and cone: caps have the normal (0, +-1, 0), bodies n.y >= 0
    // for the cone and 0 for the cylinder.
    if (n.y < 0.0f && n.x == 0.0f && n.z == 0.0f) {
        return vec2(p.x + 0.5f, 0.5f - p.z);
    }
    if (n.y > 0.0f && n.x == 0.0f && n.z == 0.0f && shape == SHAPE_CYLINDER) {
        return vec2(p.x + 0.5f, p.z + 0.5f);
    }
    return vec2(around_y(p), 0.5f - p.y);
}

// Texel (column, row) of texture tex as RGB in [0, 1].
precise vec3 texel_rgb(Texture tex, uint column, uint row) {
    uint v = texels[tex.offset + row * tex.width + column].rgba;
    precise vec3 c = div_rn(vec3(float(v & 255u), float((v >> 8u) & 255u), float((v >> 16u) & 255u)), 255.0f);
    return c;
}

// Wraps a texel coordinate x into [0, size): floor(x) mod size, the
// modulus of arithmetic (never negative), so a negative repeat count tiles
// the texture as a positive one does, the other way (the spec's rule;
// until 2026-11-27 x was held at 0 and such a texture was one texel).
// Beyond 1e9 texels either way x is held there (a repeat count that large
// has no picture to show).
uint wrap(float x, uint size) {
    precise float f = floor(max_f(min_f(x, 1.0e9f), -1.0e9f));
    if (f < 0.0f) {
        uint r = uint(-f) % size;
        return (r == 0u) ? 0u : size - r;
    }
    return uint(f) % size;
}

// The bilinear filter of sample_texture at texel coordinates (x, y),
// between the texels around (x - shift, y - shift): shift 1/2 centres
// texel k at k + 1/2 (FILTER_BILINEAR); shift 0 at k (FILTER_COURSE, the
// course's filter: T[floor x] and T[floor x + 1] by the fraction of x).
precise vec3 bilinear(Texture tex, float x, float y, float shift) {
    precise float bx = x - shift;
    precise float by = y - shift;
    precise float fx = bx - floor(bx);
    precise float fy = by - floor(by);
    uint c0 = wrap(bx, tex.width);
    uint c1 = (c0 + 1u) % tex.width;
    uint r0 = wrap(by, tex.height);
    uint r1 = (r0 + 1u) % tex.height;
    precise vec3 top = texel_rgb(tex, c0, r0) * (1.0f - fx) + texel_rgb(tex, c1, r0) * fx;
    precise vec3 bottom = texel_rgb(tex, c0, r1) * (1.0f - fx) + texel_rgb(tex, c1, r1) * fx;
    precise vec3 c = top * (1.0f - fy) + bottom * fy;
    return c;
}

// T(u, v): u, v clamped to [0, 1], scaled by the repeat counts. Nearest:
// column floor(u r_u W) mod W, row floor(v r_v H) mod H. Bilinear: the four
// texels around (u r_u W - 1/2, v r_v H - 1/2), wrapped, weighted in a fixed
// order; the course's filter: around (u r_u W, v r_v H).
precise vec3 sample_texture(Material m, vec2 uv) {
    Texture tex = textures[uint(m.texture)];
    precise float x = (clamp01(uv.x) * m.texture_repeat.x) * float(tex.width);
    precise float y = (clamp01(uv.y) * m.texture_repeat.y) * float(tex.height);
    if (HAS_BILINEAR && frame.texture_filter != FILTER_NEAREST) {
        return bilinear(tex, x, y, (frame.texture_filter == FILTER_COURSE) ? 0.0f : 0.5f);
    }
    return texel_rgb(tex, wrap(x, tex.width), wrap(y, tex.height));
}
