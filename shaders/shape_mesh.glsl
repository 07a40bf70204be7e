// shape_mesh.glsl: triangle meshes (docs/scene-format.md#triangle-meshes):
// the watertight ray-triangle test and the walk through a mesh's own
// hierarchy (layout.h, BINDING_MESH_*). Included by traversal.glsl after
// box_hit, which the walk uses.

// The ray's frame for the triangle test (Woop, Benthin and Wald 2013,
// "Watertight Ray/Triangle Intersection", JCGT 2(1)): kz the axis where
// the direction is largest, kx and ky the other two; the shear (sx, sy, sz)
// maps the ray onto the +z axis of a space where it starts at the origin.
struct TriangleRay {
    vec3 origin;
    int kx;
    int ky;
    int kz;
    vec3 shear;
};

TriangleRay triangle_ray(Ray r) {
    TriangleRay tr;
    tr.origin = r.origin;
    vec3 d = r.direction;
    int kz = 2;
    if (abs(d.x) >= abs(d.y) && abs(d.x) >= abs(d.z)) {
        kz = 0;
    } else if (abs(d.y) >= abs(d.z)) {
        kz = 1;
    }
    tr.kz = kz;
    tr.kx = (kz == 2) ? 0 : kz + 1;
    tr.ky = (tr.kx == 2) ? 0 : tr.kx + 1;
    precise float sx = div_rn(d[tr.kx], d[kz]);
    precise float sy = div_rn(d[tr.ky], d[kz]);
    precise float sz = div_rn(1.0f, d[kz]);
    tr.shear = vec3(sx, sy, sz);
    return tr;
}

// Vertex p in the ray's sheared space: (x, y) its offset from the ray in
// the plane, z its scaled distance along it. Each vertex is mapped alone,
// so two triangles that share an edge see the same two points.
precise vec3 sheared(TriangleRay tr, vec3 p) {
    precise vec3 a = p - tr.origin;
    precise float x = a[tr.kx] - tr.shear.x * a[tr.kz];
    precise float y = a[tr.ky] - tr.shear.y * a[tr.kz];
    precise float z = tr.shear.z * a[tr.kz];
    return vec3(x, y, z);
}

// The hit of the ray with triangle (a, b, c) as (t, u, v, w): t > 0 the ray
// parameter, (u, v, w) the weights of a, b and c (they sum to 1); t = T_FAR
// on a miss. The edge functions U, V, W are each a difference of two
// products of the sheared vertices; the triangle across a shared edge
// computes the same two products and subtracts them the other way round,
// which negates the result exactly. A ray through an edge (a function 0)
// counts as inside on both sides, so none slips between two triangles.
// Hit from either side.
precise vec4 triangle_hit(TriangleRay tr, vec3 a, vec3 b, vec3 c) {
    precise vec3 sa = sheared(tr, a);
    precise vec3 sb = sheared(tr, b);
    precise vec3 sc = sheared(tr, c);
    precise float u = sc.x * sb.y - sc.y * sb.x;
    precise float v = sa.x * sc.y - sa.y * sc.x;
    precise float w = sb.x * sa.y - sb.y * sa.x;
    if ((u < 0.0f || v < 0.0f || w < 0.0f) && (u > 0.0f || v > 0.0f || w > 0.0f)) {
        return vec4(T_FAR, 0.0f, 0.0f, 0.0f);
    }
    precise float det = u + v + w;
    if (det == 0.0f) {
        return vec4(T_FAR, 0.0f, 0.0f, 0.0f); // seen edge on
    }
    precise float scaled_t = u * sa.z + v * sb.z + w * sc.z;
    precise float t = div_rn(scaled_t, det);
    if (!(t > 0.0f)) {
        return vec4(T_FAR, 0.0f, 0.0f, 0.0f);
    }
    return vec4(t, div_rn(u, det), div_rn(v, det), div_rn(w, det));
}

precise vec3 cross3(vec3 a, vec3 b) {
    return vec3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

// The nearest hit of ray r (in the mesh's space) with the mesh whose root
// is mesh_nodes[root], at t <= t_max (on equal t the lowest triangle index,
// so that the answer does not depend on the order of the walk): t (T_FAR
// on a miss), the object-space normal (not unit) and the texture
// coordinates (the normal faces the ray: below). With FLAG_NO_BVH the boxes are ignored and every triangle
// is tested: the same answer.
struct MeshHit {
    float t;
    vec3 normal;
    vec2 uv;
    // AOV_LANES (0 elsewhere): the walk's steps (a node taken off the
    // stack) and the bytes they fetched: nodes, and each triangle tested
    // with its three positions.
    uint steps;
    uint node_bytes;
    uint triangle_bytes;
};

MeshHit intersect_mesh(uint root, Ray r, float t_max) {
    MeshHit best;
    best.t = t_max;
    best.normal = vec3(0.0f, 0.0f, 0.0f);
    best.uv = vec2(0.0f, 0.0f);
    best.steps = 0u;
    best.node_bytes = 0u;
    best.triangle_bytes = 0u;
    bool count = HAS_AOVS && frame.aov == AOV_LANES;
    uint best_triangle = NO_HIT;
    vec4 best_weights = vec4(0.0f);
    bool use_boxes = (frame.flags & FLAG_NO_BVH) == 0u;
    TriangleRay tr = triangle_ray(r);
    uint stack[MESH_STACK_SIZE];
    int top = 1;
    stack[0] = root;
    while (top > 0) {
        top = top - 1;
        BvhNode node = mesh_nodes[stack[top]];
        if (count) {
            best.steps = best.steps + 1u;
            best.node_bytes = best.node_bytes + NODE_BYTES;
        }
        if (use_boxes && !box_hit(r, node.lo, node.hi, best.t)) {
            continue;
        }
        if (node.count == 0u) {
            // The nearer child (by the ray's sign on the split axis) on top.
            bool left_first = r.direction[node.axis] >= 0.0f;
            stack[top] = left_first ? node.first + 1u : node.first;
            stack[top + 1] = left_first ? node.first : node.first + 1u;
            top = top + 2;
            continue;
        }
        if (count) {
            best.triangle_bytes = best.triangle_bytes + node.count * TRIANGLE_BYTES;
        }
        for (uint i = node.first; i < node.first + node.count; i++) {
            MeshTriangle tri = mesh_triangles[i];
            vec4 h = triangle_hit(tr, xyz(mesh_vertices[tri.a].position), xyz(mesh_vertices[tri.b].position),
                                  xyz(mesh_vertices[tri.c].position));
            if (h.x < best.t || (h.x == best.t && h.x < T_FAR && i < best_triangle)) {
                best.t = h.x;
                best_triangle = i;
                best_weights = h;
            }
        }
    }
    if (best_triangle == NO_HIT) {
        best.t = T_FAR;
        return best;
    }
    MeshTriangle tri = mesh_triangles[best_triangle];
    MeshVertex a = mesh_vertices[tri.a];
    MeshVertex b = mesh_vertices[tri.b];
    MeshVertex c = mesh_vertices[tri.c];
    // Two-sided: the normal turned to the side the ray comes from (by the
    // face's own normal), so that a mesh seen from inside (a room) is lit
    // from inside.
    precise vec3 face = cross3(xyz(b.position) - xyz(a.position), xyz(c.position) - xyz(a.position));
    bool back = dot3(face, r.direction) > 0.0f;
    if ((tri.flags & MESH_SMOOTH) != 0u) {
        precise vec3 n = best_weights.y * xyz(a.normal) + best_weights.z * xyz(b.normal) + best_weights.w * xyz(c.normal);
        best.normal = back ? -n : n;
    } else {
        best.normal = back ? -face : face;
    }
    precise vec2 uv = best_weights.y * vec2(a.position.w, a.normal.w) + best_weights.z * vec2(b.position.w, b.normal.w) +
                      best_weights.w * vec2(c.position.w, c.normal.w);
    best.uv = uv;
    return best;
}
