// Test-only fault injection (fault_injection.hpp): the call counter, its log, and the counting HDF5 file driver, a
// thin layer over sec2 that passes every call through and fails the counted ones from the N-th on.
#include "host/base/fault_injection.hpp"

#include <fcntl.h>
#include <hdf5.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <new>

namespace capsflow {

namespace {

struct FaultSettings {
  long long at = 0;  // 0: never fail
  int err = ENOSPC;
  std::string log;
  bool active = false;
};

const FaultSettings& settings() {
  static const FaultSettings s = [] {
    FaultSettings f;
    if (const char* v = std::getenv("CAPSFLOW_TEST_FAULT_AT"); v && *v) f.at = std::atoll(v);
    if (const char* v = std::getenv("CAPSFLOW_TEST_FAULT_ERRNO"); v && std::strcmp(v, "EIO") == 0) f.err = EIO;
    if (const char* v = std::getenv("CAPSFLOW_TEST_FAULT_LOG"); v && *v) f.log = v;
    f.active = f.at > 0 || !f.log.empty();
    return f;
  }();
  return s;
}

std::atomic<long long> g_calls{0};

}  // namespace

bool fault_injection_active() { return settings().active; }

int fault_point(const char* kind, const std::string& file) {
  const FaultSettings& s = settings();
  if (!s.active) return 0;
  const long long n = ++g_calls;
  if (!s.log.empty()) {
    // Plain system calls: the log is not one of the counted files.
    const std::string line = std::to_string(n) + " " + kind + " " + file + "\n";
    const int fd = ::open(s.log.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
    if (fd >= 0) {
      [[maybe_unused]] const ssize_t w = ::write(fd, line.data(), line.size());
      ::close(fd);
    }
  }
  return s.at > 0 && n >= s.at ? s.err : 0;
}

// ---------------------------------------------------------------------------------------------------------------
// The counting HDF5 driver: each file holds a sec2 file (opened by H5FDopen) and calls sec2's own functions on it.
// Directly, not through the public H5FD* calls: those enter the library anew and clear its error stack, which would
// lose the message of a failure being unwound (a close after a failed flush).

namespace {

struct CountingFile {
  H5FD_t pub;  // first: HDF5 fills it in and hands back its address
  H5FD_t* inner;
  std::string name;
};

// A file access property list with the sec2 driver, made at registration (outside any HDF5 call).
hid_t g_sec2_fapl = -1;

CountingFile* self(H5FD_t* f) { return reinterpret_cast<CountingFile*>(f); }
const CountingFile* self(const H5FD_t* f) { return reinterpret_cast<const CountingFile*>(f); }

// The error sec2 reports for a failed system call, in its words, so that H5File's message names the system's reason.
herr_t injected(const char* func, const char* kind, const CountingFile* f, int err) {
  H5Epush2(H5E_DEFAULT, __FILE__, func, __LINE__, H5E_ERR_CLS, H5E_IO,
           std::strcmp(kind, "write") == 0 ? H5E_WRITEERROR : H5E_SEEKERROR,
           "file %s failed: filename = '%s', errno = %d, error message = '%s'", kind, f->name.c_str(), err,
           std::strerror(err));
  errno = err;
  return -1;
}

extern "C" {

H5FD_t* counting_open(const char* name, unsigned flags, hid_t, haddr_t maxaddr) {
  H5FD_t* inner = H5FDopen(name, flags, g_sec2_fapl, maxaddr);
  if (!inner) return nullptr;
  auto* f = new (std::nothrow) CountingFile{};
  if (!f) {
    H5FDclose(inner);
    return nullptr;
  }
  f->inner = inner;
  f->name = name;
  return &f->pub;
}

herr_t counting_close(H5FD_t* file) {
  CountingFile* f = self(file);
  const herr_t r = f->inner->cls->close(f->inner);
  delete f;
  return r;
}

int counting_cmp(const H5FD_t* a, const H5FD_t* b) { return self(a)->inner->cls->cmp(self(a)->inner, self(b)->inner); }

herr_t counting_query(const H5FD_t* file, unsigned long* flags) {
  if (file) return self(file)->inner->cls->query(self(file)->inner, flags);
  return H5FDdriver_query(H5FD_SEC2, flags);  // the driver's features, asked before any file is open
}

haddr_t counting_get_eoa(const H5FD_t* file, H5FD_mem_t type) {
  return self(file)->inner->cls->get_eoa(self(file)->inner, type);
}

herr_t counting_set_eoa(H5FD_t* file, H5FD_mem_t type, haddr_t addr) {
  return self(file)->inner->cls->set_eoa(self(file)->inner, type, addr);
}

haddr_t counting_get_eof(const H5FD_t* file, H5FD_mem_t type) {
  return self(file)->inner->cls->get_eof(self(file)->inner, type);
}

herr_t counting_get_handle(H5FD_t* file, hid_t fapl, void** handle) {
  return self(file)->inner->cls->get_handle(self(file)->inner, fapl, handle);
}

herr_t counting_read(H5FD_t* file, H5FD_mem_t type, hid_t dxpl, haddr_t addr, size_t size, void* buf) {
  return self(file)->inner->cls->read(self(file)->inner, type, dxpl, addr, size, buf);
}

herr_t counting_write(H5FD_t* file, H5FD_mem_t type, hid_t dxpl, haddr_t addr, size_t size, const void* buf) {
  CountingFile* f = self(file);
  if (const int err = fault_point("write", f->name)) return injected("counting_write", "write", f, err);
  return f->inner->cls->write(f->inner, type, dxpl, addr, size, buf);
}

herr_t counting_flush(H5FD_t* file, hid_t dxpl, hbool_t closing) {
  CountingFile* f = self(file);
  if (const int err = fault_point("flush", f->name)) return injected("counting_flush", "flush", f, err);
  return f->inner->cls->flush ? f->inner->cls->flush(f->inner, dxpl, closing) : 0;
}

herr_t counting_truncate(H5FD_t* file, hid_t dxpl, hbool_t closing) {
  CountingFile* f = self(file);
  if (const int err = fault_point("truncate", f->name)) return injected("counting_truncate", "truncate", f, err);
  return f->inner->cls->truncate(f->inner, dxpl, closing);
}

herr_t counting_lock(H5FD_t* file, hbool_t rw) {
  const H5FD_t* in = self(file)->inner;
  return in->cls->lock ? in->cls->lock(self(file)->inner, rw) : 0;
}
herr_t counting_unlock(H5FD_t* file) {
  const H5FD_t* in = self(file)->inner;
  return in->cls->unlock ? in->cls->unlock(self(file)->inner) : 0;
}

}  // extern "C"

H5FD_class_t counting_class() {
  H5FD_class_t c{};
  c.name = "capsflow_fault_counting";
  c.maxaddr = static_cast<haddr_t>(INT64_MAX);  // sec2's: the largest off_t
  c.fc_degree = H5F_CLOSE_WEAK;
  c.open = counting_open;
  c.close = counting_close;
  c.cmp = counting_cmp;
  c.query = counting_query;
  c.get_eoa = counting_get_eoa;
  c.set_eoa = counting_set_eoa;
  c.get_eof = counting_get_eof;
  c.get_handle = counting_get_handle;
  c.read = counting_read;
  c.write = counting_write;
  c.flush = counting_flush;
  c.truncate = counting_truncate;
  c.lock = counting_lock;
  c.unlock = counting_unlock;
  const H5FD_mem_t map[H5FD_MEM_NTYPES] = H5FD_FLMAP_DICHOTOMY;  // sec2's
  std::memcpy(c.fl_map, map, sizeof map);
  return c;
}

}  // namespace

std::int64_t fault_counting_h5_driver() {
  static const hid_t id = [] {
    g_sec2_fapl = H5Pcreate(H5P_FILE_ACCESS);
    if (g_sec2_fapl < 0 || H5Pset_fapl_sec2(g_sec2_fapl) < 0) return hid_t{-1};
    static const H5FD_class_t cls = counting_class();
    return H5FDregister(&cls);
  }();
  return id;
}

}  // namespace capsflow
