#pragma once
// H5File: a small RAII wrapper over the HDF5 C API for the run's output, checkpoints and restarts.
//
// Conventions (see docs/output_format.md):
//   - Objects are named by absolute HDF5 paths ("/series/time"); missing parent groups are created.
//   - Fixed datasets are written once (write), extendable ones grow along their first dimension (append):
//     a record is one slice [inner dims]; the dataset is created, chunked with an unlimited first dimension,
//     on the first append. truncate() shrinks the first dimension (restart from an older checkpoint).
//     set_compression(level) makes extendable datasets created afterwards shuffle + deflate their chunks (lossless:
//     doubles still round-trip bit for bit), one record per chunk; fixed datasets stay contiguous.
//   - Numbers are stored in native little-endian IEEE / two's-complement types, so doubles round-trip bit
//     for bit (NaN payloads and -0 included). Reading converts to the requested type as HDF5 does.
//   - Strings (attributes and string datasets) are scalar, variable-length, UTF-8: h5py reads attributes
//     as str and datasets with .asstr()[()].
//   - Every HDF5 failure becomes an exception: H5Error (a bug or an environment problem) naming the file,
//     the object and HDF5's own innermost message; problems the user can fix (output exists, input file
//     missing or not HDF5) are InputError. HDF5's automatic printing of its error stack is switched off for
//     the whole process the first time an H5File is made.
//   - flush() makes what was written so far readable even if the process dies before close (the file is
//     written with the default, 1.8-compatible format, which carries no "open for writing" flag).
//
// Usage sketch (the run loop):
//   auto out = H5File::create(dir / "run.h5", cfg.overwrite);
//   out.set_attribute("/", "capsflow_version", CAPSFLOW_VERSION);
//   out.write_string("/config/text", config_text);
//   out.write("/mesh/triangles_all", {ntri, 3}, tri.data());
//   for each step:   out.append("/series/time", &t, {});
//                    out.append("/series/centroid", c.data(), {np, 3});
//   every frame:     out.append("/frames/positions", x.data(), {nnodes, 3}); out.flush();
//
//   write_checkpoint_atomically(dir / "checkpoint.h5", [&](H5File& ck) {
//     ck.write("/state/positions", {nnodes, 3}, x.data());
//     write_rng_state(ck, "/state/rng", rng);
//   });
#include <cstdint>
#include <filesystem>
#include <functional>
#include <random>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace capsflow {

// An HDF5 operation failed for a reason that is not the user's input (disk full, corrupt file, a type or
// shape mismatch in the program's own calls).
struct H5Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A whole dataset read back: its shape (empty for a scalar) and its elements in row-major order.
template <class T>
struct H5Array {
  std::vector<std::size_t> dims;
  std::vector<T> data;
};

// ReadShared: read-only without HDF5's file lock, so a file that a live run holds open for writing can be read
// between its flushes (what `capsflow analyze` and `capsflow sweep --status` use).
enum class H5Access { ReadOnly, ReadWrite, ReadShared };

class H5File {
 public:
  static constexpr std::size_t kAllRecords = static_cast<std::size_t>(-1);
  // Creates a new file. Refuses (InputError) an existing file unless `overwrite`; the check is made by HDF5
  // itself (H5F_ACC_EXCL), so it cannot race with another process creating the same file.
  static H5File create(const std::filesystem::path& path, bool overwrite = false);
  // Opens an existing file. InputError if it does not exist or is not an HDF5 file.
  static H5File open(const std::filesystem::path& path, H5Access access = H5Access::ReadOnly);

  H5File(H5File&& other) noexcept;
  H5File& operator=(H5File&& other) noexcept;
  H5File(const H5File&) = delete;
  H5File& operator=(const H5File&) = delete;
  ~H5File();  // closes without throwing; call close() to see errors

  const std::filesystem::path& path() const { return path_; }
  bool is_open() const { return id_ >= 0; }
  bool read_only() const { return read_only_; }

  // Writes all buffered data and metadata to disk (H5Fflush, global scope).
  void flush();
  // The end of the space HDF5 has allocated in the file, as its superblock records it (H5Fget_eoa). Every flush and
  // close makes the file exactly this long; a longer file was left by a flush that did not finish (a write that failed,
  // a kill), whose index may point into the bytes past this end that the next allocation would overwrite.
  std::uint64_t allocated_end() const;
  // Closes the file (and every object still open in it). Idempotent.
  void close();

  // --- structure --------------------------------------------------------------------------------
  // Creates the group and any missing parents; an existing group is fine.
  void create_group(const std::string& path);
  // True if every component of `path` exists ("/" always exists).
  bool exists(const std::string& path) const;
  // Names of the objects directly in a group, in name order.
  std::vector<std::string> children(const std::string& group) const;
  // Shape of a dataset.
  std::vector<std::size_t> dims(const std::string& path) const;
  // The stored element type of a dataset: "float64", "float32", "int64", "int32", ... ("int8".."int64",
  // "uint8".."uint64", "float16".."float64"), "string", or "other" (read() converts numbers silently; a check that
  // a file holds what its writer wrote asks this).
  std::string element_type(const std::string& path) const;
  // Absolute paths of every dataset at or below `group` (virtual ones included), in HDF5's visiting order.
  std::vector<std::string> datasets(const std::string& group = "/") const;
  // Names of the filters of a dataset's chunks in pipeline order ("shuffle", "deflate"); empty when none.
  std::vector<std::string> filters(const std::string& path) const;

  // --- compression of extendable datasets --------------------------------------------------------
  // Deflate level 0..9 (std::invalid_argument otherwise) for the extendable datasets created from now on: 0 = no
  // filter; 1..9 = byte shuffle, then deflate at that level, with one record per chunk whatever chunk_records
  // says. Why one: a compressed chunk changes size when a record is added to it, so HDF5 writes it whole at a new
  // place; a process killed during that write can leave the index pointing at a torn chunk, losing the records the
  // chunk already held (and making truncate() fail to inflate it). A chunk of one record is written once. An
  // unfiltered chunk is rewritten in place with the old records' bytes unchanged, so many records may share one.
  // Existing datasets keep the filters they were made with.
  void set_compression(int deflate_level);
  int compression() const { return deflate_level_; }

  // --- attributes on a group or dataset ("/" is the file itself) ---------------------------------
  // Integral values are stored as int64, floating ones as double, anything convertible to string_view as
  // a string. An existing attribute of that name is replaced.
  template <class T>
  void set_attribute(const std::string& object, const std::string& name, const T& value);
  bool has_attribute(const std::string& object, const std::string& name) const;
  // Removes the attribute `name` of `object`; nothing happens when it does not exist.
  void remove_attribute(const std::string& object, const std::string& name);
  // T is double, std::int64_t or std::string.
  template <class T>
  T attribute(const std::string& object, const std::string& name) const;

  // --- fixed datasets ------------------------------------------------------------------------------
  // T is double, float, std::int32_t or std::int64_t. dims of any rank (empty = scalar, zeros allowed); `data`
  // holds prod(dims) elements in row-major order. H5Error if the dataset already exists.
  template <class T>
  void write(const std::string& path, const std::vector<std::size_t>& dims, const T* data);
  template <class T>
  void write(const std::string& path, const std::vector<std::size_t>& dims, const std::vector<T>& data);
  // A scalar UTF-8 string dataset (e.g. the full text of the configuration). No embedded NULs.
  void write_string(const std::string& path, std::string_view text);
  std::string read_string(const std::string& path) const;

  // --- extendable datasets (unlimited first dimension) -------------------------------------------
  // Creates an empty dataset [0, inner...] of element type T. chunk_records = 0 picks ~64 KiB chunks; a compressed
  // dataset (set_compression) has one record per chunk.
  template <class T>
  void create_extendable(const std::string& path, const std::vector<std::size_t>& inner_dims,
                         std::size_t chunk_records = 0);
  // Appends `count` records of shape inner_dims (count * prod(inner_dims) elements at `data`), creating
  // the dataset on the first call. H5Error if the existing dataset is not extendable or its inner shape
  // differs.
  template <class T>
  void append(const std::string& path, const T* data, const std::vector<std::size_t>& inner_dims,
              std::size_t count = 1);
  // A virtual dataset [inner...] at `path` that shows record `index` of the extendable numeric dataset `source`,
  // with its element type (no copy: HDF5 reads the source). Missing parent groups are created. H5Error if `path` exists.
  void create_record_view(const std::string& path, const std::string& source, std::size_t index,
                          const std::vector<std::size_t>& inner_dims);
  // Removes the link `path` (a dataset or group); nothing happens when it does not exist.
  void remove(const std::string& path);
  // Copies the object `path` (a dataset or a group with everything below it, attributes included) to the same path
  // in `dest`, whose parent group must exist there. A dataset `path` can be cut to its first `records` records (the
  // rest is never read: a rebuild after a torn flush keeps what the checkpoint covers and nothing past it).
  void copy_object(const std::string& path, H5File& dest, std::size_t records = kAllRecords) const;
  // Copies the numeric dataset `path` to the same path in `dest` (parent group must exist there) with the same element
  // type, shape and maximum shape and its attributes, re-chunked (~64 KiB of records per chunk) and shuffled + deflated
  // at `deflate_level` (0: no filter). What a finished output's series get: many records per compressed chunk is safe
  // only for a dataset that no longer grows (set_compression says why). Streams the records, so memory stays small.
  void copy_dataset_rechunked(const std::string& path, H5File& dest, int deflate_level,
                              std::size_t records = kAllRecords) const;
  // Copies every attribute of `object` (a group, a dataset or "/") onto `dest_object` in `dest`, replacing those of
  // the same name there.
  void copy_attributes(const std::string& object, H5File& dest, const std::string& dest_object) const;
  // Number of records (the first dimension).
  std::size_t extent(const std::string& path) const;
  // Shrinks the first dimension to new_len (<= extent; std::invalid_argument otherwise). The freed
  // space is not returned to the file system (h5repack does that).
  void truncate(const std::string& path, std::size_t new_len);

  // --- reading numeric datasets ------------------------------------------------------------------
  // The whole dataset, converted to T (double, float, std::int32_t or std::int64_t).
  template <class T>
  H5Array<T> read(const std::string& path) const;
  // Records [first, first + count) along the first dimension; dims[0] of the result is count.
  template <class T>
  H5Array<T> read_records(const std::string& path, std::size_t first, std::size_t count) const;

 private:
  H5File(std::int64_t id, std::filesystem::path path, bool read_only);
  void set_attribute_f64(const std::string& object, const std::string& name, double value);
  void set_attribute_i64(const std::string& object, const std::string& name, std::int64_t value);
  void set_attribute_str(const std::string& object, const std::string& name, std::string_view value);
  void require_writable(const char* what, const std::string& object) const;

  std::int64_t id_ = -1;  // hid_t (int64_t in HDF5 >= 1.10; checked in the .cpp)
  std::filesystem::path path_;
  bool read_only_ = true;
  int deflate_level_ = 0;
};

template <class T>
void H5File::set_attribute(const std::string& object, const std::string& name, const T& value) {
  if constexpr (std::is_same_v<T, bool>) {
    set_attribute_i64(object, name, value ? 1 : 0);
  } else if constexpr (std::is_integral_v<T>) {
    if constexpr (std::is_unsigned_v<T> && sizeof(T) >= sizeof(std::int64_t)) {
      if (value > static_cast<T>(INT64_MAX))
        throw std::out_of_range("attribute '" + name + "': value does not fit in int64");
    }
    set_attribute_i64(object, name, static_cast<std::int64_t>(value));
  } else if constexpr (std::is_floating_point_v<T>) {
    set_attribute_f64(object, name, static_cast<double>(value));
  } else {
    static_assert(std::is_convertible_v<const T&, std::string_view>,
                  "set_attribute: value must be integral, floating point or a string");
    set_attribute_str(object, name, std::string_view(value));
  }
}

template <class T>
void H5File::write(const std::string& path, const std::vector<std::size_t>& dims, const std::vector<T>& data) {
  std::size_t n = 1;
  for (std::size_t d : dims) n *= d;
  if (data.size() != n)
    throw std::invalid_argument("H5File::write '" + path + "': " + std::to_string(data.size()) +
                                " values for a shape of " + std::to_string(n));
  write(path, dims, data.data());
}

// --- checkpoints ----------------------------------------------------------------------------------

// Writes a complete HDF5 file through `writer` to a temporary next to `path`, closes and fsyncs it, then
// renames it over `path`. If `writer` (or anything else) throws, the temporary is removed and the previous
// checkpoint at `path` is left untouched.
void write_checkpoint_atomically(const std::filesystem::path& path, const std::function<void(H5File&)>& writer);

// The complete state of a std::mt19937_64 as text (the standard's operator<< format), and back.
// rng_from_string throws InputError if the text is not a valid state.
std::string rng_to_string(const std::mt19937_64& rng);
std::mt19937_64 rng_from_string(const std::string& text);
// Stored as a string dataset at `path`.
void write_rng_state(H5File& file, const std::string& path, const std::mt19937_64& rng);
std::mt19937_64 read_rng_state(const H5File& file, const std::string& path);

}  // namespace capsflow
