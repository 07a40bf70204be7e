// refraction.glsl: transparent surfaces (docs/scene-format.md#refraction):
// the direction a refracted ray leaves a hit in, and what a ray leaving a
// transparent object sees of its surface.

// The refracted direction of a ray along unit d at a hit with unit outward
// normal n on a surface of index of refraction ior (relative to air, on
// either side): entering where d meets the outside (n . d < 0), leaving
// otherwise (Snell's law with eta = 1/ior or ior). Under total internal
// reflection, the mirror direction about the surface: the refracted ray's
// weight goes into the inside reflection.
precise vec3 refracted_direction(vec3 d, vec3 n, float ior) {
    precise float cos_i = -dot3(n, d);
    precise float eta = div_rn(1.0f, ior);
    precise vec3 facing = n;
    if (cos_i < 0.0f) {
        cos_i = -cos_i;
        eta = ior;
        facing = -n;
    }
    precise float k = 1.0f - (eta * eta) * (1.0f - cos_i * cos_i);
    if (k < 0.0f) {
        precise vec3 inside = d + (2.0f * cos_i) * facing;
        return inside;
    }
    precise vec3 t = eta * d + (eta * cos_i - sqrt_rn(k)) * facing;
    return t;
}

// Whether a ray leaves a transparent object at surface s: it meets the
// surface from inside (V on the side the normal points away from).
bool leaves_medium(Surface s) {
    return !negligible(s.transmit) && dot3(s.n, s.v) < 0.0f;
}

// Surface s as a ray leaving its object sees it: no colour of its own, no
// mirror ray; the refracted ray goes on with its whole weight (the course's
// renders, docs/scene-format.md#refraction).
Surface passing_out(Surface s) {
    s.base = vec3(0.0f, 0.0f, 0.0f);
    s.diffuse = vec3(0.0f, 0.0f, 0.0f);
    s.specular = vec3(0.0f, 0.0f, 0.0f);
    s.mirror = vec3(0.0f, 0.0f, 0.0f);
    s.transmit = vec3(1.0f, 1.0f, 1.0f);
    return s;
}
