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

// The radical inverse of s in base b: its base-b digits mirrored about the
// point, as one quotient of whole numbers (exact while both are below
// 2^24, which s below 3^15 keeps in bases up to 11 for the first 5 digits;
// rounded the same way in every build beyond).
precise float radical_inverse_base(uint s, uint b) {
    uint numerator = 0u;
    uint denominator = 1u;
    for (uint k = s; k != 0u; k = k / b) {
        numerator = numerator * b + k % b;
        denominator = denominator * b;
    }
    return div_rn(float(numerator), float(denominator));
}

// frac(radical_inverse(s, b) + 1/(2n)) - 1/2: coordinate b of sample s of n,
// shifted by half a stratum as sample_offset's second one, centred on 0
// (0 for the one sample of n = 1).
precise float sample_coordinate(uint s, uint n, uint b) {
    precise float x = radical_inverse_base(s, b) + div_rn(0.5f, float(n));
    if (x >= 1.0f) {
        x = x - 1.0f;
    }
    precise float centred = x - 0.5f;
    return centred;
}

// The dimensions of sample s of n beyond the pixel offset (sample_offset):
// xy its lens point, zw the rotation of its area-light points, each in
// [-1/2, 1/2): the Halton radical inverses in bases 3, 5 and 7, 11, so the
// pixel's samples are a Hammersley set in six dimensions
// (docs/scene-format.md#depth-of-field). 0 where the kernel has no lens or
// area light.
vec4 sample_dims(uint s, uint n) {
    vec4 d = vec4(0.0f, 0.0f, 0.0f, 0.0f);
    if (HAS_DOF && (frame.flags & FLAG_DOF) != 0u) {
        d.x = sample_coordinate(s, n, 3u);
        d.y = sample_coordinate(s, n, 5u);
    }
    if (HAS_AREA_LIGHTS) {
        d.z = sample_coordinate(s, n, 7u);
        d.w = sample_coordinate(s, n, 11u);
    }
    return d;
}

// sin and cos on [-pi/4, pi/4] from their Taylor series (to x^9 and
// x^10: error below 2e-9), for the disk mapping below.
precise float sin_quarter(float x) {
    precise float s = x * x;
    precise float r = x * (1.0f - s * (0.166666667f - s * (0.00833333333f - s * (0.000198412698f - s * 2.75573192e-6f))));
    return r;
}

precise float cos_quarter(float x) {
    precise float s = x * x;
    precise float r = 1.0f - s * (0.5f - s * (0.0416666667f - s * (0.00138888889f - s * (2.48015873e-5f - s * 2.75573192e-7f))));
    return r;
}

// Shirley and Chiu's concentric map of the square [-1/2, 1/2)^2 onto the
// unit disk: concentric squares to concentric circles, area for area.
vec2 concentric_disk(vec2 q) {
    precise float a = 2.0f * q.x;
    precise float b = 2.0f * q.y;
    if (a == 0.0f && b == 0.0f) {
        return vec2(0.0f, 0.0f);
    }
    if (abs(a) > abs(b)) {
        precise float phi = 0.785398163f * div_rn(b, a);
        precise float x = a * cos_quarter(phi);
        precise float y = a * sin_quarter(phi);
        return vec2(x, y);
    }
    // phi = pi/2 - (pi/4)(a/b): cos and sin trade places.
    precise float theta = 0.785398163f * div_rn(a, b);
    precise float x = b * sin_quarter(theta);
    precise float y = b * cos_quarter(theta);
    return vec2(x, y);
}

// The thin lens (FLAG_DOF): the pinhole ray r through the lens point
// `lens` (a square point of sample_dims, mapped onto the disk of radius
// frame.lens_radius across the camera's u and v axes), aimed at the point
// r meets at frame.focal_distance along the view axis: r's direction d
// ends 1 along the view axis, so eye + f d is that point, and the new ray
// from eye + o is d - o/f, with the same t at the focal plane.
Ray lens_ray(Ray r, vec2 lens) {
    vec2 disk = concentric_disk(lens);
    precise vec3 u = unit(xyz(frame.world_from_film[0]));
    precise vec3 v = unit(xyz(frame.world_from_film[1]));
    precise vec3 across = (frame.lens_radius * disk.x) * u + (frame.lens_radius * disk.y) * v;
    Ray lensed;
    precise vec3 origin = r.origin + across;
    lensed.origin = origin;
    precise vec3 direction = r.direction - div_rn(across, frame.focal_distance);
    lensed.direction = direction;
    return lensed;
}
