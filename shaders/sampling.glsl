// sampling.glsl: everything one pixel computes from its samples: the
// supersampling pattern, their average, what the pixel stores, its place
// in a kernel's tile and whether the device ran every loop to its end.

// The radical inverse of s in base 2 (van der Corput): its bits mirrored
// about the binary point. Exact in float for s < 2^24.
precise float radical_inverse(uint s) {
    precise float r = 0.0f;
    precise float f = 0.5f;
    for (uint k = s; k != 0u; k = k >> 1u) {
        if ((k & 1u) != 0u) {
            r = r + f;
        }
        f = f * 0.5f;
    }
    return r;
}

// Supersampling pattern: sample s of n is at ((s + 1/2) / n, frac(vdc(s) +
// 1/(2n))) in the pixel (a Hammersley set shifted by half a stratum), as an
// offset from the pixel centre. n = 1 gives the centre; n = 4 gives
// (+-1/8 or +-3/8) in both axes, one sample per row and column stratum.
vec2 sample_offset(uint s, uint n) {
    precise float x = div_rn(float(s) + 0.5f, float(n)) - 0.5f;
    precise float y = radical_inverse(s) + div_rn(0.5f, float(n));
    if (y >= 1.0f) {
        y = y - 1.0f;
    }
    precise float y_offset = y - 0.5f;
    return vec2(x, y_offset);
}

// What a pixel stores: the hit's t, id and normal (0, NO_HIT and 0 on a
// miss), `color` quantised and the number of rays traced for it.
PixelOut pixel_out(SceneHit hit, vec3 color, uint rays) {
    PixelOut o;
    o.rays = rays;
    o.rgba = pack_rgba8(color);
    // w: the walk's passes, hit or miss, in an AOV other than colour (a
    // colour kernel leaves their count out; the CPU build counts them anyway).
    precise float passes = (frame.aov != AOV_COLOR) ? float(hit.passes) : 0.0f;
    if (hit.id == NO_HIT) {
        o.normal = vec4(0.0f, 0.0f, 0.0f, passes);
        o.t = 0.0f;
        o.id = NO_HIT;
    } else {
        o.normal = vec4(hit.normal, passes);
        o.t = hit.t;
        o.id = hit.id;
    }
    return o;
}

// The pixel of invocation k (gl_LocalInvocationIndex) of workgroup `group`
// in the kernels' 8x8 tiles (WORKGROUP_SIZE; the bit layout assumes 8).
// Lavapipe runs invocations 8n .. 8n+7 as one 8-wide vector, so these are
// a 4x2 block of pixels rather than a row of 8: rays closer together take
// more alike paths through the hierarchy, and the vector's loops end sooner
// (9% on recursiveSpheres4). Every pixel of the tile is still one
// invocation's; GPUs with 32-wide subgroups still get 8x4 blocks.
uvec2 tile_pixel(uvec2 group, uint k) {
    uint x = (k & 3u) | (((k >> 3u) & 1u) << 2u);
    uint y = ((k >> 2u) & 1u) | ((k >> 4u) << 1u);
    return uvec2(group.x * uint(WORKGROUP_SIZE) + x, group.y * uint(WORKGROUP_SIZE) + y);
}

// Whether the device ran every loop of this invocation to its end.
// Mesa's llvmpipe (lavapipe) gives each shader invocation 65535 loop
// iterations in all, counted over every loop it runs
// (LP_MAX_TGSI_LOOP_ITERATIONS), then ends each loop after its first pass
// without a word: a pixel that needs more comes out wrong. Run last, this
// loop of frame.loop_canary passes (LOOP_CANARY, 2, unknown to the
// compiler, so it is not unrolled) finds out: cut short, it runs once. The
// CPU build always runs it to the end; a frame with loop_canary 0 (the
// harness's zeroed default) asks nothing.
bool loop_budget_ok() {
    uint passes = 0u;
    for (uint k = 0u; k < frame.loop_canary; k++) {
        passes = passes + 1u;
    }
    return passes == frame.loop_canary;
}

// The colour a pixel stores: its n samples' colour sum over n; with
// AOV_SAMPLES, n on the heat scale (course_sampling.glsl course_color).
precise vec3 sample_average(vec3 sum, uint n) {
    if (HAS_AOVS && frame.aov == AOV_SAMPLES) {
        return heat_color(div_rn(float(n), float(COURSE_MAX_SAMPLES)));
    }
    precise vec3 average = div_rn(sum, float(n));
    return average;
}

// render_pixel under FLAG_COURSE_SAMPLING: the course's adaptive scheme
// (course_sampling.glsl), its samples in the order course_add asks for
// them, sample k's lens point and area-light rotation sample_dims(k, 1) (as
// the preview's: the count is not known ahead); t, id and normal from the first.
PixelOut render_course_pixel(uint j, uint i) {
    CourseSum st = course_start();
    PixelSample first = sample_pixel(j, i, course_offset(st), sample_dims(st.samples, 1u));
    st = course_add(st, first.color);
    uint rays = first.rays;
    while (!course_done(st)) {
        PixelSample next = sample_pixel(j, i, course_offset(st), sample_dims(st.samples, 1u));
        st = course_add(st, next.color);
        rays = rays + next.rays;
    }
    PixelOut o = pixel_out(first.hit, course_color(st), rays);
    if (!loop_budget_ok()) {
        o.rays = o.rays | RAYS_CUT_SHORT;
    }
    return o;
}

// Everything one pixel computes (the CPU build's and the harness's way;
// render.comp computes the same one sample per dispatch): frame.spp samples in the fixed pattern,
// their colours summed in sample order and divided by the count; t, id and
// normal from the first sample (the pixel centre when spp = 1); the rays of
// every sample.
PixelOut render_pixel(uint j, uint i) {
    if (HAS_COURSE_SAMPLING && (frame.flags & FLAG_COURSE_SAMPLING) != 0u) {
        return render_course_pixel(j, i);
    }
    uint n = max(frame.spp, 1u);
    PixelSample first = sample_pixel(j, i, sample_offset(0u, n), sample_dims(0u, n));
    precise vec3 sum = first.color;
    uint rays = first.rays;
    for (uint s = 1u; s < n; s++) {
        PixelSample next = sample_pixel(j, i, sample_offset(s, n), sample_dims(s, n));
        sum = sum + next.color;
        rays = rays + next.rays;
    }
    PixelOut o = pixel_out(first.hit, sample_average(sum, n), rays);
    if (!loop_budget_ok()) {
        o.rays = o.rays | RAYS_CUT_SHORT;
    }
    return o;
}
