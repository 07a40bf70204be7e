// shapes.glsl: the canonical shapes, object space (see docs/scene-format.md#primitives):
//   cube [-0.5, 0.5]^3, sphere r 0.5, cylinder r 0.5 with y in [-0.5, 0.5]
//   and both caps, cone with base r 0.5 at y = -0.5, apex at y = 0.5 and a
//   base cap, torus about y with ring radius 0.375 and tube radius 0.125.
// Every shape is registered here and nowhere else on the shaders' side
// (docs/architecture.md, "Adding a shape"): its id, its specialization
// constant, its file's #include and its lines in intersect_shape and
// surface_uv. Then what the shapes share (a plane's t, the nearer of two
// hits, the roots of a quadratic, a ray's closest approach, the angle about
// y), one file per shape (its test, intersect_NAME, and its texture
// coordinates, NAME_uv), and intersect_shape and surface_uv, which
// dispatch to them.

// Primitive.shape. The host reads these (host/build.rs), and its
// scene::SHAPES names each canonical one.
#define SHAPE_CUBE 0u
#define SHAPE_CONE 1u
#define SHAPE_CYLINDER 2u
#define SHAPE_SPHERE 3u
#define SHAPE_TORUS 4u
#define SHAPE_MESH 5u // a triangle mesh: Primitive.mesh is its root in the mesh nodes (traversal.glsl)
#define SHAPE_IDS 6   // one past the last id: a new shape takes it and moves it on
// The CPU build's lean copy (host/cpu/shared.hpp) keeps the shapes whose
// ids are below this, the course's four; the host runs it only for scenes
// of them (render::Specialization::cpu_lean).
#define SHAPE_LEAN_IDS 4

// Each shape's specialization constant, SPEC_SHAPES + its id (layout.h),
// as a HAS_* bool: true unless the host specialises the kernel for a scene
// without the shape. SHAPE_SPEC is scene_buffers.glsl's (a specialization
// constant) or the C++ build's (host/cpu/shared.hpp, a const bool).
#define SPEC_CUBES (SPEC_SHAPES + 0)
#define SPEC_CONES (SPEC_SHAPES + 1)
#define SPEC_CYLINDERS (SPEC_SHAPES + 2)
#define SPEC_SPHERES (SPEC_SHAPES + 3)
#define SPEC_TORI (SPEC_SHAPES + 4)
#define SPEC_MESHES (SPEC_SHAPES + 5)
#define SPEC_COUNT (SPEC_SHAPES + SHAPE_IDS) // every specialization constant of layout.h and here
SHAPE_SPEC(SPEC_CUBES, HAS_CUBES);
SHAPE_SPEC(SPEC_CONES, HAS_CONES);
SHAPE_SPEC(SPEC_CYLINDERS, HAS_CYLINDERS);
SHAPE_SPEC(SPEC_SPHERES, HAS_SPHERES);
SHAPE_SPEC(SPEC_TORI, HAS_TORI);
SHAPE_SPEC(SPEC_MESHES, HAS_MESHES);

// The ray parameter where the ray meets the plane {p[axis] = s}. A ray
// parallel to the plane gives +-inf or NaN, which every caller's `t > 0 &&
// t < best` rejects.
precise float plane_t(Ray r, int axis, float s) {
    precise float t = div_rn(s - r.origin[axis], r.direction[axis]);
    return t;
}

// Keeps `best` unless (t, normal) is a nearer hit with t > 0.
ShapeHit nearer(ShapeHit best, float t, vec3 normal) {
    if (t > 0.0f && t < best.t) {
        ShapeHit h;
        h.t = t;
        h.normal = normal;
        return h;
    }
    return best;
}

// u in [0, 1) around the y axis: (-atan2(z, x) / 2 pi) mod 1.
precise float around_y(vec3 p) {
    precise float u = -atan2_portable(p.z, p.x) * 0.159154937f;
    if (u < 0.0f) {
        u = u + 1.0f;
    }
    return u;
}

// The smaller and larger roots of a t^2 + b t + c = 0 as (t0, t1), or
// (T_FAR, T_FAR) when there is none. a == 0 gives the one root of the line.
precise vec2 quadratic_roots(float a, float b, float c) {
    if (a == 0.0f) {
        if (b == 0.0f) {
            return vec2(T_FAR, T_FAR);
        }
        precise float t = div_rn(-c, b);
        return vec2(t, t);
    }
    precise float disc = b * b - 4.0f * a * c;
    if (disc < 0.0f) {
        return vec2(T_FAR, T_FAR);
    }
    // q = -(b + sign(b) root) / 2 adds like signs, so neither root loses
    // digits to -b + root when a is small (a cone's a = dx^2 + dz^2 -
    // dy^2/4 for rays along its side): the roots are q / a and c / q.
    precise float root = sqrt_rn(disc);
    precise float q = -0.5f * (b + ((b < 0.0f) ? -root : root));
    if (q == 0.0f) {
        return vec2(0.0f, 0.0f); // b = disc = 0, so c = 0: a double root at 0
    }
    precise float q0 = div_rn(q, a);
    precise float q1 = div_rn(c, q);
    return (q1 < q0) ? vec2(q1, q0) : vec2(q0, q1);
}

// The t at which ray r passes closest to the point c. The quadrics and
// the bounding spheres solve from there rather than from the ray's origin,
// so that a ray from far off keeps their size (intersect_sphere).
precise float closest_t(Ray r, vec3 c) {
    precise float t = div_rn(dot3(c - r.origin, r.direction), dot3(r.direction, r.direction));
    return t;
}

// The shapes' own files (shape_mesh.glsl is traversal.glsl's).
#include "shape_cube.glsl"
#include "shape_sphere.glsl"
#include "shape_cylinder.glsl"
#include "shape_cone.glsl"
#include "shape_torus.glsl"

// The test of shape `shape`; the HAS_* constants leave out the shapes a
// specialised kernel's scene does not have.
ShapeHit intersect_shape(uint shape, Ray r) {
    if (HAS_CUBES && shape == SHAPE_CUBE) {
        return intersect_cube(r);
    }
    if (HAS_CONES && shape == SHAPE_CONE) {
        return intersect_cone(r);
    }
    if (HAS_CYLINDERS && shape == SHAPE_CYLINDER) {
        return intersect_cylinder(r);
    }
    if (HAS_TORI && shape == SHAPE_TORUS) {
        return intersect_torus(r);
    }
    if (HAS_SPHERES) {
        return intersect_sphere(r);
    }
    return no_hit();
}

// (u, v) of an object-space hit point p with the shape test's normal n
// (docs/scene-format.md#texture-coordinates): a mesh's are its own
// (traversal.glsl, primitive_hit, keeps them in p); the HAS_* constants
// leave out the shapes a specialised kernel's scene does not have.
precise vec2 surface_uv(uint shape, vec3 p, vec3 n) {
    if (HAS_MESHES && shape == SHAPE_MESH) {
        return vec2(p.x, p.y);
    }
    if (HAS_CUBES && shape == SHAPE_CUBE) {
        return cube_uv(p, n);
    }
    if (HAS_SPHERES && shape == SHAPE_SPHERE) {
        return sphere_uv(p);
    }
    if (HAS_TORI && shape == SHAPE_TORUS) {
        return torus_uv(p);
    }
    if (HAS_CYLINDERS && shape == SHAPE_CYLINDER) {
        return cylinder_uv(p, n);
    }
    return cone_uv(p, n);
}
