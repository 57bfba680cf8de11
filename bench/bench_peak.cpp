// This machine's floating-point and memory peaks, the floors that docs/performance.md divides each stage's work by.
//   BM_FmaPeak:  independent AVX-512 (else AVX2) FMA chains in registers; counter flops = 2 per lane per FMA.
//   BM_Triad:    STREAM triad a = b + s c over 3 x 64 MiB (far beyond the caches); counter bytes = 24 per element
//                (two reads, one write; the write-allocate read is not counted, as in STREAM).
// Arg: threads (1 or 2). Run it in the same session as bench_step:
//   OMP_NUM_THREADS=2 build/release/bench/bench_peak --benchmark_repetitions=3
#include <benchmark/benchmark.h>
#include <immintrin.h>

#include <vector>

// GCC 12's AVX-512 intrinsics start from _mm512_undefined_pd(), which its uninitialized-use warnings report.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

namespace {

constexpr long kFmaIters = 1L << 24;

__attribute__((target("avx512f"))) double fma_chains_avx512(long iters) {
  __m512d a[12];
  const __m512d m = _mm512_set1_pd(0.999999), c = _mm512_set1_pd(1e-7);
  for (int k = 0; k < 12; ++k) a[k] = _mm512_set1_pd(1.0 + k);
  for (long i = 0; i < iters; ++i)
    for (int k = 0; k < 12; ++k) a[k] = _mm512_fmadd_pd(a[k], m, c);
  __m512d s = a[0];
  for (int k = 1; k < 12; ++k) s = _mm512_add_pd(s, a[k]);
  return _mm512_reduce_add_pd(s);
}

__attribute__((target("avx2,fma"))) double fma_chains_avx2(long iters) {
  __m256d a[12];
  const __m256d m = _mm256_set1_pd(0.999999), c = _mm256_set1_pd(1e-7);
  for (int k = 0; k < 12; ++k) a[k] = _mm256_set1_pd(1.0 + k);
  for (long i = 0; i < iters; ++i)
    for (int k = 0; k < 12; ++k) a[k] = _mm256_fmadd_pd(a[k], m, c);
  __m256d s = a[0];
  for (int k = 1; k < 12; ++k) s = _mm256_add_pd(s, a[k]);
  alignas(32) double l[4];
  _mm256_store_pd(l, s);
  return l[0] + l[1] + l[2] + l[3];
}

void BM_FmaPeak(benchmark::State& st) {
  const int nt = static_cast<int>(st.range(0));
  const bool avx512 = __builtin_cpu_supports("avx512f");
  const double lanes = avx512 ? 8.0 : 4.0;
  double sink = 0.0;
  for (auto _ : st) {
#pragma omp parallel num_threads(nt) reduction(+ : sink)
    sink += avx512 ? fma_chains_avx512(kFmaIters) : fma_chains_avx2(kFmaIters);
  }
  benchmark::DoNotOptimize(sink);
  st.counters["flops"] = benchmark::Counter(2.0 * lanes * 12.0 * kFmaIters * nt, benchmark::Counter::kIsIterationInvariantRate);
  st.SetLabel(avx512 ? "avx512" : "avx2");
}

void BM_Triad(benchmark::State& st) {
  const int nt = static_cast<int>(st.range(0));
  const long n = 8L << 20;  // 64 MiB per array
  std::vector<double> a(n), b(n), c(n);
#pragma omp parallel for num_threads(nt) schedule(static)
  for (long i = 0; i < n; ++i) a[i] = 0.0, b[i] = 1.0, c[i] = 2.0;  // first touch by the threads that stream
  const double s = 3.0;
  for (auto _ : st) {
#pragma omp parallel for num_threads(nt) schedule(static)
    for (long i = 0; i < n; ++i) a[i] = b[i] + s * c[i];
    benchmark::ClobberMemory();
  }
  st.counters["bytes"] = benchmark::Counter(24.0 * n, benchmark::Counter::kIsIterationInvariantRate);
}

}  // namespace

BENCHMARK(BM_FmaPeak)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Triad)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);
