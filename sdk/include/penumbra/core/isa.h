// Which instruction set a routine with a wide path runs.
#pragma once

namespace penumbra {

// Best takes the widest path the CPU has (AVX2 on x86-64 CPUs that have it, with FMA and F16C
// where the routine says so), Portable the baseline of the target (4-lane SSE on x86-64). The two
// paths of a routine compute the same function (its header says whether to the bit); Portable is
// there to show that on a machine that has the wide one.
enum class Isa { Best, Portable };

}  // namespace penumbra
