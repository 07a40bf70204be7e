// raycast_cpu_lean.cpp: raycast_cpu.cpp's row loops compiled a second time
// with the features a course scene seldom reaches left out (shared.hpp,
// RAYCAST_CPU_LEAN), as raycast_cpu_render_rows_lean and
// raycast_cpu_preview_rows_lean; cpu.rs calls them where the frame's
// specialization leaves those features out as well.
#define RAYCAST_CPU_LEAN
#include "raycast_cpu.cpp"
