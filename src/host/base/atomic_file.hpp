#pragma once
// Safe creation and replacement of output files.
//
// A run writes several files (the HDF5 series, checkpoints, the XDMF index). Two failure modes are guarded
// against here:
//   1. clobbering the output of an earlier run by accident: ensure_can_create() refuses an existing file
//      unless the caller says overwrite, and checks the directory up front, so that a run fails in its
//      first second rather than after hours of computing;
//   2. a crash (or an exception) while a file is being rewritten: replace_file_atomically() and
//      write_file_atomically() write a temporary next to the target, fsync it, rename it over the target
//      and fsync the directory. rename(2) within one directory is atomic on POSIX file systems, so a reader
//      (or a restart) sees either the complete old file or the complete new one, never a torn one.
//
// Usage:
//   ensure_can_create(out_dir / "run.h5", cfg.overwrite);             // InputError: user-fixable
//   write_file_atomically(out_dir / "run.xdmf", xml_text);
//   write_file_atomically(out_dir / "summary.csv", [&](std::ostream& os) { os << ...; });
//   replace_file_atomically(ckpt, [&](const std::filesystem::path& tmp) { some_library_write(tmp); });
//
// Limitations: the replaced file gets fresh permissions (umask), not those of the file it replaces; no
// protection against two processes writing the same target concurrently (the last rename wins, each
// temporary has its own unique name so they never corrupt each other).
#include <filesystem>
#include <utility>
#include <vector>
#include <functional>
#include <iosfwd>
#include <string>
#include <string_view>

namespace capsflow {

// Throws InputError (naming the file) if `path` cannot be created as a new output file: it exists and
// `overwrite` is false, it exists and is a directory, its directory does not exist, or the directory is
// not writable. Creates nothing.
// Also refuses (check_output_kind) a symbolic link as the last component and anything but a regular file.
void ensure_can_create(const std::filesystem::path& path, bool overwrite);

// InputError if `path` is a symbolic link (an output is a regular file; linked directories above it are fine) or
// exists and is not a regular file (a device node, a FIFO, a socket, a directory). --force does not change this.
void check_output_kind(const std::filesystem::path& path);

// InputError if the output `path` is the same file as one of the run's inputs (each given as {path, what it is,
// e.g. "configuration"}): --force must not replace the file being read.
void check_not_an_input(const std::filesystem::path& path,
                        const std::vector<std::pair<std::filesystem::path, std::string>>& inputs);

// A fresh temporary name in the same directory as `path` (same file system, so rename is atomic):
// "<dir>/.<name>.tmp.<pid>.<counter>". Unique within the process and across processes; the file is not
// created. Hidden (leading dot) so that globs like *.h5 do not pick up a half-written file.
std::string temp_path_for(const std::filesystem::path& path);

// Removes the temporaries temp_path_for(path) made by processes that no longer exist (killed while replacing
// `path`). A caller that holds the right to write `path` (the run's marker) calls it before its first write.
void remove_stale_temporaries(const std::filesystem::path& path);

// Calls produce(tmp) to create the file `tmp` (a temp_path_for(path)), then fsyncs it, renames it onto
// `path` and fsyncs the directory. If produce throws, or any step before the rename fails, the temporary is
// removed, `path` is left untouched and the exception propagates (std::system_error for file-system failures).
// When only the directory's fsync fails, `path` already is the new, complete file (a rename cannot be undone) and
// the exception still propagates: a caller that cleans up after a failure must look at what is on disk (issue 55).
void replace_file_atomically(const std::filesystem::path& path,
                             const std::function<void(const std::filesystem::path& tmp)>& produce);

// Atomically replaces (or creates) `path` with `content`.
void write_file_atomically(const std::filesystem::path& path, std::string_view content);

// Atomically replaces (or creates) `path` with what `writer` puts on the stream (binary mode). A stream
// left in a failed state counts as an error.
void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& writer);

// fsync(2) of a file or a directory; throws std::system_error naming the path on failure.
void fsync_path(const std::filesystem::path& path);

}  // namespace capsflow
