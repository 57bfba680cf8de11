#pragma once
// Zeroed arrays from fftw_malloc (the alignment FFTW's plans are made with), for the slit plans' grids and spectra.
#include <fftw3.h>

#include <cstddef>
#include <cstring>
#include <new>

namespace capsflow {

template <class T>
T* fftw_alloc_array(std::size_t n) {
  void* p = fftw_malloc(sizeof(T) * n);
  if (!p) throw std::bad_alloc();
  std::memset(p, 0, sizeof(T) * n);
  return static_cast<T*>(p);
}

}  // namespace capsflow
