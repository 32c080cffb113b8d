// Which instruction set a routine with a wide path runs, and what this CPU has.
#pragma once

namespace penumbra {

// Best takes the widest path the CPU has (AVX2 on x86-64 CPUs that have it, with FMA and F16C
// where the routine says so), Portable the baseline of the target (4-lane SSE on x86-64). The two
// paths of a routine compute the same function (its header says whether to the bit); Portable is
// there to show that on a machine that has the wide one.
enum class Isa { Best, Portable };

// Whether this CPU has AVX2 (false off x86-64). Read once. Thread-safe.
bool cpu_has_avx2();
// Whether it has AVX2, FMA and F16C together (F16C from CPUID leaf 1: not every compiler's
// cpu-supports builtin names it). Read once. Thread-safe.
bool cpu_has_avx2_fma_f16c();

}  // namespace penumbra
