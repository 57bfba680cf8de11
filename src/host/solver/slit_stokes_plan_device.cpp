// The implementation of slit_stokes_plan_device.hpp: SlitStokesPlanDevice, the device twin of SlitStokesPlan.
#include "host/solver/slit_stokes_plan_device.hpp"

#include <fftw3.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <new>
#include <stdexcept>
#include <string>

#include "host/base/backend_select.hpp"
#include "host/base/errors.hpp"
#include "host/solver/slit_stokes_plan.hpp"
#include "host/base/stopwatch.hpp"
#include "kernels/dispatch.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/mode_solve_device.hpp"

#ifdef CAPSFLOW_HAVE_OPENMP
#include <omp.h>
#endif
#ifdef CAPSFLOW_HAVE_CUFFT
#include <cuda_runtime_api.h>
#include <cufft.h>
#include <dlfcn.h>
#endif

namespace capsflow {
namespace {

double* fftw_alloc_doubles(std::size_t n) {
  void* p = fftw_malloc(sizeof(double) * (n > 0 ? n : 1));
  if (!p) throw std::bad_alloc();
  std::memset(p, 0, sizeof(double) * n);
  return static_cast<double*>(p);
}

// Per-launch scratch of the mode solve: enough modes to fill a GPU, at most about 256 MiB.
std::size_t mode_chunk(std::size_t modes, int N) {
  const std::size_t per_mode = slit_mode_scratch_doubles(N) * sizeof(double);
  std::size_t chunk = (std::size_t(256) << 20) / per_mode;
  if (chunk < 1024) chunk = 1024;
  return chunk < modes ? chunk : modes;
}

// True when target regions run on the host (no device, or the OpenMP runtime fell back): the one question that
// picks FFTW or cuFFT.
bool target_runs_on_host() {
  int on_host = 1;
#if defined(CAPSFLOW_HAVE_OFFLOAD)
#pragma omp target map(tofrom : on_host)
  { on_host = omp_is_initial_device(); }
#endif
  return on_host != 0;
}

#ifdef CAPSFLOW_HAVE_CUFFT
// cuFFT, loaded at run time: the GPU machine's own libcufft (about 280 MB, never packed; docs/device.md), so binaries
// start where it is missing and only a device global solve on a GPU needs it.
struct CufftApi {
  decltype(&cufftPlanMany) plan_many = nullptr;
  decltype(&cufftExecD2Z) exec_d2z = nullptr;
  decltype(&cufftExecZ2D) exec_z2d = nullptr;
  decltype(&cufftDestroy) destroy = nullptr;
};

const CufftApi& cufft_api() {
  static std::mutex m;
  static CufftApi api;
  static bool loaded = false;
  std::lock_guard<std::mutex> lock(m);
  if (loaded) return api;
  std::string tried;
  void* lib = nullptr;
  // The user's choice, the soname (LD_LIBRARY_PATH, the loader cache), the library found at configure time, and the
  // usual toolkit location on a machine whose CUDA lives elsewhere than here.
  const char* env = std::getenv("CAPSFLOW_CUFFT_LIBRARY");
  const std::string usual = std::string("/usr/local/cuda/lib64/") + CAPSFLOW_CUFFT_SONAME;
  for (const char* name : {env, CAPSFLOW_CUFFT_SONAME, CAPSFLOW_CUFFT_LIBRARY, usual.c_str()}) {
    if (name == nullptr || *name == '\0') continue;
    tried += std::string(tried.empty() ? "" : ", ") + name;
    lib = dlopen(name, RTLD_NOW | RTLD_LOCAL);
    if (lib) break;
  }
  if (!lib)
    throw BackendUnavailable("device global solve: cannot load cuFFT (tried " + tried +
                             "); put the CUDA libraries on LD_LIBRARY_PATH or set CAPSFLOW_CUFFT_LIBRARY");
  api.plan_many = reinterpret_cast<decltype(api.plan_many)>(dlsym(lib, "cufftPlanMany"));
  api.exec_d2z = reinterpret_cast<decltype(api.exec_d2z)>(dlsym(lib, "cufftExecD2Z"));
  api.exec_z2d = reinterpret_cast<decltype(api.exec_z2d)>(dlsym(lib, "cufftExecZ2D"));
  api.destroy = reinterpret_cast<decltype(api.destroy)>(dlsym(lib, "cufftDestroy"));
  if (!api.plan_many || !api.exec_d2z || !api.exec_z2d || !api.destroy)
    throw BackendUnavailable("device global solve: " + tried + " lacks cufftPlanMany/ExecD2Z/ExecZ2D/Destroy");
  loaded = true;
  return api;
}

void cufft_check(cufftResult r, const char* what) {
  if (r != CUFFT_SUCCESS)
    throw std::runtime_error(std::string("device global solve: ") + what + " failed (cufftResult " +
                             std::to_string(static_cast<int>(r)) + ")");
}

void cuda_check(cudaError_t e, const char* what) {
  if (e != cudaSuccess)
    throw std::runtime_error(std::string("device global solve: ") + what + ": " + cudaGetErrorString(e));
}
#endif

}  // namespace

// The plane FFTs, in one place: cuFFT on the arrays' device addresses (GPU), or FFTW on them where the host can
// address them (the host fallback, where they are the host arrays, and the host-memory test device).
struct SlitStokesPlanDevice::Fft {
  bool gpu = false;
  int nx = 0, nz = 0, np = 0;
  std::size_t plane = 0, cplane = 0;
  // FFTW: one 2D plan per plane shape, executed plane by plane (unaligned: plane offsets and other arrays).
  fftw_plan fwd = nullptr, inv = nullptr;
#ifdef CAPSFLOW_HAVE_CUFFT
  // cuFFT: batched over every plane of the three fields (and the six wall maps), on the runtime's default stream.
  cufftHandle cfwd = 0, cinv = 0, cwall = 0;
  bool have_cfwd = false, have_cinv = false, have_cwall = false;
#endif
  double *d_force = nullptr, *d_vel = nullptr, *d_spec = nullptr, *d_wall = nullptr, *d_wspec = nullptr;

  ~Fft() {
    {
      std::lock_guard<std::mutex> lock(fftw_planner_mutex());
      if (fwd) fftw_destroy_plan(fwd);
      if (inv) fftw_destroy_plan(inv);
    }
#ifdef CAPSFLOW_HAVE_CUFFT
    if (have_cfwd || have_cinv || have_cwall) {  // then cuFFT is loaded
      const CufftApi& api = cufft_api();
      if (have_cfwd) api.destroy(cfwd);
      if (have_cinv) api.destroy(cinv);
      if (have_cwall) api.destroy(cwall);
    }
#endif
  }
};

SlitStokesPlanDevice::SlitStokesPlanDevice(const SlitGeometry& geo, const GgemGrid& grid)
    : geo_(geo),
      nx_(grid.nx),
      nz_(grid.nz),
      N_(grid.ny),
      nzh_(grid.nz / 2 + 1),
      mirror_((require_built(Backend::Device, "SlitStokesPlanDevice"), Backend::Device)) {
  try {
    setup();
  } catch (...) {
    release();
    throw;
  }
}

void SlitStokesPlanDevice::setup() {
  plane_ = static_cast<std::size_t>(nx_) * nz_;
  cplane_ = static_cast<std::size_t>(nx_) * nzh_;
  const std::size_t np = N_ + 1;
  host_fallback_ = target_runs_on_host();
  const bool fftw_on_device = host_fallback_ || device_memory_host_addressable_for_tests();
#ifndef CAPSFLOW_HAVE_CUFFT
  if (!fftw_on_device)
    throw BackendUnavailable(
        "device global solve: this offload build has no cuFFT (the CUDA toolkit with cuFFT was not found at configure "
        "time; set CUDAToolkit_ROOT and rebuild), so it cannot run the global solve on the GPU");
#endif

  y_.resize(np);
  for (int j = 0; j <= N_; ++j) y_[j] = 0.5 * geo_.H * (1.0 - std::cos(kPi * j / N_));
  y_[0] = 0.0;
  y_[N_] = geo_.H;
  slit_homogeneous_solutions(geo_, nx_, nz_, N_, Backend::Threads, hom_phi_, hom_psi_, hom_minv_);
  dct_.resize(np * np);
  dct1_matrix(N_, dct_.data());

  force_ = fftw_alloc_doubles(3 * grid_size());
  vel_ = fftw_alloc_doubles(3 * grid_size());
  spec_ = fftw_alloc_doubles(2 * 3 * np * cplane_);
  coef_ = fftw_alloc_doubles(2 * 3 * np * cplane_);
  wall_ = fftw_alloc_doubles(6 * plane_);
  wspec_ = fftw_alloc_doubles(2 * 6 * cplane_);
  // Mapped once, for the plan's lifetime (the homogeneous solutions and the DCT matrix are the one push they get).
  mirror_.attach(force_, 3 * grid_size());
  mirror_.attach(vel_, 3 * grid_size());
  mirror_.attach(spec_, 2 * 3 * np * cplane_);
  mirror_.attach(coef_, 2 * 3 * np * cplane_);
  mirror_.attach(wall_, 6 * plane_);
  mirror_.attach(wspec_, 2 * 6 * cplane_);
  mirror_.attach(y_.data(), y_.size());
  mirror_.attach(hom_phi_.data(), hom_phi_.size());
  mirror_.attach(hom_psi_.data(), hom_psi_.size());
  mirror_.attach(hom_minv_.data(), hom_minv_.size());
  mirror_.attach(dct_.data(), dct_.size());

  chunk_ = mode_chunk(cplane_, N_);
#ifdef CAPSFLOW_HAVE_OPENMP
  scratch_device_ = host_fallback_ ? omp_get_initial_device() : omp_get_default_device();
  scratch_ = static_cast<double*>(
      omp_target_alloc(chunk_ * slit_mode_scratch_doubles(N_) * sizeof(double), scratch_device_));
#endif
  if (!scratch_)
    throw BackendUnavailable("device out of memory: the global solve's per-mode scratch (" +
                             std::to_string(chunk_ * slit_mode_scratch_doubles(N_) * sizeof(double) >> 20) +
                             " MiB) does not fit on the device");

  fft_ = std::make_unique<Fft>();
  Fft& f = *fft_;
  f.nx = nx_;
  f.nz = nz_;
  f.np = static_cast<int>(np);
  f.plane = plane_;
  f.cplane = cplane_;
  f.gpu = !fftw_on_device;
  // The arrays' device addresses (the host arrays themselves on the host fallback).
  f.d_force = mirror_.device_ptr(force_);
  f.d_vel = mirror_.device_ptr(vel_);
  f.d_spec = mirror_.device_ptr(spec_);
  f.d_wall = mirror_.device_ptr(wall_);
  f.d_wspec = mirror_.device_ptr(wspec_);
  if (!f.gpu) {
    std::lock_guard<std::mutex> lock(fftw_planner_mutex());
    auto* cs = reinterpret_cast<fftw_complex*>(spec_);
    f.fwd = fftw_plan_dft_r2c_2d(nx_, nz_, force_, cs, FFTW_ESTIMATE | FFTW_UNALIGNED);
    f.inv = fftw_plan_dft_c2r_2d(nx_, nz_, cs, vel_, FFTW_ESTIMATE | FFTW_UNALIGNED | FFTW_DESTROY_INPUT);
    if (!f.fwd || !f.inv) throw std::runtime_error("FFTW planning failed");
    return;
  }
#ifdef CAPSFLOW_HAVE_CUFFT
  const CufftApi& api = cufft_api();
  // cuFFT runs in the CUDA context current on this thread; after the target regions above that is the OpenMP
  // runtime's (libgomp makes its context current, and the CUDA runtime adopts a current context). Check that it sees
  // the mapped arrays before trusting it.
  cudaPointerAttributes attr{};
  if (cudaPointerGetAttributes(&attr, f.d_force) != cudaSuccess || attr.type != cudaMemoryTypeDevice)
    throw BackendUnavailable(
        "device global solve: the CUDA runtime does not see the OpenMP runtime's device arrays (two CUDA contexts: "
        "was a target region run before backend_available(device)?), so cuFFT cannot work on them");
  int n[2] = {nx_, nz_};
  int rembed[2] = {nx_, nz_}, cembed[2] = {nx_, nzh_};
  const int batch = 3 * static_cast<int>(np);
  cufft_check(api.plan_many(&f.cfwd, 2, n, rembed, 1, static_cast<int>(plane_), cembed, 1, static_cast<int>(cplane_),
                            CUFFT_D2Z, batch),
              "cufftPlanMany (forward)");
  f.have_cfwd = true;
  cufft_check(api.plan_many(&f.cinv, 2, n, cembed, 1, static_cast<int>(cplane_), rembed, 1, static_cast<int>(plane_),
                            CUFFT_Z2D, batch),
              "cufftPlanMany (inverse)");
  f.have_cinv = true;
  cufft_check(api.plan_many(&f.cwall, 2, n, rembed, 1, static_cast<int>(plane_), cembed, 1, static_cast<int>(cplane_),
                            CUFFT_D2Z, 6),
              "cufftPlanMany (walls)");
  f.have_cwall = true;
#endif
}

SlitStokesPlanDevice::~SlitStokesPlanDevice() { release(); }

void SlitStokesPlanDevice::release() noexcept {
  fft_.reset();
#ifdef CAPSFLOW_HAVE_OPENMP
  if (scratch_) omp_target_free(scratch_, scratch_device_);
#endif
  for (double* p : {force_, vel_, spec_, coef_, wall_, wspec_, y_.data(), hom_phi_.data(), hom_psi_.data(),
                    hom_minv_.data(), dct_.data()}) {
    if (p) {
      try {
        mirror_.detach(p);
      } catch (const std::logic_error&) {
        // not attached: the constructor stopped before
      }
    }
  }
  for (double* p : {force_, vel_, spec_, coef_, wall_, wspec_})
    if (p) fftw_free(p);
  force_ = vel_ = spec_ = coef_ = wall_ = wspec_ = scratch_ = nullptr;
}

const char* SlitStokesPlanDevice::fft_name() const {
  if (fft_ && fft_->gpu) return "cuFFT";
  return host_fallback_ ? "FFTW, host fallback" : "FFTW on the device's arrays (host-memory test device)";
}

SlitGridView SlitStokesPlanDevice::view() const {
  return slit_grid_view(geo_, nx_, nz_, N_, y_.data());
}

void SlitStokesPlanDevice::zero_forcing_and_walls() {
#ifdef CAPSFLOW_HAVE_OFFLOAD
  double* f = force_;
  double* w = wall_;
  const long long nf = static_cast<long long>(3 * grid_size()), nw = static_cast<long long>(6 * plane_);
#pragma omp target teams distribute parallel for map(tofrom : f[0:nf])
  for (long long t = 0; t < nf; ++t) f[t] = 0.0;
#pragma omp target teams distribute parallel for map(tofrom : w[0:nw])
  for (long long t = 0; t < nw; ++t) w[t] = 0.0;
#endif
}

void SlitStokesPlanDevice::set_walls_negated(const double* const wall_local_u[3]) {
#ifdef CAPSFLOW_HAVE_OFFLOAD
  double* w = wall_;
  const double* u0 = wall_local_u[0];
  const double* u1 = wall_local_u[1];
  const double* u2 = wall_local_u[2];
  const std::size_t pl = plane_;
  const long long n = static_cast<long long>(2 * plane_);
  const std::size_t nw = 6 * plane_;
#pragma omp target teams distribute parallel for map(to : u0[0:n], u1[0:n], u2[0:n]) map(tofrom : w[0:nw])
  for (long long t = 0; t < n; ++t) {
    const std::size_t side = static_cast<std::size_t>(t) / pl, p = static_cast<std::size_t>(t) % pl;
    w[(side * 3 + 0) * pl + p] = -u0[t];
    w[(side * 3 + 1) * pl + p] = -u1[t];
    w[(side * 3 + 2) * pl + p] = -u2[t];
  }
#else
  (void)wall_local_u;
#endif
}

void SlitStokesPlanDevice::fft_forward() {
  Fft& f = *fft_;
  if (!f.gpu) {
    const int planes = 3 * f.np;
#pragma omp parallel for schedule(static)
    for (int j = 0; j < planes; ++j)
      fftw_execute_dft_r2c(f.fwd, f.d_force + j * plane_, reinterpret_cast<fftw_complex*>(f.d_spec) + j * cplane_);
#pragma omp parallel for schedule(static)
    for (int j = 0; j < 6; ++j)
      fftw_execute_dft_r2c(f.fwd, f.d_wall + j * plane_, reinterpret_cast<fftw_complex*>(f.d_wspec) + j * cplane_);
    return;
  }
#ifdef CAPSFLOW_HAVE_CUFFT
  // The target regions before this one are synchronous (no nowait): their writes are complete here.
  const CufftApi& api = cufft_api();
  cufft_check(api.exec_d2z(f.cfwd, f.d_force, reinterpret_cast<cufftDoubleComplex*>(f.d_spec)), "cufftExecD2Z");
  cufft_check(api.exec_d2z(f.cwall, f.d_wall, reinterpret_cast<cufftDoubleComplex*>(f.d_wspec)),
              "cufftExecD2Z (walls)");
  // cuFFT runs asynchronously on the default stream; the mode kernel (the OpenMP runtime's stream) must see its output.
  cuda_check(cudaDeviceSynchronize(), "cudaDeviceSynchronize after the forward FFTs");
#endif
}

void SlitStokesPlanDevice::fft_inverse() {
  Fft& f = *fft_;
  if (!f.gpu) {
    const int planes = 3 * f.np;
#pragma omp parallel for schedule(static)
    for (int j = 0; j < planes; ++j)
      fftw_execute_dft_c2r(f.inv, reinterpret_cast<fftw_complex*>(f.d_spec) + j * cplane_, f.d_vel + j * plane_);
    return;
  }
#ifdef CAPSFLOW_HAVE_CUFFT
  const CufftApi& api = cufft_api();
  cufft_check(api.exec_z2d(f.cinv, reinterpret_cast<cufftDoubleComplex*>(f.d_spec), f.d_vel), "cufftExecZ2D");
  cuda_check(cudaDeviceSynchronize(), "cudaDeviceSynchronize after the inverse FFTs");
#endif
}

void SlitStokesPlanDevice::solve() {
  auto t0 = std::chrono::steady_clock::now();
  fft_forward();
  t_transform_ = seconds_since(t0);
  auto t1 = std::chrono::steady_clock::now();
  SlitModeGrid g{nx_, nz_, N_, geo_.H, geo_.Lx, geo_.Lz};
  slit_solve_modes_device(g, spec_, coef_, wspec_, hom_phi_.data(), hom_psi_.data(), hom_minv_.data(), dct_.data(),
                          scratch_, chunk_);
  t_modes_ = seconds_since(t1);
  auto t2 = std::chrono::steady_clock::now();
  fft_inverse();
  t_transform_ += seconds_since(t2);
}

void SlitStokesPlanDevice::push_forcing() { mirror_.push(force_, 3 * grid_size()); }
void SlitStokesPlanDevice::push_walls() { mirror_.push(wall_, 6 * plane_); }
void SlitStokesPlanDevice::pull_forcing() { mirror_.pull(force_, 3 * grid_size()); }
void SlitStokesPlanDevice::pull_velocity() { mirror_.pull(vel_, 3 * grid_size()); }

}  // namespace capsflow
