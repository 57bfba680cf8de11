#pragma once
// The host's vector path: which instruction set the x86-64 host loops of the local sums, the spreading and
// interpolation and the mode solves use. Chosen once per process from the CPU and capped by the environment, so that
// one machine can test every path it can execute (tools/simd_paths.sh, docs/performance.md section 6):
//   CAPSFLOW_SIMD=portable|avx2|avx512   the highest path to use (the CPU's best when unset or higher)
//   CAPSFLOW_NO_AVX512=1                 the same as CAPSFLOW_SIMD=avx2 (kept for existing scripts)
// The local sums have all three paths; the spreading, interpolation and mode solves have AVX-512 and portable loops
// (their portable loops run on the avx2 and portable paths). Offload builds and other CPUs: always portable.
#include <string>

namespace capsflow {

enum class SimdPath : int { Portable = 0, Avx2 = 1, Avx512 = 2 };

// The path this process uses (fixed at the first call).
SimdPath host_simd_path();
// The best path this CPU and build can execute.
SimdPath cpu_simd_path();
const char* simd_path_name(SimdPath p);

// The rule behind host_simd_path, for tests: the CPU's best capped by the two variables' values (nullptr: unset). An
// unrecognised CAPSFLOW_SIMD leaves the cap off (the command line refuses it first: simd_environment_problem).
SimdPath simd_path_for(SimdPath cpu, const char* simd_env, const char* no_avx512_env);
// Empty when CAPSFLOW_SIMD is unset or names a path; else the one-line message that names the variable.
std::string simd_environment_problem();

}  // namespace capsflow
