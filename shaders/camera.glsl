// camera.glsl: the primary ray through a pixel (frame.world_from_film).

// The primary ray through pixel (column j, row i; row 0 at the top), at
// `offset` pixels from its centre (0, 0 for the centre). The film point
// (x, y, -1) has x, y in [-1, 1]; world_from_film maps it to world space, so
// its linear part maps it to the ray direction.
Ray camera_ray(uint j, uint i, vec2 offset) {
    precise float x = div_rn((float(j) + 0.5f) + offset.x, float(frame.width)) * 2.0f - 1.0f;
    precise float y = 1.0f - div_rn((float(i) + 0.5f) + offset.y, float(frame.height)) * 2.0f;
    Ray r;
    r.origin = xyz(frame.eye);
    r.direction = transform_vector(frame.world_from_film, vec3(x, y, -1.0f));
    return r;
}
