// shape_sphere.glsl: the sphere of radius 0.5 (included by shapes.glsl).

// Sphere: |o + t d|^2 = 0.25; normal = the hit point. Solved from the
// ray's closest approach to the centre, not the quadratic's b^2 - 4ac,
// which loses the 0.25 against |o|^2 once the ray starts far off in object
// units: a sphere 3,000 radii away (the tips of recursive-spheres depth 8
// seen from the camera) has |o|^2 ~ 1e7, whose f32 step is 1, so it drew
// noise up to twice its size. This errs by a few f32 steps of |o|, so a
// bounding sphere with a small slack holds every hit (sphere_hit).
ShapeHit intersect_sphere(Ray r) {
    precise float a = dot3(r.direction, r.direction);
    precise float tc = closest_t(r, vec3(0.0f, 0.0f, 0.0f));
    precise vec3 closest = r.origin + tc * r.direction;
    precise float disc = 0.25f - dot3(closest, closest);
    precise float half_chord = sqrt_rn(div_rn(max_f(disc, 0.0f), a));
    precise vec2 ts = (disc < 0.0f) ? vec2(T_FAR, T_FAR) : vec2(tc - half_chord, tc + half_chord);
    ShapeHit best = no_hit();
    for (int k = 0; k < 2; k++) {
        precise float t = ts[k];
        precise vec3 p = r.origin + t * r.direction;
        best = nearer(best, t, p);
    }
    return best;
}

// (u, v): u around y, v by latitude from the top.
precise vec2 sphere_uv(vec3 p) {
    return vec2(around_y(p), 0.5f - asin_portable(2.0f * p.y) * 0.318309873f);
}
