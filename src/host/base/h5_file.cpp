// The implementation of h5_file.hpp: H5File, the RAII wrapper over the HDF5 C API for outputs and checkpoints.
#include "host/base/h5_file.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cstring>
#include <locale>
#include <map>
#include <mutex>
#include <sstream>
#include <utility>

#include "host/base/atomic_file.hpp"
#include "host/base/errors.hpp"
#include "host/base/fault_injection.hpp"

namespace capsflow {

static_assert(std::is_same_v<hid_t, std::int64_t>, "H5File stores hid_t as int64_t (HDF5 >= 1.10)");

namespace fs = std::filesystem;

namespace {

// HDF5 prints its whole error stack to stderr on every failure by default; we report through exceptions.
void init_hdf5() {
  static std::once_flag once;
  std::call_once(once, [] {
    // No library shutdown at exit: after a failed H5Fclose (disk full) HDF5 1.10 keeps the half-closed file and its
    // exit handler segfaults closing it again. Every file is closed by its H5File before exit.
    H5dont_atexit();
    H5open();
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  });
}

// The innermost (first detected) error on HDF5's default stack, e.g. "H5F_open: unable to open file: ...".
std::string hdf5_message() {
  std::string msg;
  auto walk = [](unsigned n, const H5E_error2_t* err, void* data) -> herr_t {
    if (n != 0) return 0;
    auto* out = static_cast<std::string*>(data);
    char minor[160] = "";
    H5Eget_msg(err->min_num, nullptr, minor, sizeof minor);
    const std::string desc = err->desc ? err->desc : "";
    // A system call failed (disk full, permissions): its reason is what the user needs, not HDF5's whole record.
    const std::size_t at = desc.find("error message = '");
    if (at != std::string::npos) {
      const std::size_t from = at + 17, to = desc.find('\'', from);
      *out = desc.substr(from, to == std::string::npos ? std::string::npos : to - from);
      const std::size_t e = desc.find("errno = ");
      if (e != std::string::npos) *out += " (errno " + desc.substr(e + 8, desc.find(',', e) - e - 8) + ")";
      return 0;
    }
    *out = std::string(err->func_name ? err->func_name : "?") + ": " + desc;
    if (minor[0] != '\0') *out += " (" + std::string(minor) + ")";
    return 0;
  };
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, walk, &msg);
  H5Eclear2(H5E_DEFAULT);
  return msg.empty() ? std::string("no HDF5 error message") : msg;
}

// An owned HDF5 identifier, closed by the matching H5?close.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle() = default;
  Handle(hid_t id, Closer closer) : id_(id), closer_(closer) {}
  Handle(Handle&& o) noexcept : id_(std::exchange(o.id_, -1)), closer_(o.closer_) {}
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = std::exchange(o.id_, -1);
      closer_ = o.closer_;
    }
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() { reset(); }
  void reset() {
    if (id_ >= 0 && closer_) closer_(id_);
    id_ = -1;
  }
  hid_t get() const { return id_; }

 private:
  hid_t id_ = -1;
  Closer closer_ = nullptr;
};

template <class T>
hid_t native_type() {
  if constexpr (std::is_same_v<T, double>) return H5T_NATIVE_DOUBLE;
  if constexpr (std::is_same_v<T, float>) return H5T_NATIVE_FLOAT;
  if constexpr (std::is_same_v<T, std::int32_t>) return H5T_NATIVE_INT32;
  if constexpr (std::is_same_v<T, std::int64_t>) return H5T_NATIVE_INT64;
}

std::vector<hsize_t> to_hsize(const std::vector<std::size_t>& v) { return {v.begin(), v.end()}; }

std::size_t product(const std::vector<std::size_t>& v) {
  std::size_t n = 1;
  for (std::size_t d : v) n *= d;
  return n;
}

std::string shape_string(const std::vector<std::size_t>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + std::to_string(v[i]);
  return s + "]";
}

// Context for error messages: which file, which object.
struct Where {
  const fs::path& file;
  const std::string& object;
  [[noreturn]] void fail(const std::string& what) const {
    throw H5Error("HDF5: cannot " + what + " '" + object + "' in '" + file.string() + "': " + hdf5_message());
  }
  [[noreturn]] void fail_plain(const std::string& what) const {
    throw H5Error("HDF5: " + what + " ('" + object + "' in '" + file.string() + "')");
  }
  hid_t check(hid_t id, const std::string& what) const {
    if (id < 0) fail(what);
    return id;
  }
  void check_status(herr_t status, const std::string& what) const {
    if (status < 0) fail(what);
  }
};

Handle make_lcpl(const Where& w) {
  Handle lcpl(w.check(H5Pcreate(H5P_LINK_CREATE), "make a link property list for"), H5Pclose);
  w.check_status(H5Pset_create_intermediate_group(lcpl.get(), 1), "set intermediate groups for");
  w.check_status(H5Pset_char_encoding(lcpl.get(), H5T_CSET_UTF8), "set the name encoding for");
  return lcpl;
}

Handle vlen_string_type(const Where& w) {
  Handle t(w.check(H5Tcopy(H5T_C_S1), "make a string type for"), H5Tclose);
  w.check_status(H5Tset_size(t.get(), H5T_VARIABLE), "make a string type for");
  w.check_status(H5Tset_cset(t.get(), H5T_CSET_UTF8), "make a string type for");
  return t;
}

// Reads a scalar string (variable or fixed length) through `read(memtype, buffer)`.
template <class Read>
std::string read_string_value(hid_t file_type, hid_t space, const Where& w, Read read) {
  if (H5Tget_class(file_type) != H5T_STRING) w.fail_plain("not a string");
  if (H5Sget_simple_extent_npoints(space) != 1) w.fail_plain("not a single string");
  const htri_t variable = H5Tis_variable_str(file_type);
  if (variable < 0) w.fail("inspect the string type of");
  if (variable) {
    Handle mem = vlen_string_type(w);
    char* p = nullptr;
    w.check_status(read(mem.get(), &p), "read the string");
    std::string s = p ? std::string(p) : std::string();
    if (p) H5free_memory(p);
    return s;
  }
  const std::size_t size = H5Tget_size(file_type);
  Handle mem(w.check(H5Tcopy(H5T_C_S1), "make a string type for"), H5Tclose);
  w.check_status(H5Tset_size(mem.get(), size), "make a string type for");
  std::vector<char> buf(size + 1, '\0');
  w.check_status(read(mem.get(), buf.data()), "read the string");
  return std::string(buf.data(), strnlen(buf.data(), size));
}

std::vector<std::size_t> space_dims(hid_t space, const Where& w, std::vector<hsize_t>* maxdims = nullptr) {
  const int rank = H5Sget_simple_extent_ndims(space);
  if (rank < 0) w.fail("get the shape of");
  std::vector<hsize_t> d(static_cast<std::size_t>(rank)), m(static_cast<std::size_t>(rank));
  if (rank > 0 && H5Sget_simple_extent_dims(space, d.data(), m.data()) < 0) w.fail("get the shape of");
  if (maxdims) *maxdims = m;
  return {d.begin(), d.end()};
}

void check_numeric(hid_t dset, const Where& w) {
  Handle ftype(w.check(H5Dget_type(dset), "get the type of"), H5Tclose);
  const H5T_class_t c = H5Tget_class(ftype.get());
  if (c != H5T_INTEGER && c != H5T_FLOAT) w.fail_plain("not a numeric dataset");
}

}  // namespace

// ------------------------------------------------------------------------------------------------------
// Life cycle

H5File::H5File(std::int64_t id, fs::path path, bool read_only) : id_(id), path_(std::move(path)), read_only_(read_only) {}

H5File::H5File(H5File&& other) noexcept
    : id_(std::exchange(other.id_, -1)),
      path_(std::move(other.path_)),
      read_only_(other.read_only_),
      deflate_level_(other.deflate_level_) {}

H5File& H5File::operator=(H5File&& other) noexcept {
  if (this != &other) {
    if (id_ >= 0) H5Fclose(id_);
    id_ = std::exchange(other.id_, -1);
    path_ = std::move(other.path_);
    read_only_ = other.read_only_;
    deflate_level_ = other.deflate_level_;
  }
  return *this;
}

H5File::~H5File() {
  if (id_ >= 0) {
    H5Fclose(id_);
    H5Eclear2(H5E_DEFAULT);
  }
}

namespace {
Handle file_access_plist(const Where& w) {
  // STRONG: closing the file closes every object still open in it, so close() really releases the file.
  Handle fapl(w.check(H5Pcreate(H5P_FILE_ACCESS), "make a file access property list for"), H5Pclose);
  w.check_status(H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG), "set the close degree for");
  // Tests only: the driver that counts (and fails) the writes, flushes and truncations (fault_injection.hpp).
  if (fault_injection_active())
    w.check_status(H5Pset_driver(fapl.get(), fault_counting_h5_driver(), nullptr), "set the test driver for");
  return fapl;
}
}  // namespace

H5File H5File::create(const fs::path& path, bool overwrite) {
  init_hdf5();
  ensure_can_create(path, overwrite);  // InputError with a clear message for the common cases
  const std::string root = "/";
  const Where w{path, root};
  Handle fapl = file_access_plist(w);
  std::error_code ec;
  const bool existed = fs::exists(fs::symlink_status(path, ec));
  const hid_t id = H5Fcreate(path.c_str(), overwrite ? H5F_ACC_TRUNC : H5F_ACC_EXCL, H5P_DEFAULT, fapl.get());
  if (id < 0) {
    const std::string msg = hdf5_message();
    if (!overwrite && existed)  // created by someone else since ensure_can_create looked
      throw InputError("output file '" + path.string() + "' already exists; refusing to overwrite it");
    // HDF5 may leave the file it could not finish (disk full): an empty file would block the rerun.
    if (!existed) fs::remove(path, ec);
    throw H5Error("HDF5: cannot create file '" + path.string() + "': " + msg);
  }
  return H5File(id, path, false);
}

H5File H5File::open(const fs::path& path, H5Access access) {
  init_hdf5();
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError("HDF5 file '" + path.string() + "' does not exist");
  if (H5Fis_hdf5(path.c_str()) <= 0) {
    H5Eclear2(H5E_DEFAULT);
    throw InputError("'" + path.string() + "' is not an HDF5 file (or cannot be read)");
  }
  const std::string root = "/";
  const Where w{path, root};
  Handle fapl = file_access_plist(w);
  const bool ro = access != H5Access::ReadWrite;
  if (access == H5Access::ReadShared)
    w.check_status(H5Pset_file_locking(fapl.get(), false, true), "switch off file locking for");
  const hid_t id = H5Fopen(path.c_str(), ro ? H5F_ACC_RDONLY : H5F_ACC_RDWR, fapl.get());
  if (id < 0) throw H5Error("HDF5: cannot open file '" + path.string() + "': " + hdf5_message());
  return H5File(id, path, ro);
}

void H5File::flush() {
  const std::string root = "/";
  const Where w{path_, root};
  if (id_ < 0) w.fail_plain("file is closed");
  if (read_only_) return;
  w.check_status(H5Fflush(id_, H5F_SCOPE_GLOBAL), "flush");
}

std::uint64_t H5File::allocated_end() const {
  const std::string root = "/";
  const Where w{path_, root};
  if (id_ < 0) w.fail_plain("file is closed");
  haddr_t eoa = 0;
  w.check_status(H5Fget_eoa(id_, &eoa), "get the allocated end of");
  return static_cast<std::uint64_t>(eoa);
}

void H5File::close() {
  if (id_ < 0) return;
  const hid_t id = std::exchange(id_, -1);
  if (H5Fclose(id) < 0) throw H5Error("HDF5: cannot close file '" + path_.string() + "': " + hdf5_message());
}

void H5File::require_writable(const char* what, const std::string& object) const {
  const Where w{path_, object};
  if (id_ < 0) w.fail_plain(std::string("cannot ") + what + ": file is closed");
  if (read_only_) w.fail_plain(std::string("cannot ") + what + ": file is open read-only");
}

// ------------------------------------------------------------------------------------------------------
// Structure

namespace {
extern "C" herr_t collect_link_name(hid_t, const char* name, const H5L_info_t*, void* out) {
  static_cast<std::vector<std::string>*>(out)->emplace_back(name);
  return 0;
}
}  // namespace

std::vector<std::string> H5File::children(const std::string& group) const {
  const Where w{path_, group};
  if (id_ < 0) w.fail_plain("file is closed");
  Handle g(w.check(H5Gopen2(id_, group.c_str(), H5P_DEFAULT), "open group"), H5Gclose);
  std::vector<std::string> names;
  w.check_status(H5Literate(g.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr, collect_link_name, &names), "list");
  return names;
}

bool H5File::exists(const std::string& path) const {
  const Where w{path_, path};
  if (id_ < 0) w.fail_plain("file is closed");
  if (path.empty() || path[0] != '/') w.fail_plain("object paths must be absolute (start with '/')");
  std::size_t pos = 1;
  while (pos < path.size()) {
    std::size_t next = path.find('/', pos);
    if (next == std::string::npos) next = path.size();
    if (next > pos) {
      const std::string prefix = path.substr(0, next);
      const htri_t e = H5Lexists(id_, prefix.c_str(), H5P_DEFAULT);
      if (e < 0) w.fail("look up");
      if (e == 0) return false;
    }
    pos = next + 1;
  }
  return true;
}

void H5File::create_group(const std::string& path) {
  require_writable("create a group", path);
  if (exists(path)) {
    H5O_info_t info;
    const Where w{path_, path};
    w.check_status(H5Oget_info_by_name(id_, path.c_str(), &info, H5P_DEFAULT), "inspect");
    if (info.type != H5O_TYPE_GROUP) w.fail_plain("exists and is not a group");
    return;
  }
  const Where w{path_, path};
  Handle lcpl = make_lcpl(w);
  Handle g(w.check(H5Gcreate2(id_, path.c_str(), lcpl.get(), H5P_DEFAULT, H5P_DEFAULT), "create group"), H5Gclose);
}

void H5File::create_record_view(const std::string& path, const std::string& source, std::size_t index,
                                const std::vector<std::size_t>& inner_dims) {
  require_writable("create a view", path);
  const Where w{path_, path};
  if (exists(path)) w.fail_plain("exists already");
  const std::size_t slash = path.rfind('/');
  if (slash > 0) create_group(path.substr(0, slash));
  std::vector<hsize_t> vdims = to_hsize(inner_dims), start(inner_dims.size() + 1, 0), count(inner_dims.size() + 1, 1);
  start[0] = index;
  std::vector<hsize_t> src_dims{index + 1}, src_max{H5S_UNLIMITED};
  for (std::size_t i = 0; i < inner_dims.size(); ++i) {
    count[i + 1] = inner_dims[i];
    src_dims.push_back(inner_dims[i]);
    src_max.push_back(inner_dims[i]);
  }
  Handle vspace(w.check(H5Screate_simple(static_cast<int>(vdims.size()), vdims.data(), nullptr),
                        "make a dataspace for"), H5Sclose);
  Handle sspace(w.check(H5Screate_simple(static_cast<int>(src_dims.size()), src_dims.data(), src_max.data()),
                        "make a dataspace for"), H5Sclose);
  w.check_status(H5Sselect_hyperslab(sspace.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr),
                 "select the record for");
  Handle dcpl(w.check(H5Pcreate(H5P_DATASET_CREATE), "make a creation property list for"), H5Pclose);
  // The view has the source's element type (a view of a float dataset stays float).
  Handle src(w.check(H5Dopen2(id_, source.c_str(), H5P_DEFAULT), "open the source of"), H5Dclose);
  Handle type(w.check(H5Dget_type(src.get()), "get the type of the source of"), H5Tclose);
  // "." : the source lives in this same file, whatever it is called later.
  w.check_status(H5Pset_virtual(dcpl.get(), vspace.get(), ".", source.c_str(), sspace.get()), "map");
  Handle lcpl = make_lcpl(w);
  Handle d(w.check(H5Dcreate2(id_, path.c_str(), type.get(), vspace.get(), lcpl.get(), dcpl.get(),
                              H5P_DEFAULT),
                   "create the view"),
           H5Dclose);
}

void H5File::remove(const std::string& path) {
  require_writable("remove", path);
  if (!exists(path)) return;
  const Where w{path_, path};
  w.check_status(H5Ldelete(id_, path.c_str(), H5P_DEFAULT), "remove");
}

// Copied object by object rather than by H5Ocopy: when the copy of a dataset's data fails on a write error (a full
// disk), HDF5 1.10's H5Ocopy closes the source's datatype twice and the process dies inside the library (issue 55).
// Here every handle is ours, so a failed write is one more H5Error. Datasets keep their creation properties (layout,
// chunks, filters, fill value, maximum shape); chunks go across as stored (compressed bytes are not inflated), other
// layouts by one read and one write in the file's own type (no conversion: every bit is kept).
namespace {
// Frees what HDF5 allocated for the variable-length elements (strings) it read into `buf`.
struct VlenReclaim {
  hid_t type, space;
  void* buf;
  bool on;
  ~VlenReclaim() {
    if (on) H5Dvlen_reclaim(type, space, H5P_DEFAULT, buf);
  }
};

// `space` is the copy's (its first dimension possibly cut): only what lies inside it is read from `src`.
void copy_dataset_data(hid_t src, hid_t dst, hid_t type, hid_t space, hid_t dcpl, const Where& w, const Where& wd) {
  const H5D_layout_t layout = H5Pget_layout(dcpl);
  if (layout < 0) w.fail("get the layout of");
  if (layout == H5D_VIRTUAL) return;  // the mapping is in the creation properties: no data of its own
  const hssize_t npoints = H5Sget_simple_extent_npoints(space);
  if (npoints < 0) w.fail("count the elements of");
  if (npoints == 0) return;
  if (layout == H5D_CHUNKED) {
    const int rank = H5Pget_chunk(dcpl, 0, nullptr);
    if (rank <= 0) w.fail("get the chunks of");
    std::vector<hsize_t> chunk(static_cast<std::size_t>(rank)), dims(chunk.size());
    if (H5Pget_chunk(dcpl, rank, chunk.data()) < 0) w.fail("get the chunks of");
    if (H5Sget_simple_extent_dims(space, dims.data(), nullptr) < 0) w.fail("get the shape of");
    // Every position of the chunk grid in row-major order; a chunk never written has no address and stays unwritten
    // (it reads as the fill value in both files).
    std::vector<hsize_t> grid(chunk.size()), at(chunk.size(), 0), offset(chunk.size());
    for (std::size_t i = 0; i < chunk.size(); ++i) grid[i] = (dims[i] + chunk[i] - 1) / chunk[i];
    std::vector<unsigned char> buf;
    for (;;) {
      for (std::size_t i = 0; i < chunk.size(); ++i) offset[i] = at[i] * chunk[i];
      unsigned mask = 0;
      haddr_t addr = HADDR_UNDEF;
      hsize_t size = 0;
      w.check_status(H5Dget_chunk_info_by_coord(src, offset.data(), &mask, &addr, &size), "locate a chunk of");
      if (addr != HADDR_UNDEF && size > 0) {
        buf.resize(static_cast<std::size_t>(size));
        uint32_t filters = 0;
        w.check_status(H5Dread_chunk(src, H5P_DEFAULT, offset.data(), &filters, buf.data()), "read a chunk of");
        wd.check_status(H5Dwrite_chunk(dst, H5P_DEFAULT, filters, offset.data(), buf.size(), buf.data()),
                        "write a chunk of");
      }
      std::size_t d = chunk.size();
      while (d > 0 && ++at[d - 1] == grid[d - 1]) at[--d] = 0;
      if (d == 0) return;
    }
  }
  // Contiguous or compact: small in a run's files (the mesh, the configuration text), so read whole.
  const std::size_t esize = H5Tget_size(type);
  if (esize == 0) w.fail("get the element size of");
  std::vector<unsigned char> buf(static_cast<std::size_t>(npoints) * esize);
  w.check_status(H5Dread(src, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()), "read dataset");
  const bool vlen = H5Tdetect_class(type, H5T_VLEN) > 0 || H5Tis_variable_str(type) > 0;
  VlenReclaim reclaim{type, space, buf.data(), vlen};
  wd.check_status(H5Dwrite(dst, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()), "write dataset");
}

// The objects already copied, by their address in the source file: a second hard link to one links to its copy.
using CopiedObjects = std::map<haddr_t, std::string>;

void copy_tree(const H5File& src, hid_t src_id, H5File& dst, hid_t dst_id, const std::string& path,
               CopiedObjects& copied, std::size_t records = H5File::kAllRecords) {
  const Where w{src.path(), path};
  const Where wd{dst.path(), path};
  H5O_info_t info;
  w.check_status(H5Oget_info_by_name(src_id, path.c_str(), &info, H5P_DEFAULT), "inspect");
  if (const auto seen = copied.find(info.addr); seen != copied.end()) {
    Handle lcpl = make_lcpl(wd);
    wd.check_status(H5Lcreate_hard(dst_id, seen->second.c_str(), dst_id, path.c_str(), lcpl.get(), H5P_DEFAULT),
                    "link");
    return;
  }
  if (info.type == H5O_TYPE_GROUP) {
    Handle g(w.check(H5Gopen2(src_id, path.c_str(), H5P_DEFAULT), "open group"), H5Gclose);
    if (path != "/") {
      Handle gcpl(w.check(H5Gget_create_plist(g.get()), "get the creation properties of"), H5Pclose);
      Handle lcpl = make_lcpl(wd);
      Handle out(wd.check(H5Gcreate2(dst_id, path.c_str(), lcpl.get(), gcpl.get(), H5P_DEFAULT), "create group"),
                 H5Gclose);
    }
    copied.emplace(info.addr, path);
    src.copy_attributes(path, dst, path);
    const std::string prefix = path == "/" ? "/" : path + "/";
    for (const std::string& name : src.children(path)) {
      const std::string child = prefix + name;
      H5L_info_t link;
      w.check_status(H5Lget_info(src_id, child.c_str(), &link, H5P_DEFAULT), "inspect the link of");
      if (link.type == H5L_TYPE_HARD) {
        copy_tree(src, src_id, dst, dst_id, child, copied);
        continue;
      }
      // A soft or external link: its value as it is (it names a path, not an object).
      std::vector<char> value(link.u.val_size + 1, '\0');
      w.check_status(H5Lget_val(src_id, child.c_str(), value.data(), value.size(), H5P_DEFAULT), "read the link");
      const Where wc{dst.path(), child};
      Handle lcpl = make_lcpl(wc);
      if (link.type == H5L_TYPE_SOFT) {
        wc.check_status(H5Lcreate_soft(value.data(), dst_id, child.c_str(), lcpl.get(), H5P_DEFAULT), "link");
      } else if (link.type == H5L_TYPE_EXTERNAL) {
        const char* file = nullptr;
        const char* object = nullptr;
        unsigned flags = 0;
        w.check_status(H5Lunpack_elink_val(value.data(), value.size(), &flags, &file, &object), "read the link");
        wc.check_status(H5Lcreate_external(file, object, dst_id, child.c_str(), lcpl.get(), H5P_DEFAULT), "link");
      } else {
        w.fail_plain("cannot copy a user-defined link");
      }
    }
    return;
  }
  if (info.type != H5O_TYPE_DATASET) w.fail_plain("cannot copy: neither a group nor a dataset");
  Handle d(w.check(H5Dopen2(src_id, path.c_str(), H5P_DEFAULT), "open dataset"), H5Dclose);
  Handle dtype(w.check(H5Dget_type(d.get()), "get the type of"), H5Tclose);
  // A transient copy of the type: a committed (named) type of the source file cannot be used in another file.
  Handle type(w.check(H5Tcopy(dtype.get()), "copy the type of"), H5Tclose);
  Handle space(w.check(H5Dget_space(d.get()), "get the dataspace of"), H5Sclose);
  Handle dcpl(w.check(H5Dget_create_plist(d.get()), "get the creation properties of"), H5Pclose);
  if (records != H5File::kAllRecords) {
    if (H5Pget_layout(dcpl.get()) != H5D_CHUNKED) w.fail_plain("cannot cut a dataset that is not chunked to records");
    std::vector<hsize_t> maxdims;
    std::vector<std::size_t> dims = space_dims(space.get(), w, &maxdims);
    if (dims.empty()) w.fail_plain("cannot cut a scalar dataset to records");
    dims[0] = std::min(dims[0], records);
    const std::vector<hsize_t> hd = to_hsize(dims);
    w.check_status(H5Sset_extent_simple(space.get(), static_cast<int>(hd.size()), hd.data(), maxdims.data()),
                   "cut the shape of");
  }
  Handle lcpl = make_lcpl(wd);
  Handle out(wd.check(H5Dcreate2(dst_id, path.c_str(), type.get(), space.get(), lcpl.get(), dcpl.get(), H5P_DEFAULT),
                      "create dataset"),
             H5Dclose);
  copied.emplace(info.addr, path);
  copy_dataset_data(d.get(), out.get(), type.get(), space.get(), dcpl.get(), w, wd);
  out.reset();
  src.copy_attributes(path, dst, path);
}
}  // namespace

void H5File::copy_object(const std::string& path, H5File& dest, std::size_t records) const {
  dest.require_writable("copy into", path);
  const Where w{path_, path};
  if (id_ < 0) w.fail_plain("file is closed");
  CopiedObjects copied;
  copy_tree(*this, id_, dest, dest.id_, path, copied, records);
}

namespace {
extern "C" herr_t collect_dataset(hid_t, const char* name, const H5O_info_t* info, void* out) {
  if (info->type == H5O_TYPE_DATASET) static_cast<std::vector<std::string>*>(out)->emplace_back(name);
  return 0;
}
}  // namespace

std::vector<std::string> H5File::datasets(const std::string& group) const {
  const Where w{path_, group};
  if (id_ < 0) w.fail_plain("file is closed");
  std::vector<std::string> names;
  w.check_status(H5Ovisit_by_name2(id_, group.c_str(), H5_INDEX_NAME, H5_ITER_INC, collect_dataset, &names,
                                   H5O_INFO_BASIC, H5P_DEFAULT),
                 "visit");
  std::string prefix = group == "/" ? "/" : group + "/";
  for (std::string& n : names) n = prefix + n;
  return names;
}

std::vector<std::string> H5File::filters(const std::string& path) const {
  const Where w{path_, path};
  Handle d(w.check(H5Dopen2(id_, path.c_str(), H5P_DEFAULT), "open dataset"), H5Dclose);
  Handle dcpl(w.check(H5Dget_create_plist(d.get()), "get the creation properties of"), H5Pclose);
  const int n = H5Pget_nfilters(dcpl.get());
  if (n < 0) w.fail("count the filters of");
  std::vector<std::string> out;
  for (unsigned i = 0; i < static_cast<unsigned>(n); ++i) {
    unsigned flags = 0, cd[8];
    std::size_t ncd = 8;
    char name[64] = "";
    const H5Z_filter_t id = H5Pget_filter2(dcpl.get(), i, &flags, &ncd, cd, sizeof name, name, nullptr);
    if (id < 0) w.fail("read the filters of");
    out.push_back(id == H5Z_FILTER_SHUFFLE ? "shuffle" : id == H5Z_FILTER_DEFLATE ? "deflate" : name);
  }
  return out;
}

void H5File::set_compression(int deflate_level) {
  if (deflate_level < 0 || deflate_level > 9)
    throw std::invalid_argument("H5File::set_compression: deflate level " + std::to_string(deflate_level) +
                                " is not in 0..9");
  if (deflate_level > 0 && (H5Zfilter_avail(H5Z_FILTER_DEFLATE) <= 0 || H5Zfilter_avail(H5Z_FILTER_SHUFFLE) <= 0)) {
    const std::string root = "/";
    const Where w{path_, root};
    w.fail_plain("this HDF5 library has no deflate (zlib) or shuffle filter");
  }
  deflate_level_ = deflate_level;
}

std::vector<std::size_t> H5File::dims(const std::string& path) const {
  const Where w{path_, path};
  Handle d(w.check(H5Dopen2(id_, path.c_str(), H5P_DEFAULT), "open dataset"), H5Dclose);
  Handle s(w.check(H5Dget_space(d.get()), "get the dataspace of"), H5Sclose);
  return space_dims(s.get(), w);
}

std::string H5File::element_type(const std::string& path) const {
  const Where w{path_, path};
  Handle d(w.check(H5Dopen2(id_, path.c_str(), H5P_DEFAULT), "open dataset"), H5Dclose);
  Handle t(w.check(H5Dget_type(d.get()), "get the type of"), H5Tclose);
  const std::string bits = std::to_string(8 * H5Tget_size(t.get()));
  switch (H5Tget_class(t.get())) {
    case H5T_FLOAT: return "float" + bits;
    case H5T_INTEGER: return (H5Tget_sign(t.get()) == H5T_SGN_NONE ? "uint" : "int") + bits;
    case H5T_STRING: return "string";
    default: return "other";
  }
}

// ------------------------------------------------------------------------------------------------------
// Attributes

namespace {
Handle open_object(hid_t file, const std::string& object, const Where& w) {
  return Handle(w.check(H5Oopen(file, object.c_str(), H5P_DEFAULT), "open object"), H5Oclose);
}

Handle fresh_attribute(hid_t obj, const std::string& name, hid_t type, const Where& w) {
  const htri_t e = H5Aexists(obj, name.c_str());
  if (e < 0) w.fail("look up attribute '" + name + "' on");
  if (e > 0) w.check_status(H5Adelete(obj, name.c_str()), "replace attribute '" + name + "' on");
  Handle space(w.check(H5Screate(H5S_SCALAR), "make a dataspace for"), H5Sclose);
  return Handle(w.check(H5Acreate2(obj, name.c_str(), type, space.get(), H5P_DEFAULT, H5P_DEFAULT),
                        "create attribute '" + name + "' on"),
                H5Aclose);
}
}  // namespace

void H5File::set_attribute_f64(const std::string& object, const std::string& name, double value) {
  require_writable("write an attribute", object);
  const Where w{path_, object};
  Handle obj = open_object(id_, object, w);
  Handle a = fresh_attribute(obj.get(), name, H5T_IEEE_F64LE, w);
  w.check_status(H5Awrite(a.get(), H5T_NATIVE_DOUBLE, &value), "write attribute '" + name + "' on");
}

void H5File::set_attribute_i64(const std::string& object, const std::string& name, std::int64_t value) {
  require_writable("write an attribute", object);
  const Where w{path_, object};
  Handle obj = open_object(id_, object, w);
  Handle a = fresh_attribute(obj.get(), name, H5T_STD_I64LE, w);
  w.check_status(H5Awrite(a.get(), H5T_NATIVE_INT64, &value), "write attribute '" + name + "' on");
}

void H5File::set_attribute_str(const std::string& object, const std::string& name, std::string_view value) {
  require_writable("write an attribute", object);
  const Where w{path_, object};
  if (value.find('\0') != std::string_view::npos)
    throw std::invalid_argument("attribute '" + name + "' on '" + object + "': strings cannot contain NUL");
  Handle obj = open_object(id_, object, w);
  Handle type = vlen_string_type(w);
  Handle a = fresh_attribute(obj.get(), name, type.get(), w);
  const std::string s(value);
  const char* p = s.c_str();
  w.check_status(H5Awrite(a.get(), type.get(), &p), "write attribute '" + name + "' on");
}

bool H5File::has_attribute(const std::string& object, const std::string& name) const {
  const Where w{path_, object};
  const htri_t e = H5Aexists_by_name(id_, object.c_str(), name.c_str(), H5P_DEFAULT);
  if (e < 0) w.fail("look up attribute '" + name + "' on");
  return e > 0;
}

void H5File::remove_attribute(const std::string& object, const std::string& name) {
  require_writable("remove an attribute", object);
  if (!has_attribute(object, name)) return;
  const Where w{path_, object};
  w.check_status(H5Adelete_by_name(id_, object.c_str(), name.c_str(), H5P_DEFAULT), "remove attribute '" + name + "' on");
}

template <class T>
T H5File::attribute(const std::string& object, const std::string& name) const {
  const Where w{path_, object};
  Handle a(w.check(H5Aopen_by_name(id_, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT),
                   "open attribute '" + name + "' on"),
           H5Aclose);
  Handle ftype(w.check(H5Aget_type(a.get()), "get the type of attribute '" + name + "' on"), H5Tclose);
  Handle space(w.check(H5Aget_space(a.get()), "get the shape of attribute '" + name + "' on"), H5Sclose);
  if constexpr (std::is_same_v<T, std::string>) {
    return read_string_value(ftype.get(), space.get(), w,
                             [&](hid_t mem, void* buf) { return H5Aread(a.get(), mem, buf); });
  } else {
    const H5T_class_t c = H5Tget_class(ftype.get());
    if (c != H5T_INTEGER && c != H5T_FLOAT) w.fail_plain("attribute '" + name + "' is not numeric");
    if (H5Sget_simple_extent_npoints(space.get()) != 1) w.fail_plain("attribute '" + name + "' is not a scalar");
    T value{};
    w.check_status(H5Aread(a.get(), native_type<T>(), &value), "read attribute '" + name + "' on");
    return value;
  }
}

template double H5File::attribute<double>(const std::string&, const std::string&) const;
template std::int64_t H5File::attribute<std::int64_t>(const std::string&, const std::string&) const;
template std::string H5File::attribute<std::string>(const std::string&, const std::string&) const;

// ------------------------------------------------------------------------------------------------------
// Datasets

template <class T>
void H5File::write(const std::string& path, const std::vector<std::size_t>& dims, const T* data) {
  require_writable("write a dataset", path);
  const Where w{path_, path};
  if (exists(path)) w.fail_plain("dataset already exists");
  const std::vector<hsize_t> hd = to_hsize(dims);
  Handle space(w.check(dims.empty() ? H5Screate(H5S_SCALAR)
                                    : H5Screate_simple(static_cast<int>(hd.size()), hd.data(), nullptr),
                       "make the dataspace of"),
               H5Sclose);
  Handle lcpl = make_lcpl(w);
  Handle d(w.check(H5Dcreate2(id_, path.c_str(), native_type<T>(), space.get(), lcpl.get(), H5P_DEFAULT, H5P_DEFAULT),
                   "create dataset"),
           H5Dclose);
  if (product(dims) == 0) return;
  if (data == nullptr) throw std::invalid_argument("H5File::write '" + path + "': null data");
  w.check_status(H5Dwrite(d.get(), native_type<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, data), "write dataset");
}

void H5File::write_string(const std::string& path, std::string_view text) {
  require_writable("write a string dataset", path);
  const Where w{path_, path};
  if (text.find('\0') != std::string_view::npos)
    throw std::invalid_argument("string dataset '" + path + "': strings cannot contain NUL");
  if (exists(path)) w.fail_plain("dataset already exists");
  Handle type = vlen_string_type(w);
  Handle space(w.check(H5Screate(H5S_SCALAR), "make the dataspace of"), H5Sclose);
  Handle lcpl = make_lcpl(w);
  Handle d(w.check(H5Dcreate2(id_, path.c_str(), type.get(), space.get(), lcpl.get(), H5P_DEFAULT, H5P_DEFAULT),
                   "create dataset"),
           H5Dclose);
  const std::string s(text);
  const char* p = s.c_str();
  w.check_status(H5Dwrite(d.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, &p), "write dataset");
}

std::string H5File::read_string(const std::string& path) const {
  const Where w{path_, path};
  Handle d(w.check(H5Dopen2(id_, path.c_str(), H5P_DEFAULT), "open dataset"), H5Dclose);
  Handle ftype(w.check(H5Dget_type(d.get()), "get the type of"), H5Tclose);
  Handle space(w.check(H5Dget_space(d.get()), "get the dataspace of"), H5Sclose);
  return read_string_value(ftype.get(), space.get(), w, [&](hid_t mem, void* buf) {
    return H5Dread(d.get(), mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf);
  });
}

namespace {
constexpr std::size_t kTargetChunkBytes = 64 * 1024;  // small files stay small, big records one per chunk
constexpr std::size_t kMaxChunkBytes = (std::size_t{1} << 32) - 1;  // HDF5 limit

// Records per chunk for records of `record_bytes`: ~kTargetChunkBytes, at least one, within HDF5's limit.
std::size_t chunk_records_for(std::size_t record_bytes) {
  return std::min(std::max<std::size_t>(1, kTargetChunkBytes / record_bytes),
                  std::max<std::size_t>(1, kMaxChunkBytes / record_bytes));
}

// Shuffle groups the bytes of equal significance (exponents, high mantissa bytes) so that deflate finds them.
void set_deflate(hid_t dcpl, int level, const Where& w) {
  w.check_status(H5Pset_shuffle(dcpl), "set the shuffle filter of");
  w.check_status(H5Pset_deflate(dcpl, static_cast<unsigned>(level)), "set the deflate filter of");
}
}  // namespace

template <class T>
void H5File::create_extendable(const std::string& path, const std::vector<std::size_t>& inner_dims,
                               std::size_t chunk_records) {
  require_writable("create a dataset", path);
  const Where w{path_, path};
  if (exists(path)) w.fail_plain("dataset already exists");
  for (std::size_t d : inner_dims)
    if (d == 0) throw std::invalid_argument("extendable dataset '" + path + "': inner dimensions must be > 0");
  const std::size_t record_bytes = product(inner_dims) * sizeof(T);
  if (record_bytes > kMaxChunkBytes)
    throw std::invalid_argument("extendable dataset '" + path + "': one record exceeds HDF5's 4 GiB chunk limit");
  if (chunk_records == 0) chunk_records = chunk_records_for(record_bytes);
  if (deflate_level_ > 0) chunk_records = 1;  // written once, never rewritten (set_compression)
  chunk_records = std::min(chunk_records, std::max<std::size_t>(1, kMaxChunkBytes / record_bytes));

  std::vector<hsize_t> cur{0}, max{H5S_UNLIMITED}, chunk{chunk_records};
  for (std::size_t d : inner_dims) {
    cur.push_back(d);
    max.push_back(d);
    chunk.push_back(d);
  }
  Handle space(w.check(H5Screate_simple(static_cast<int>(cur.size()), cur.data(), max.data()), "make the dataspace of"),
               H5Sclose);
  Handle dcpl(w.check(H5Pcreate(H5P_DATASET_CREATE), "make a creation property list for"), H5Pclose);
  w.check_status(H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data()), "set the chunks of");
  if (deflate_level_ > 0) set_deflate(dcpl.get(), deflate_level_, w);
  Handle lcpl = make_lcpl(w);
  Handle d(w.check(H5Dcreate2(id_, path.c_str(), native_type<T>(), space.get(), lcpl.get(), dcpl.get(), H5P_DEFAULT),
                   "create dataset"),
           H5Dclose);
}

template <class T>
void H5File::append(const std::string& path, const T* data, const std::vector<std::size_t>& inner_dims,
                    std::size_t count) {
  require_writable("append to a dataset", path);
  const Where w{path_, path};
  if (!exists(path)) create_extendable<T>(path, inner_dims);
  Handle d(w.check(H5Dopen2(id_, path.c_str(), H5P_DEFAULT), "open dataset"), H5Dclose);
  Handle fspace(w.check(H5Dget_space(d.get()), "get the dataspace of"), H5Sclose);
  std::vector<hsize_t> maxdims;
  std::vector<std::size_t> cur = space_dims(fspace.get(), w, &maxdims);
  if (cur.empty() || maxdims[0] != H5S_UNLIMITED) w.fail_plain("cannot append: dataset is not extendable");
  const std::vector<std::size_t> inner(cur.begin() + 1, cur.end());
  if (inner != inner_dims)
    w.fail_plain("cannot append records of shape " + shape_string(inner_dims) + " to a dataset of records " +
                 shape_string(inner));
  {
    Handle ftype(w.check(H5Dget_type(d.get()), "get the type of"), H5Tclose);
    if (H5Tget_class(ftype.get()) != H5Tget_class(native_type<T>()))
      w.fail_plain("cannot append: element type differs (integer vs floating point)");
  }
  if (count == 0) return;
  if (data == nullptr) throw std::invalid_argument("H5File::append '" + path + "': null data");

  std::vector<hsize_t> new_dims = to_hsize(cur);
  const hsize_t old_len = new_dims[0];
  new_dims[0] = old_len + count;
  w.check_status(H5Dset_extent(d.get(), new_dims.data()), "extend dataset");
  Handle fs2(w.check(H5Dget_space(d.get()), "get the dataspace of"), H5Sclose);
  std::vector<hsize_t> start(new_dims.size(), 0), block = new_dims;
  start[0] = old_len;
  block[0] = count;
  w.check_status(H5Sselect_hyperslab(fs2.get(), H5S_SELECT_SET, start.data(), nullptr, block.data(), nullptr),
                 "select the new records of");
  Handle mspace(w.check(H5Screate_simple(static_cast<int>(block.size()), block.data(), nullptr), "make a memory space for"),
                H5Sclose);
  w.check_status(H5Dwrite(d.get(), native_type<T>(), mspace.get(), fs2.get(), H5P_DEFAULT, data), "append to dataset");
}

void H5File::copy_dataset_rechunked(const std::string& path, H5File& dest, int deflate_level,
                                    std::size_t records) const {
  dest.require_writable("copy into", path);
  if (deflate_level < 0 || deflate_level > 9)
    throw std::invalid_argument("H5File::copy_dataset_rechunked: deflate level " + std::to_string(deflate_level) +
                                " is not in 0..9");
  const Where w{path_, path};
  const Where wd{dest.path_, path};
  Handle d(w.check(H5Dopen2(id_, path.c_str(), H5P_DEFAULT), "open dataset"), H5Dclose);
  check_numeric(d.get(), w);
  Handle ftype(w.check(H5Dget_type(d.get()), "get the type of"), H5Tclose);
  Handle mtype(w.check(H5Tget_native_type(ftype.get(), H5T_DIR_ASCEND), "get the memory type of"), H5Tclose);
  Handle space(w.check(H5Dget_space(d.get()), "get the dataspace of"), H5Sclose);
  std::vector<hsize_t> maxdims;
  std::vector<std::size_t> dims = space_dims(space.get(), w, &maxdims);
  if (dims.empty()) w.fail_plain("cannot re-chunk a scalar dataset");
  dims[0] = std::min(dims[0], records);
  const std::size_t record_elems = product(std::vector<std::size_t>(dims.begin() + 1, dims.end()));
  const std::size_t esize = H5Tget_size(mtype.get());
  const std::size_t record_bytes = std::max<std::size_t>(1, record_elems * esize);
  if (record_bytes > kMaxChunkBytes) w.fail_plain("one record exceeds HDF5's 4 GiB chunk limit");

  std::vector<hsize_t> chunk = to_hsize(dims);
  chunk[0] = chunk_records_for(record_bytes);
  if (maxdims[0] != H5S_UNLIMITED) chunk[0] = std::min<hsize_t>(chunk[0], std::max<hsize_t>(1, maxdims[0]));
  for (hsize_t& c : chunk) c = std::max<hsize_t>(c, 1);
  Handle dcpl(wd.check(H5Pcreate(H5P_DATASET_CREATE), "make a creation property list for"), H5Pclose);
  wd.check_status(H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data()), "set the chunks of");
  if (deflate_level > 0) set_deflate(dcpl.get(), deflate_level, wd);
  const std::vector<hsize_t> hd = to_hsize(dims);
  Handle dspace(wd.check(H5Screate_simple(static_cast<int>(hd.size()), hd.data(), maxdims.data()),
                         "make the dataspace of"),
                H5Sclose);
  Handle lcpl = make_lcpl(wd);
  Handle out(wd.check(H5Dcreate2(dest.id_, path.c_str(), ftype.get(), dspace.get(), lcpl.get(), dcpl.get(),
                                 H5P_DEFAULT),
                      "create dataset"),
             H5Dclose);
  // Whole chunks at a time: every chunk of the new dataset is written once.
  const std::size_t block = static_cast<std::size_t>(chunk[0]) * 16;
  std::vector<unsigned char> buf;
  for (std::size_t first = 0; first < dims[0]; first += block) {
    std::vector<hsize_t> start(dims.size(), 0), count = hd;
    start[0] = first;
    count[0] = std::min(block, dims[0] - first);
    buf.resize(static_cast<std::size_t>(count[0]) * record_elems * esize);
    if (buf.empty()) continue;
    Handle mspace(w.check(H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr),
                          "make a memory space for"),
                  H5Sclose);
    w.check_status(H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr),
                   "select records of");
    w.check_status(H5Dread(d.get(), mtype.get(), mspace.get(), space.get(), H5P_DEFAULT, buf.data()), "read dataset");
    w.check_status(H5Sselect_hyperslab(dspace.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr),
                   "select records of");
    wd.check_status(H5Dwrite(out.get(), mtype.get(), mspace.get(), dspace.get(), H5P_DEFAULT, buf.data()),
                    "write dataset");
  }
  out.reset();
  copy_attributes(path, dest, path);
}

namespace {
struct AttributeCopy {
  hid_t dest;
  const Where* w;
  const Where* wd;
  std::string error;  // an exception cannot cross HDF5's C iteration: kept here and rethrown after it
};

extern "C" herr_t copy_one_attribute(hid_t src, const char* name, const H5A_info_t*, void* data) {
  auto* c = static_cast<AttributeCopy*>(data);
  try {
    Handle a(c->w->check(H5Aopen(src, name, H5P_DEFAULT), std::string("open attribute '") + name + "' on"), H5Aclose);
    Handle type(c->w->check(H5Aget_type(a.get()), std::string("get the type of attribute '") + name + "' on"),
                H5Tclose);
    Handle space(c->w->check(H5Aget_space(a.get()), std::string("get the shape of attribute '") + name + "' on"),
                 H5Sclose);
    const hssize_t n = H5Sget_simple_extent_npoints(space.get());
    if (n < 0) c->w->fail(std::string("count the values of attribute '") + name + "' on");
    std::vector<unsigned char> buf(std::max<std::size_t>(1, static_cast<std::size_t>(n) * H5Tget_size(type.get())));
    // The file type serves as the memory type: the bytes go across unconverted (variable-length strings as pointers,
    // which HDF5 allocates on reading and which are freed below).
    c->w->check_status(H5Aread(a.get(), type.get(), buf.data()), std::string("read attribute '") + name + "' on");
    const bool vlen = H5Tdetect_class(type.get(), H5T_VLEN) > 0 || H5Tis_variable_str(type.get()) > 0;
    struct Reclaim {
      bool on;
      hid_t type, space;
      void* buf;
      ~Reclaim() {
        if (on) H5Dvlen_reclaim(type, space, H5P_DEFAULT, buf);
      }
    } reclaim{vlen, type.get(), space.get(), buf.data()};
    const htri_t e = H5Aexists(c->dest, name);
    if (e < 0) c->wd->fail(std::string("look up attribute '") + name + "' on");
    if (e > 0) c->wd->check_status(H5Adelete(c->dest, name), std::string("replace attribute '") + name + "' on");
    Handle out(c->wd->check(H5Acreate2(c->dest, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT),
                            std::string("create attribute '") + name + "' on"),
               H5Aclose);
    c->wd->check_status(H5Awrite(out.get(), type.get(), buf.data()),
                        std::string("write attribute '") + name + "' on");
  } catch (const std::exception& e) {
    c->error = e.what();
    return -1;
  }
  return 0;
}
}  // namespace

void H5File::copy_attributes(const std::string& object, H5File& dest, const std::string& dest_object) const {
  dest.require_writable("copy attributes onto", dest_object);
  const Where w{path_, object};
  const Where wd{dest.path_, dest_object};
  Handle src = open_object(id_, object, w);
  Handle dst = open_object(dest.id_, dest_object, wd);
  AttributeCopy c{dst.get(), &w, &wd, {}};
  hsize_t idx = 0;
  const herr_t status = H5Aiterate2(src.get(), H5_INDEX_NAME, H5_ITER_INC, &idx, copy_one_attribute, &c);
  if (!c.error.empty()) throw H5Error(c.error);
  w.check_status(status, "copy the attributes of");
}

std::size_t H5File::extent(const std::string& path) const {
  const std::vector<std::size_t> d = dims(path);
  if (d.empty()) {
    const Where w{path_, path};
    w.fail_plain("a scalar dataset has no records");
  }
  return d[0];
}

void H5File::truncate(const std::string& path, std::size_t new_len) {
  require_writable("truncate a dataset", path);
  const Where w{path_, path};
  Handle d(w.check(H5Dopen2(id_, path.c_str(), H5P_DEFAULT), "open dataset"), H5Dclose);
  Handle fspace(w.check(H5Dget_space(d.get()), "get the dataspace of"), H5Sclose);
  std::vector<hsize_t> maxdims;
  const std::vector<std::size_t> cur = space_dims(fspace.get(), w, &maxdims);
  if (cur.empty() || maxdims[0] != H5S_UNLIMITED) w.fail_plain("cannot truncate: dataset is not extendable");
  if (new_len > cur[0])
    throw std::invalid_argument("H5File::truncate '" + path + "': new length " + std::to_string(new_len) +
                                " exceeds the current " + std::to_string(cur[0]));
  std::vector<hsize_t> nd = to_hsize(cur);
  nd[0] = new_len;
  w.check_status(H5Dset_extent(d.get(), nd.data()), "truncate dataset");
}

template <class T>
H5Array<T> H5File::read(const std::string& path) const {
  const Where w{path_, path};
  Handle d(w.check(H5Dopen2(id_, path.c_str(), H5P_DEFAULT), "open dataset"), H5Dclose);
  check_numeric(d.get(), w);
  Handle space(w.check(H5Dget_space(d.get()), "get the dataspace of"), H5Sclose);
  H5Array<T> out;
  out.dims = space_dims(space.get(), w);
  out.data.resize(product(out.dims));
  if (!out.data.empty())
    w.check_status(H5Dread(d.get(), native_type<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data.data()), "read dataset");
  return out;
}

template <class T>
H5Array<T> H5File::read_records(const std::string& path, std::size_t first, std::size_t count) const {
  const Where w{path_, path};
  Handle d(w.check(H5Dopen2(id_, path.c_str(), H5P_DEFAULT), "open dataset"), H5Dclose);
  check_numeric(d.get(), w);
  Handle space(w.check(H5Dget_space(d.get()), "get the dataspace of"), H5Sclose);
  const std::vector<std::size_t> cur = space_dims(space.get(), w);
  if (cur.empty()) w.fail_plain("a scalar dataset has no records");
  if (first > cur[0] || count > cur[0] - first)
    throw std::out_of_range("H5File::read_records '" + path + "': records [" + std::to_string(first) + ", " +
                            std::to_string(first + count) + ") of " + std::to_string(cur[0]));
  H5Array<T> out;
  out.dims = cur;
  out.dims[0] = count;
  out.data.resize(product(out.dims));
  if (out.data.empty()) return out;
  std::vector<hsize_t> start(cur.size(), 0), block = to_hsize(out.dims);
  start[0] = first;
  w.check_status(H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start.data(), nullptr, block.data(), nullptr),
                 "select records of");
  Handle mspace(w.check(H5Screate_simple(static_cast<int>(block.size()), block.data(), nullptr), "make a memory space for"),
                H5Sclose);
  w.check_status(H5Dread(d.get(), native_type<T>(), mspace.get(), space.get(), H5P_DEFAULT, out.data.data()),
                 "read dataset");
  return out;
}

#define CAPSFLOW_H5_INSTANTIATE(T)                                                                             \
  template void H5File::write<T>(const std::string&, const std::vector<std::size_t>&, const T*);              \
  template void H5File::create_extendable<T>(const std::string&, const std::vector<std::size_t>&, std::size_t); \
  template void H5File::append<T>(const std::string&, const T*, const std::vector<std::size_t>&, std::size_t); \
  template H5Array<T> H5File::read<T>(const std::string&) const;                                               \
  template H5Array<T> H5File::read_records<T>(const std::string&, std::size_t, std::size_t) const;
CAPSFLOW_H5_INSTANTIATE(double)
CAPSFLOW_H5_INSTANTIATE(float)
CAPSFLOW_H5_INSTANTIATE(std::int32_t)
CAPSFLOW_H5_INSTANTIATE(std::int64_t)
#undef CAPSFLOW_H5_INSTANTIATE

// ------------------------------------------------------------------------------------------------------
// Checkpoints and random-number state

void write_checkpoint_atomically(const fs::path& path, const std::function<void(H5File&)>& writer) {
  replace_file_atomically(path, [&](const fs::path& tmp) {
    H5File file = H5File::create(tmp, false);
    writer(file);
    file.close();  // all data on disk (and errors seen) before the rename
  });
}

std::string rng_to_string(const std::mt19937_64& rng) {
  std::ostringstream os;
  os.imbue(std::locale::classic());
  os << rng;
  return os.str();
}

std::mt19937_64 rng_from_string(const std::string& text) {
  std::istringstream is(text);
  is.imbue(std::locale::classic());
  std::mt19937_64 rng;
  is >> rng;
  if (is.fail()) throw InputError("invalid mt19937_64 state in the checkpoint (" + std::to_string(text.size()) + " characters)");
  is >> std::ws;
  if (!is.eof()) throw InputError("invalid mt19937_64 state in the checkpoint: trailing characters");
  return rng;
}

void write_rng_state(H5File& file, const std::string& path, const std::mt19937_64& rng) {
  file.write_string(path, rng_to_string(rng));
  file.set_attribute(path, "generator", "std::mt19937_64");
}

std::mt19937_64 read_rng_state(const H5File& file, const std::string& path) {
  return rng_from_string(file.read_string(path));
}

}  // namespace capsflow
