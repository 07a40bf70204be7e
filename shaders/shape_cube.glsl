// shape_cube.glsl: the cube [-0.5, 0.5]^3 (included by shapes.glsl).

// Cube: each of the six face planes x, y, z = +-0.5, the hit point's other
// two coordinates within [-0.5, 0.5].
ShapeHit intersect_cube(Ray r) {
    ShapeHit best = no_hit();
    for (int axis = 0; axis < 3; axis++) {
        int a1 = (axis + 1) % 3;
        int a2 = (axis + 2) % 3;
        for (int side = 0; side < 2; side++) {
            float s = (side == 0) ? 0.5f : -0.5f;
            precise float t = plane_t(r, axis, s);
            precise float p1 = r.origin[a1] + t * r.direction[a1];
            precise float p2 = r.origin[a2] + t * r.direction[a2];
            if (abs(p1) <= 0.5f && abs(p2) <= 0.5f) {
                vec3 n = vec3(0.0f, 0.0f, 0.0f);
                n[axis] = s; // a component, not a swizzle
                best = nearer(best, t, n);
            }
        }
    }
    return best;
}

// (u, v) on the face the normal n says, each face's square seen from outside.
precise vec2 cube_uv(vec3 p, vec3 n) {
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
