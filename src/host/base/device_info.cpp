// The implementation of device_info.hpp: what the device backend runs on.
#include "host/base/device_info.hpp"

#include <cstdio>
#include <cstdlib>

#include "host/base/backend_select.hpp"
#include "host/base/errors.hpp"
#include "kernels/backend.hpp"

#ifdef CAPSFLOW_HAVE_OPENMP
#include <omp.h>
#endif
#ifdef CAPSFLOW_HAVE_CUDA
#include <cuda_runtime_api.h>
#include <dlfcn.h>
#endif

namespace capsflow {
namespace {

std::string gib(std::size_t bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f GiB", static_cast<double>(bytes) / (1024.0 * 1024.0 * 1024.0));
  return buf;
}

}  // namespace

void share_cuda_primary_context() {
#ifdef CAPSFLOW_HAVE_CUDA
  static const bool done = [] {
    const int d = default_device();
    if (device_count() == 0 || d < 0 || d >= device_count()) return false;
    // A context already current on this thread (the OpenMP runtime opened the device first, with its own) is left
    // alone: the CUDA runtime adopts a current context, and replacing it would strand the OpenMP runtime's memory and
    // kernels. The driver library is loaded by now (omp_get_num_devices initialised it); ask it without loading it.
    if (void* cuda = dlopen("libcuda.so.1", RTLD_LAZY | RTLD_NOLOAD)) {
      using GetCurrent = int (*)(void**);
      auto get_current = reinterpret_cast<GetCurrent>(dlsym(cuda, "cuCtxGetCurrent"));
      void* ctx = nullptr;
      const bool busy = get_current != nullptr && get_current(&ctx) == 0 && ctx != nullptr;
      dlclose(cuda);
      if (busy) return false;
    }
    // cudaSetDevice makes the primary context current on this thread, and cudaFree(0) initialises it; libgomp, when it
    // opens the device later, adopts the current context instead of creating its own.
    return cudaSetDevice(d) == cudaSuccess && cudaFree(nullptr) == cudaSuccess;
  }();
  (void)done;
#endif
}

bool cuda_runtime_linked() {
#ifdef CAPSFLOW_HAVE_CUDA
  return true;
#else
  return false;
#endif
}

std::vector<GpuInfo> cuda_devices(std::string& why) {
  std::vector<GpuInfo> out;
#ifdef CAPSFLOW_HAVE_CUDA
  int n = 0;
  const cudaError_t e = cudaGetDeviceCount(&n);
  if (e != cudaSuccess) {
    why = std::string("CUDA runtime: ") + cudaGetErrorString(e);
    return out;
  }
  for (int d = 0; d < n; ++d) {
    cudaDeviceProp p{};
    if (cudaGetDeviceProperties(&p, d) != cudaSuccess) continue;
    GpuInfo g;
    g.index = d;
    g.name = p.name;
    g.cc_major = p.major;
    g.cc_minor = p.minor;
    g.total_bytes = p.totalGlobalMem;
    std::size_t free_b = 0, total_b = 0;
    if (cudaSetDevice(d) == cudaSuccess && cudaMemGetInfo(&free_b, &total_b) == cudaSuccess) g.free_bytes = free_b;
    out.push_back(g);
  }
  if (out.empty()) why = "CUDA runtime: no device";
  if (n > 0) (void)cudaSetDevice(default_device() >= 0 && default_device() < n ? default_device() : 0);
#else
  why = "built without the CUDA runtime (offload build without the CUDA toolkit, or a host-only build)";
#endif
  return out;
}

int default_device() {
#ifdef CAPSFLOW_HAVE_OFFLOAD
  return omp_get_default_device();
#else
  return -1;
#endif
}

std::string device_description() {
  const int n = device_count(), d = default_device();
  if (n == 0) {
    return device_host_fallback_for_tests() ? "no device: host fallback, test switch CAPSFLOW_TEST_DEVICE_HOST_FALLBACK"
                                            : "no device";
  }
  std::string text = "device " + std::to_string(d) + " of " + std::to_string(n);
  std::string why;
  for (const GpuInfo& g : cuda_devices(why))
    if (g.index == d) text += ": " + g.name;
  const char* cvd = std::getenv("CUDA_VISIBLE_DEVICES");
  if (cvd != nullptr) text += std::string(", CUDA_VISIBLE_DEVICES=") + cvd;
  return text;
}

std::vector<std::string> device_report() {
  std::vector<std::string> lines;
  char buf[256];
  std::snprintf(buf, sizeof buf, "devices    %d (OpenMP offload devices)", device_count());
  lines.emplace_back(buf);
  if (!device_backend_built()) return lines;
  const char* cvd = std::getenv("CUDA_VISIBLE_DEVICES");
  std::snprintf(buf, sizeof buf, "default    device %d (OMP_DEFAULT_DEVICE; CUDA_VISIBLE_DEVICES=%s)", default_device(),
                cvd ? cvd : "unset");
  lines.emplace_back(buf);
  std::string why;
  const std::vector<GpuInfo> gpus = cuda_devices(why);
  if (gpus.empty()) lines.push_back("gpu        none: " + why);
  for (const GpuInfo& g : gpus) {
    std::snprintf(buf, sizeof buf, "gpu %-6d %s, compute capability %d.%d, memory %s (%s free)", g.index,
                  g.name.c_str(), g.cc_major, g.cc_minor, gib(g.total_bytes).c_str(), gib(g.free_bytes).c_str());
    lines.emplace_back(buf);
  }
  if (device_host_fallback_for_tests() && device_count() == 0)
    lines.push_back("fallback   CAPSFLOW_TEST_DEVICE_HOST_FALLBACK=1: 'device' runs its target regions on the host "
                    "(test-only switch)");
  return lines;
}

std::size_t device_bytes_per_step(std::size_t grid_points, std::size_t nodes) {
  // 12 per grid point: the device global solve's resident forcing, velocity, spectra and coefficients (3 fields each);
  // 120 per node: nodes, targets, elements, spread stencils; plus the global solve's per-mode scratch (<= 256 MiB).
  const std::size_t doubles = 12 * grid_points + 120 * nodes;
  return (doubles * sizeof(double) + (std::size_t(256) << 20)) * 5 / 4;
}

void require_device_memory(std::size_t bytes, const std::string& what) {
#ifdef CAPSFLOW_HAVE_CUDA
  if (device_count() == 0) return;  // host fallback (tests): nothing to allocate on a device
  const int d = default_device();
  cudaDeviceProp p{};
  std::size_t free_b = 0, total_b = 0;
  if (cudaGetDeviceProperties(&p, d) != cudaSuccess || cudaSetDevice(d) != cudaSuccess ||
      cudaMemGetInfo(&free_b, &total_b) != cudaSuccess)
    return;
  if (bytes <= free_b) return;
  throw BackendUnavailable("device out of memory: " + what + " needs about " + gib(bytes) + " on device " +
                           std::to_string(d) + " (" + p.name + "), " + gib(free_b) + " free of " + gib(total_b) +
                           "; use a coarser grid, fewer capsules, a larger card, or the 'threads' backend");
#else
  (void)bytes;
  (void)what;
#endif
}

}  // namespace capsflow
