// lighting.glsl: local lighting (docs/scene-format.md#lighting-model: "Lighting model of
// the official renders"): a light's intensity (attenuation, spot falloff),
// the surface a hit shows, one light's Phong term, and what is too small
// to trace a ray for.

// light_intensity of a point or spot light of colour `color`.
precise vec3 positioned_light_intensity(Light l, vec3 color, vec3 to_light, float dist) {
    precise float falloff = (l.attenuation.x + l.attenuation.y * dist) + l.attenuation.z * (dist * dist);
    precise float att = min_f(1.0f, div_rn(1.0f, falloff));
    if (HAS_EXPLAIN && (frame.flags & FLAG_EXPLAIN_UNCAPPED_ATTENUATION) != 0u) {
        att = div_rn(1.0f, falloff); // `raycast explain`'s variant: not capped at 1
    }
    precise vec3 intensity = color * att;
    if (HAS_SPOT_LIGHTS && l.kind == LIGHT_SPOT) {
        // Angle between the spot axis and (p - position) = -to_light.
        precise float cos_theta = -dot3(xyz(l.spot_axis), to_light);
        precise float theta = acos_portable(cos_theta) * DEGREES_PER_RADIAN;
        precise float inner = l.angle_deg - l.penumbra_deg;
        if (theta > l.angle_deg) {
            return vec3(0.0f, 0.0f, 0.0f);
        }
        if (theta > inner) {
            precise float x = div_rn(theta - inner, l.penumbra_deg);
            precise float smooth_step = (3.0f * (x * x)) - 2.0f * ((x * x) * x);
            intensity = intensity * (1.0f - smooth_step);
        }
    }
    return intensity;
}

// The intensity of light `l` arriving along unit `to_light` (pointing at the
// light) from `dist` away, before shadows: colour, distance attenuation and
// spot falloff.
precise vec3 light_intensity(Light l, vec3 to_light, float dist) {
    precise vec3 intensity = xyz(l.color);
    if (HAS_AREA_LIGHTS && l.kind == LIGHT_AREA) {
        // Each of an area light's points is a point light of its colour / N.
        intensity = div_rn(intensity, float(frame.light_samples));
    }
    if (HAS_POSITIONED_LIGHTS && l.kind != LIGHT_DIRECTIONAL) {
        return positioned_light_intensity(l, intensity, to_light, dist);
    }
    return intensity;
}

// Point k of the n that area light l (LIGHT_AREA) shows a sample: the
// stratified Hammersley point ((k + 1/2)/n, radical_inverse(k) + 1/(2n)) of
// the unit square, rotated by the sample's `rotation` (sample_dims zw; 0 at
// one sample a pixel) modulo 1, placed on the rectangle position + a e_u +
// b e_v with a, b in [-1/2, 1/2) (docs/scene-format.md#area-lights).
precise vec3 area_light_point(Light l, uint k, uint n, vec2 rotation) {
    precise float a = div_rn(float(k) + 0.5f, float(n)) + rotation.x;
    precise float b = (radical_inverse_base(k, 2u) + div_rn(0.5f, float(n))) + rotation.y;
    a = a - floor(a);
    b = b - floor(b);
    precise vec3 p = (xyz(l.position) + (a - 0.5f) * xyz(l.direction_to_light)) + (b - 0.5f) * xyz(l.spot_axis);
    return p;
}

// The shading of one hit, a light at a time (sample_pixel): Phong at the
// hit point p with unit normal n, seen from v (toward the viewer), of a
// surface whose diffuse colour is already blended with its texel.
struct Surface {
    vec3 p;
    vec3 n;
    vec3 v;
    vec3 base;     // ambient + emissive: the colour before any light
    vec3 diffuse;
    vec3 specular;
    float shininess;
    vec3 mirror;   // the mirror ray's weight k_s O_r
    vec3 transmit; // the refracted ray's weight k_t O_t (0 without FLAG_REFRACTION)
    float ior;
};

// The surface at `hit`, seen along ray r: everything its shading reads of
// its material, read once.
Surface surface_at(Ray r, SceneHit hit) {
    Material m = material_at(hit.material);
    Surface s;
    precise vec3 p = r.origin + hit.t * r.direction;
    s.p = p;
    s.n = hit.normal;
    precise vec3 v = -unit(r.direction);
    s.v = v;
    precise vec3 base = frame.k.x * xyz(m.ambient) + xyz(m.emissive);
    s.base = base;
    precise vec3 diffuse = frame.k.y * xyz(m.diffuse);
    if (HAS_TEXTURES && m.texture >= 0 && (frame.flags & FLAG_TEXTURES) != 0u) {
        precise vec3 texel = sample_texture(m, surface_uv(hit.shape, hit.p_object, hit.n_object));
        diffuse = (1.0f - m.blend) * diffuse + m.blend * texel;
    }
    s.diffuse = diffuse;
    precise vec3 specular = frame.k.z * xyz(m.specular);
    s.specular = specular;
    s.shininess = m.shininess;
    precise vec3 mirror = frame.k.z * xyz(m.reflective);
    s.mirror = mirror;
    s.transmit = vec3(0.0f, 0.0f, 0.0f);
    s.ior = m.ior;
    if (HAS_REFRACTION && (frame.flags & FLAG_REFRACTION) != 0u) {
        precise vec3 transmit = frame.k.w * xyz(m.transparent);
        s.transmit = transmit;
    }
    return s;
}

// What light l adds at surface s when nothing shadows it: diffuse and
// specular times its intensity. to_light is the unit vector toward it.
precise vec3 light_term(Surface s, Light l, vec3 to_light, float dist) {
    precise vec3 intensity = light_intensity(l, to_light, dist);
    precise float n_dot_l = dot3(s.n, to_light);
    precise vec3 term = s.diffuse * max_f(0.0f, n_dot_l);
    // `raycast explain`'s variants (layout.h FLAG_EXPLAIN_*): n.l taken
    // as it is, below 0 too; the highlight from the half vector.
    bool explained = HAS_EXPLAIN && (frame.flags & (FLAG_EXPLAIN_NEGATIVE_LIGHT | FLAG_EXPLAIN_BLINN)) != 0u;
    if (explained && (frame.flags & FLAG_EXPLAIN_NEGATIVE_LIGHT) != 0u) {
        term = s.diffuse * n_dot_l;
    }
    if (HAS_SPECULAR && s.shininess > 0.0f) {
        precise vec3 reflected = (2.0f * n_dot_l) * s.n - to_light;
        precise float toward = dot3(reflected, s.v);
        if (explained && (frame.flags & FLAG_EXPLAIN_BLINN) != 0u) {
            toward = dot3(unit(to_light + s.v), s.n);
        }
        precise float highlight = pow_portable(max_f(0.0f, toward), s.shininess);
        term = term + s.specular * highlight;
    }
    precise vec3 lit = intensity * term;
    return lit;
}

// Whether every channel of c is 0 or subnormal (below 2^-126 in size). A
// light term or mirror weight that small changes no pixel (the colours it
// would add are below 2^-126, far under a step of 1/255), and a GPU may
// flush it to 0 where the CPU build keeps it (NVIDIA promises no
// subnormals), so both builds treat it as nothing: no shadow or mirror ray.
bool negligible(vec3 c) {
    return abs(c.x) < 1.17549435e-38f && abs(c.y) < 1.17549435e-38f && abs(c.z) < 1.17549435e-38f;
}

precise vec3 clamp3(vec3 c) {
    if (HAS_EXPLAIN && (frame.flags & FLAG_EXPLAIN_NO_CLAMP) != 0u) {
        return c;
    }
    return vec3(clamp01(c.x), clamp01(c.y), clamp01(c.z));
}
