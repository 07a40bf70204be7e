// raycast_cpu_lean_avx2.cpp: the lean copy (raycast_cpu_lean.cpp) compiled
// for x86-64 CPUs with AVX2 (-mavx2, host/cpu/CMakeLists.txt), as
// raycast_cpu_render_rows_lean_avx2 and raycast_cpu_preview_rows_lean_avx2:
// records_meet.hpp then tests eight records a group where it tests four,
// and a leaf of the course's recursive scenes holds five. cpu.rs calls it
// where the lean copy would draw and the CPU has AVX2. The same
// operations on the same floats (no FMA: the flags keep -ffp-contract=off),
// so the same bits.
#define RAYCAST_CPU_LEAN
#define RAYCAST_CPU_AVX2
#include "raycast_cpu.cpp"
