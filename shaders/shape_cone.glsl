// shape_cone.glsl: the cone with base radius 0.5 at y = -0.5 and apex at
// y = 0.5, and its base cap (included by shapes.glsl).

// Cone body x^2 + z^2 = ((0.5 - y) / 2)^2 as a t^2 + b t + c = 0 for the
// points o + t d of ray r, with h = 0.5 - o.y:
//   a = dx^2 + dz^2 - dy^2 / 4
//   b = 2 (ox dx + oz dz) + h dy / 2
//   c = ox^2 + oz^2 - h^2 / 4
// Returned as (a, b, c).
precise vec3 cone_quadratic(Ray r) {
    precise float h = 0.5f - r.origin.y;
    precise float a = (r.direction.x * r.direction.x + r.direction.z * r.direction.z) - 0.25f * (r.direction.y * r.direction.y);
    precise float b = 2.0f * (r.origin.x * r.direction.x + r.origin.z * r.direction.z) + 0.5f * (h * r.direction.y);
    precise float c = (r.origin.x * r.origin.x + r.origin.z * r.origin.z) - 0.25f * (h * h);
    return vec3(a, b, c);
}

// Cone: the body for y in [-0.5, 0.5] with normal the gradient
// (2x, (0.5 - y) / 2, 2z), and the base cap y = -0.5. The quadratic is
// solved for the ray moved to its closest approach to the centre (t0), as
// the sphere, so that its c keeps the cone's size for rays from far off.
ShapeHit intersect_cone(Ray r) {
    precise float t0 = closest_t(r, vec3(0.0f, 0.0f, 0.0f));
    Ray near_centre;
    near_centre.origin = r.origin + t0 * r.direction;
    near_centre.direction = r.direction;
    precise vec3 q = cone_quadratic(near_centre);
    precise vec2 ss = quadratic_roots(q.x, q.y, q.z);
    precise vec2 ts = (ss.x == T_FAR) ? ss : vec2(t0 + ss.x, t0 + ss.y);
    ShapeHit best = no_hit();
    for (int k = 0; k < 2; k++) {
        precise float t = ts[k];
        precise vec3 p = r.origin + t * r.direction;
        if (abs(p.y) <= 0.5f) {
            best = nearer(best, t, vec3(2.0f * p.x, 0.5f * (0.5f - p.y), 2.0f * p.z));
        }
    }
    best = cap(best, r, -0.5f, -1.0f);
    return best;
}

// (u, v): the base cap (normal (0, -1, 0)) as a square seen from below,
// the body (n.y >= 0) u around y and v down it.
precise vec2 cone_uv(vec3 p, vec3 n) {
    if (n.y < 0.0f && n.x == 0.0f && n.z == 0.0f) {
        return vec2(p.x + 0.5f, 0.5f - p.z);
    }
    return vec2(around_y(p), 0.5f - p.y);
}
