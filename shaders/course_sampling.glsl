// course_sampling.glsl: the course's adaptive supersampling (`--supersample
// course`, FLAG_COURSE_SAMPLING; docs/scene-format.md#adaptive-supersampling):
// a square starts with 4 samples at its quadrant centres; when, in any
// channel, their max - min exceeds COURSE_THRESHOLD, each quadrant is
// refined the same way, down to COURSE_LEVELS levels (8x8 finest). A
// square's value is the mean of its 4 quadrants' values in float, each
// quadrant's value its sample or, refined, its own square's value.
//
// The walk through that tree is a state (layout.h CourseSum) that takes
// one sample at a time, so that render.comp can draw one sample of every
// pixel per dispatch as it does for --spp (sampling.glsl loop_budget_ok)
// and the CPU build can loop over the same steps: the same operations in
// the same order, so both give the same bits.

// Exceeded in one channel by a square's 4 samples' max - min, the square is refined.
#define COURSE_THRESHOLD 0.2f

// CourseSum.state: bits 0-1 the next sample of the square (its quadrant),
// 2-3 the square's level, 4-5 and 6-7 the quadrant it is at levels 1 and
// 2, COURSE_DONE when the pixel's colour is in `a0`. Zero: the pixel's
// first sample is next.
#define COURSE_LEVEL_SHIFT 2u
#define COURSE_QUADRANT_SHIFT 4u // + 2 (level - 1)
#define COURSE_DONE 256u

precise vec3 min3(vec3 a, vec3 b) {
    return vec3(min_f(a.x, b.x), min_f(a.y, b.y), min_f(a.z, b.z));
}

precise vec3 max3(vec3 a, vec3 b) {
    return vec3(max_f(a.x, b.x), max_f(a.y, b.y), max_f(a.z, b.z));
}

// The state before a pixel's first sample.
CourseSum course_start() {
    CourseSum st;
    st.a0 = vec4(0.0f, 0.0f, 0.0f, 0.0f);
    st.b0 = st.a0;
    st.c0 = st.a0;
    st.a1 = st.a0;
    st.b1 = st.a0;
    st.c1 = st.a0;
    st.c2 = st.a0;
    st.state = 0u;
    st.samples = 0u;
    st.rays = 0u;
    st.pad0 = 0u;
    return st;
}

bool course_done(CourseSum st) {
    return (st.state & COURSE_DONE) != 0u;
}

// The quadrant (0 to 3: x in bit 0, y, downward, in bit 1) the square of
// state `state` is at on level `level` (1 or 2).
uint course_quadrant(uint state, uint level) {
    return (state >> (COURSE_QUADRANT_SHIFT + 2u * (level - 1u))) & 3u;
}

// Where the next sample of `st` lies, as an offset from the pixel centre
// in pixels (sample_pixel's `offset`): the centre of quadrant q of the
// current square. Exact in float: every step is a power of 2.
vec2 course_offset(CourseSum st) {
    uint level = (st.state >> COURSE_LEVEL_SHIFT) & 3u;
    uint q = st.state & 3u;
    precise float x = -0.5f;
    precise float y = -0.5f;
    precise float size = 1.0f;
    for (uint l = 1u; l <= level; l++) {
        size = size * 0.5f;
        uint ql = course_quadrant(st.state, l);
        x = x + float(ql & 1u) * size;
        y = y + float(ql >> 1u) * size;
    }
    precise float half_size = size * 0.5f;
    x = x + (float(q & 1u) + 0.5f) * half_size;
    y = y + (float(q >> 1u) + 0.5f) * half_size;
    return vec2(x, y);
}

// `st` with its next sample's colour `c` in it: the square's min, max and
// sum; once its 4 are in, refined (the first quadrant's square next) or
// its mean handed up to the squares above, as far as they are complete.
CourseSum course_add(CourseSum st, vec3 c) {
    uint level = (st.state >> COURSE_LEVEL_SHIFT) & 3u;
    uint q = st.state & 3u;
    st.samples = st.samples + 1u;
    precise vec3 lo = c;
    precise vec3 hi = c;
    precise vec3 sum = c;
    if (q > 0u) {
        if (level == 0u) {
            lo = min3(xyz(st.a0), c);
            hi = max3(xyz(st.b0), c);
            sum = xyz(st.c0) + c;
        } else if (level == 1u) {
            lo = min3(xyz(st.a1), c);
            hi = max3(xyz(st.b1), c);
            sum = xyz(st.c1) + c;
        } else {
            sum = xyz(st.c2) + c;
        }
    }
    if (level == 0u) {
        st.a0 = vec4(lo, 0.0f);
        st.b0 = vec4(hi, 0.0f);
        st.c0 = vec4(sum, 0.0f);
    } else if (level == 1u) {
        st.a1 = vec4(lo, 0.0f);
        st.b1 = vec4(hi, 0.0f);
        st.c1 = vec4(sum, 0.0f);
    } else {
        st.c2 = vec4(sum, 0.0f);
    }
    if (q < 3u) {
        st.state = st.state + 1u;
        return st;
    }
    // The square's 4 samples are in.
    precise vec3 range = hi - lo;
    bool uneven = range.x > COURSE_THRESHOLD || range.y > COURSE_THRESHOLD || range.z > COURSE_THRESHOLD;
    uint quadrants = st.state & ~((3u << COURSE_LEVEL_SHIFT) | 3u);
    if (uneven && level + 1u < uint(COURSE_LEVELS)) {
        // Refined: its slot `a` sums its quadrants' values from now on;
        // the first quadrant's square is next.
        if (level == 0u) {
            st.a0 = vec4(0.0f, 0.0f, 0.0f, 0.0f);
        } else {
            st.a1 = vec4(0.0f, 0.0f, 0.0f, 0.0f);
        }
        uint child = level + 1u;
        uint cleared = quadrants & ~(3u << (COURSE_QUADRANT_SHIFT + 2u * (child - 1u)));
        st.state = cleared | (child << COURSE_LEVEL_SHIFT);
        return st;
    }
    precise vec3 value = sum * 0.25f;
    // Up the tree: the square's value joins its parent's sum; the parent
    // goes on with its next quadrant, or, with all 4 in, its own mean goes up.
    while (level > 0u) {
        uint k = course_quadrant(st.state, level);
        uint parent = level - 1u;
        precise vec3 siblings = vec3(0.0f, 0.0f, 0.0f);
        if (parent == 0u) {
            siblings = xyz(st.a0) + value;
            st.a0 = vec4(siblings, 0.0f);
        } else {
            siblings = xyz(st.a1) + value;
            st.a1 = vec4(siblings, 0.0f);
        }
        if (k < 3u) {
            uint shift = COURSE_QUADRANT_SHIFT + 2u * (level - 1u);
            uint next = (quadrants & ~(3u << shift)) | ((k + 1u) << shift);
            st.state = next | (level << COURSE_LEVEL_SHIFT);
            return st;
        }
        value = siblings * 0.25f;
        level = parent;
    }
    st.a0 = vec4(value, 0.0f);
    st.state = COURSE_DONE;
    return st;
}

// The colour a finished pixel stores: its value, or with AOV_SAMPLES its
// count of samples on the heat scale (dark red at COURSE_MAX_SAMPLES).
precise vec3 course_color(CourseSum st) {
    if (HAS_AOVS && frame.aov == AOV_SAMPLES) {
        return heat_color(div_rn(float(st.samples), float(COURSE_MAX_SAMPLES)));
    }
    return xyz(st.a0);
}
