// textures.glsl: texture mapping (docs/scene-format.md#texture-coordinates:
// v = 0 at the top row): the texel at a hit's (u, v), nearest or bilinear.
// Each shape's (u, v) is its own file's (shapes.glsl surface_uv).

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
