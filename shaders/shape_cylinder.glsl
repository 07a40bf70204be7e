// shape_cylinder.glsl: the cylinder of radius 0.5, y in [-0.5, 0.5], and
// its flat caps (`cap`, which the cone's base uses too; included by
// shapes.glsl).

// Flat cap {y = s, x^2 + z^2 <= 0.25} with normal (0, ny, 0).
ShapeHit cap(ShapeHit best, Ray r, float s, float ny) {
    if (HAS_EXPLAIN && (frame.flags & FLAG_EXPLAIN_NO_CAPS) != 0u) {
        return best;
    }
    precise float t = plane_t(r, 1, s);
    precise float x = r.origin.x + t * r.direction.x;
    precise float z = r.origin.z + t * r.direction.z;
    precise float rr = x * x + z * z;
    if (rr <= 0.25f) {
        best = nearer(best, t, vec3(0.0f, ny, 0.0f));
    }
    return best;
}

// Cylinder: body x^2 + z^2 = 0.25 for y in [-0.5, 0.5], normal (x, 0, z);
// caps y = +-0.5. The body, as the sphere, from the ray's closest approach
// to the axis (in x and z), which keeps the 0.25 for rays from far off; a
// ray parallel to the axis (a = 0) meets the body nowhere or everywhere,
// and the caps decide.
ShapeHit intersect_cylinder(Ray r) {
    precise float a = r.direction.x * r.direction.x + r.direction.z * r.direction.z;
    precise float tc = div_rn(-(r.origin.x * r.direction.x + r.origin.z * r.direction.z), a);
    precise float cx = r.origin.x + tc * r.direction.x;
    precise float cz = r.origin.z + tc * r.direction.z;
    precise float disc = 0.25f - (cx * cx + cz * cz);
    precise float half_chord = sqrt_rn(div_rn(max_f(disc, 0.0f), a));
    precise vec2 ts = (a == 0.0f || disc < 0.0f) ? vec2(T_FAR, T_FAR) : vec2(tc - half_chord, tc + half_chord);
    ShapeHit best = no_hit();
    for (int k = 0; k < 2; k++) {
        precise float t = ts[k];
        precise vec3 p = r.origin + t * r.direction;
        if (abs(p.y) <= 0.5f) {
            best = nearer(best, t, vec3(p.x, 0.0f, p.z));
        }
    }
    best = cap(best, r, 0.5f, 1.0f);
    best = cap(best, r, -0.5f, -1.0f);
    return best;
}

// (u, v): the caps (normal (0, +-1, 0)) as squares seen from outside, the
// body u around y and v down it.
precise vec2 cylinder_uv(vec3 p, vec3 n) {
    if (n.y < 0.0f && n.x == 0.0f && n.z == 0.0f) {
        return vec2(p.x + 0.5f, 0.5f - p.z);
    }
    if (n.y > 0.0f && n.x == 0.0f && n.z == 0.0f) {
        return vec2(p.x + 0.5f, p.z + 0.5f);
    }
    return vec2(around_y(p), 0.5f - p.y);
}
