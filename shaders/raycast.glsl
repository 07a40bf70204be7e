// raycast.glsl: everything computed per pixel — camera rays, the four
// canonical primitive tests, nearest hit, normals, local lighting and
// quantisation. Written once; it runs as GLSL in the compute kernels and
// compiles unchanged as C++ with GLM (the CPU build, host/cpu/shared.hpp).
// This file is the one that kernels and the CPU build include: it includes
// the files below, one per concern, in the order each needs the others.
//
// Exactness rules (docs/exactness.md#the-recipe), which every line obeys so
// that lavapipe and the CPU build agree bit for bit:
//   - no normalize(), no mat*vec, no built-in dot: fixed-order sums instead;
//   - `precise` on every float temporary and float-returning function;
//   - min / max / clamp as ternaries in GLM's operand order;
//   - no fma(), no transcendental built-ins: pow and acos are built here
//     from + - * / and sqrt (the fast kernel aside: exact.glsl, FAST_MATH);
//   - literals with the f suffix, at most 9 significant digits;
//   - no swizzles on the left of =, no out/inout, no struct constructors.
//
// The includer declares, before including this file, the scene buffers:
// scene_buffers.glsl in GLSL, host/cpu/shared.hpp in C++.

#ifndef RAYCAST_GLSL
#define RAYCAST_GLSL

#include "exact.glsl"
#include "rays.glsl"
#include "camera.glsl"
#include "shapes.glsl" // and shape_cube, shape_sphere, shape_cylinder, shape_cone, shape_torus
#include "traversal.glsl"
#include "textures.glsl"
#include "lighting.glsl"
#include "refraction.glsl"
#include "aov.glsl"
#include "trace.glsl"
#include "course_sampling.glsl"
#include "sampling.glsl"

#endif
