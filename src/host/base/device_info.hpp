#pragma once
// What the device backend runs on: the OpenMP offload devices, the CUDA GPUs behind them (name, memory), and a
// clear error before a run that would not fit in device memory (libgomp and libomptarget abort the whole process
// on a failed device allocation, with a one-line runtime message that names neither the run nor the remedy).
//
// Device selection: the run uses the OpenMP default device (omp_get_default_device(): 0 unless OMP_DEFAULT_DEVICE is
// set). Under Slurm, `srun --gpus-per-task=1` sets CUDA_VISIBLE_DEVICES per task, so each task sees its own GPU as
// device 0; the OpenMP runtime and the CUDA runtime number the visible devices alike (docs/device.md).
#include <cstddef>
#include <string>
#include <vector>

namespace capsflow {

struct GpuInfo {
  int index = 0;                 // CUDA device number among the visible devices (= OpenMP device number)
  std::string name;              // e.g. "NVIDIA H100 80GB HBM3"
  int cc_major = 0, cc_minor = 0;
  std::size_t total_bytes = 0;   // device memory
  std::size_t free_bytes = 0;    // free now (0 when it could not be read)
};

// Makes the default device's primary CUDA context current on this thread, once per process, where the CUDA runtime is
// linked, a GPU is visible and no context is current yet (else nothing). Called before the OpenMP runtime opens the
// device (backend_available for 'device'): libgomp then adopts that context instead of creating its own, so the OpenMP
// runtime, the CUDA runtime (GPU names, the memory check: cudaSetDevice) and cuFFT (the device global solve, on the
// OpenMP runtime's device pointers) share one context. Two contexts would not see each other's memory.
void share_cuda_primary_context();

// True when this binary was linked with the CUDA runtime (offload builds that found the CUDA toolkit at configure time).
bool cuda_runtime_linked();

// The GPUs the CUDA runtime sees; empty with a reason in `why` (no CUDA runtime linked, no driver, no device).
std::vector<GpuInfo> cuda_devices(std::string& why);

// The OpenMP device the device backend uses (omp_get_default_device()), -1 in builds without offload.
int default_device();

// One line for run logs: "device 0 of 1: NVIDIA H100 80GB HBM3, CUDA_VISIBLE_DEVICES=3", or the host fallback.
std::string device_description();

// Lines for `capsflow info`: devices, the default device, CUDA_VISIBLE_DEVICES, each GPU with its memory.
std::vector<std::string> device_report();

// Device memory a step needs, with a quarter on top for the runtime: the global solve's resident grids and its
// per-mode scratch (SlitStokesPlanDevice), plus the node, element and stencil arrays the local sums map per call.
std::size_t device_bytes_per_step(std::size_t grid_points, std::size_t nodes);

// Throws BackendUnavailable when the default device's free memory (where it can be read) is below `bytes`:
// "device out of memory: <what> needs about X GiB on device d (<name>), Y GiB free of Z GiB; ...".
// No-op where the memory cannot be read (no CUDA runtime linked, host fallback).
void require_device_memory(std::size_t bytes, const std::string& what);

}  // namespace capsflow
