#pragma once
// Test-only fault injection (issue 55): makes the N-th write, flush, truncate, fsync or rename of the process fail,
// the way SQLite tests its error paths, so that every I/O error path of a command can be exercised one by one.
//
// Read from the environment once, at the first counted call; only the tests set these variables:
//   CAPSFLOW_TEST_FAULT_AT=N        the N-th counted call (N >= 1) and every later one fail, as on a disk that has
//                                   just filled up (or died): nothing after the fault succeeds by luck.
//   CAPSFLOW_TEST_FAULT_ERRNO=E     the error: ENOSPC (the default) or EIO.
//   CAPSFLOW_TEST_FAULT_LOG=FILE    one line per counted call, "N KIND FILE", appended (without counting itself), so a
//                                   test learns how many calls a command makes by running it once without a fault.
// Neither AT nor LOG set: every call passes (one getenv per variable per process).
//
// Counted calls: the HDF5 file driver's write, flush and truncate (every HDF5 file opened through H5File, by a driver
// layered over sec2 that is switched on only in this mode: h5_fault_driver.cpp), and the atomic-file helpers' write,
// fsync and rename (atomic_file.cpp).
#include <cstdint>
#include <string>

namespace capsflow {

// Whether CAPSFLOW_TEST_FAULT_AT or CAPSFLOW_TEST_FAULT_LOG is set.
bool fault_injection_active();

// Counts one call of `kind` ("write", "flush", "truncate", "fsync", "rename") on `file`; returns 0 when it may go on,
// or the errno it must fail with.
int fault_point(const char* kind, const std::string& file);

// The HDF5 file driver that counts (an hid_t; registered at the first call). Only for fault_injection_active().
std::int64_t fault_counting_h5_driver();

}  // namespace capsflow
