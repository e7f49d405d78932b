#include "host/io/log_h5.h"

#include <hdf5.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "host/io/log_detail.h"

namespace imuforge::io::h5 {

namespace {

// Column index → row field: 0 t_s, 1 segment, 2 temp_C, 3 chamber_C, 4..6 f_ref, 7..9 w_ref, 10..15 raw,
// 16 + 2i tbl_angle_<i>, 17 + 2i tbl_rate_<i>.
struct Column {
  std::string name;
  bool integer;  // segment and raw counts: int32 datasets
};

std::vector<Column> columns(int table_axes) {
  std::vector<Column> c;
  for (int i = 0; i < 16; ++i) c.push_back({detail::kRequired[i], i == 1 || i >= 10});
  for (int t = 0; t < table_axes; ++t) {
    c.push_back({"tbl_angle_" + std::to_string(t), false});
    c.push_back({"tbl_rate_" + std::to_string(t), false});
  }
  return c;
}

double get_double(const LogRow& r, std::size_t col) {
  if (col == 0) return r.t_s;
  if (col == 2) return r.temp_C;
  if (col == 3) return r.chamber_C;
  if (col < 7) return r.has_ref ? r.f_ref[col - 4] : std::nan("");
  if (col < 10) return r.has_ref ? r.w_ref[col - 7] : std::nan("");
  const std::size_t t = (col - 16) / 2;
  return (col - 16) % 2 == 0 ? r.table_angle_rad[t] : r.table_rate_rad_s[t];
}

std::int32_t get_int(const LogRow& r, std::size_t col) { return col == 1 ? r.segment : r.raw[col - 10]; }

// HDF5 prints its error stack to stderr by default; errors reach the user as LogError instead.
void quiet() {
  static const bool done = [] {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    return true;
  }();
  (void)done;
}

// Closes an HDF5 handle on scope exit.
struct Handle {
  hid_t id = -1;
  herr_t (*close)(hid_t) = nullptr;
  Handle(hid_t i, herr_t (*c)(hid_t)) : id(i), close(c) {}
  ~Handle() {
    if (id >= 0 && close) close(id);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  operator hid_t() const { return id; }
};

// Closes the datasets and the file (errors ignored: used on failure paths and in destructors).
void close_handles(std::vector<hid_t>& ds, hid_t& file) {
  for (hid_t d : ds)
    if (d >= 0) H5Dclose(d);
  ds.clear();
  if (file >= 0) H5Fclose(file);
  file = -1;
}

}  // namespace

bool is_hdf5_signature(const char first8[8]) { return std::memcmp(first8, "\x89HDF\r\n\x1a\n", 8) == 0; }

// ================================================================= writer

struct Writer::Impl {
  std::string path;
  hid_t file = -1;
  std::vector<Column> cols;
  std::vector<hid_t> ds;
  std::vector<std::vector<double>> dbuf;
  std::vector<std::vector<std::int32_t>> ibuf;
  std::size_t buffered = 0;
  std::uint64_t written = 0;

  [[noreturn]] void fail(const std::string& what) const { throw LogError(path + ": HDF5: " + what); }

  void attr(const char* name, hid_t type, const void* value) {
    Handle space(H5Screate(H5S_SCALAR), H5Sclose);
    Handle a(H5Acreate2(file, name, type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    if (a < 0 || H5Awrite(a, type, value) < 0) fail(std::string("cannot write attribute '") + name + "'");
  }
  void attr_str(const std::string& name, const std::string& v) {
    Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(t, H5T_VARIABLE);
    H5Tset_cset(t, H5T_CSET_UTF8);
    const char* p = v.c_str();
    attr(name.c_str(), t, &p);
  }
  void attr_double(const char* name, double v) { attr(name, H5T_NATIVE_DOUBLE, &v); }
  void attr_int(const char* name, std::int32_t v) { attr(name, H5T_NATIVE_INT32, &v); }

  void flush_rows() {
    if (buffered == 0) return;
    const hsize_t start = written, count = buffered, size = written + buffered;
    for (std::size_t c = 0; c < cols.size(); ++c) {
      if (H5Dset_extent(ds[c], &size) < 0) fail("cannot extend dataset '" + cols[c].name + "'");
      Handle fspace(H5Dget_space(ds[c]), H5Sclose);
      Handle mspace(H5Screate_simple(1, &count, nullptr), H5Sclose);
      H5Sselect_hyperslab(fspace, H5S_SELECT_SET, &start, nullptr, &count, nullptr);
      const herr_t rc = cols[c].integer
                            ? H5Dwrite(ds[c], H5T_NATIVE_INT32, mspace, fspace, H5P_DEFAULT, ibuf[c].data())
                            : H5Dwrite(ds[c], H5T_NATIVE_DOUBLE, mspace, fspace, H5P_DEFAULT, dbuf[c].data());
      if (rc < 0) fail("cannot write dataset '" + cols[c].name + "'");
      dbuf[c].clear();
      ibuf[c].clear();
    }
    written += buffered;
    buffered = 0;
  }

  void close_all() { close_handles(ds, file); }
};

Writer::Writer(const std::string& path, const LogMeta& meta) : p_(std::make_unique<Impl>()) {
  quiet();
  detail::check_meta(meta, path);
  Impl& w = *p_;
  w.path = path;
  Handle fcpl(H5Pcreate(H5P_FILE_CREATE), H5Pclose);
  // Keep the metadata in file order (LogMeta::extra is ordered).
  H5Pset_attr_creation_order(fcpl, H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED);
  w.file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, fcpl, H5P_DEFAULT);
  if (w.file < 0) throw LogError(path + ": cannot create HDF5 file");
  try {
    w.attr_str("format", "imuforge-log");
    w.attr_int("format_version", kLogFormatVersion);
    w.attr_str("serial", meta.serial);
    w.attr_double("sample_rate_hz", meta.sample_rate_hz);
    w.attr_double("accel_lsb_mps2", meta.accel_lsb_mps2);
    w.attr_double("gyro_lsb_rad_s", meta.gyro_lsb_rad_s);
    w.attr_double("latitude_deg", meta.latitude_deg);
    w.attr_double("height_m", meta.height_m);
    w.attr_double("gravity_mps2", meta.gravity_mps2);
    w.attr_int("table_axes", meta.table_axes);
    w.attr_int("accel_bits", meta.accel_bits);
    w.attr_int("gyro_bits", meta.gyro_bits);
    for (const auto& [k, v] : meta.extra) w.attr_str(k, v);

    w.cols = columns(meta.table_axes);
    const hsize_t zero = 0, unlimited = H5S_UNLIMITED, chunk = kH5ChunkRows;
    Handle space(H5Screate_simple(1, &zero, &unlimited), H5Sclose);
    Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
    H5Pset_chunk(dcpl, 1, &chunk);
    if (H5Zfilter_avail(H5Z_FILTER_DEFLATE) > 0) {
      H5Pset_shuffle(dcpl);
      H5Pset_deflate(dcpl, 4);
    }
    for (const Column& c : w.cols) {
      hid_t d = H5Dcreate2(w.file, c.name.c_str(), c.integer ? H5T_STD_I32LE : H5T_IEEE_F64LE, space, H5P_DEFAULT,
                           dcpl, H5P_DEFAULT);
      if (d < 0) w.fail("cannot create dataset '" + c.name + "'");
      w.ds.push_back(d);
    }
    w.dbuf.resize(w.cols.size());
    w.ibuf.resize(w.cols.size());
  } catch (...) {
    w.close_all();
    throw;
  }
}

Writer::~Writer() {
  if (p_) p_->close_all();
}

void Writer::write(const LogRow& row) {
  Impl& w = *p_;
  if (w.file < 0) throw LogError(w.path + ": log not open for writing");
  for (std::size_t c = 0; c < w.cols.size(); ++c) {
    if (w.cols[c].integer) w.ibuf[c].push_back(get_int(row, c));
    else w.dbuf[c].push_back(get_double(row, c));
  }
  if (++w.buffered == kH5ChunkRows) w.flush_rows();
}

void Writer::flush() {
  Impl& w = *p_;
  if (w.file < 0) return;
  w.flush_rows();
  if (H5Fflush(w.file, H5F_SCOPE_GLOBAL) < 0) w.fail("flush failed");
}

void Writer::close() {
  Impl& w = *p_;
  if (w.file < 0) return;
  try {
    w.flush_rows();
  } catch (...) {
    w.close_all();
    throw;
  }
  for (hid_t d : w.ds)
    if (H5Dclose(d) < 0) w.fail("cannot close a dataset");
  w.ds.clear();
  const herr_t rc = H5Fclose(w.file);
  w.file = -1;
  if (rc < 0) w.fail("close failed");
}

// ================================================================= reader

struct Reader::Impl {
  std::string path;
  hid_t file = -1;
  std::vector<Column> cols;
  std::vector<hid_t> ds;  // −1: optional table column absent
  std::uint64_t n = 0, pos = 0, buf_start = 0, buf_len = 0;
  std::vector<std::vector<double>> dbuf;
  std::vector<std::vector<std::int32_t>> ibuf;

  [[noreturn]] void fail(const std::string& what) const { throw LogError(path + ": " + what); }

  void load(std::uint64_t start) {
    const hsize_t s = start, count = std::min<std::uint64_t>(kH5ChunkRows, n - start);
    Handle mspace(H5Screate_simple(1, &count, nullptr), H5Sclose);
    for (std::size_t c = 0; c < cols.size(); ++c) {
      if (ds[c] < 0) continue;
      Handle fspace(H5Dget_space(ds[c]), H5Sclose);
      H5Sselect_hyperslab(fspace, H5S_SELECT_SET, &s, nullptr, &count, nullptr);
      herr_t rc;
      if (cols[c].integer) {
        ibuf[c].resize(count);
        rc = H5Dread(ds[c], H5T_NATIVE_INT32, mspace, fspace, H5P_DEFAULT, ibuf[c].data());
      } else {
        dbuf[c].resize(count);
        rc = H5Dread(ds[c], H5T_NATIVE_DOUBLE, mspace, fspace, H5P_DEFAULT, dbuf[c].data());
      }
      if (rc < 0) fail("dataset '" + cols[c].name + "': read error at rows " + std::to_string(start) + "..");
    }
    buf_start = start;
    buf_len = count;
  }

  void close_all() { close_handles(ds, file); }
};

namespace {

struct AttrList {
  std::vector<std::pair<std::string, std::string>> kv;
  std::string error;
};

// One root attribute as text (numbers in shortest round-trip form) for detail::apply_meta.
herr_t collect_attr(hid_t loc, const char* name, const H5A_info_t*, void* data) {
  auto* out = static_cast<AttrList*>(data);
  Handle a(H5Aopen(loc, name, H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(a), H5Tclose);
  Handle space(H5Aget_space(a), H5Sclose);
  if (a < 0 || type < 0 || space < 0 || H5Sget_simple_extent_npoints(space) != 1) {
    out->error = std::string("attribute '") + name + "' is not a single value";
    return -1;
  }
  std::string value;
  switch (H5Tget_class(type)) {
    case H5T_STRING: {
      if (H5Tis_variable_str(type) > 0) {
        Handle mt(H5Tcopy(H5T_C_S1), H5Tclose);
        H5Tset_size(mt, H5T_VARIABLE);
        H5Tset_cset(mt, H5Tget_cset(type));
        char* p = nullptr;
        if (H5Aread(a, mt, &p) < 0) {
          if (p) H5free_memory(p);  // a read that fails after the library allocated (corrupt file)
          out->error = std::string("attribute '") + name + "' cannot be read";
          return -1;
        }
        value = p ? p : "";
        H5free_memory(p);
      } else {
        std::vector<char> buf(H5Tget_size(type) + 1, '\0');
        if (H5Aread(a, type, buf.data()) < 0) {
          out->error = std::string("attribute '") + name + "' cannot be read";
          return -1;
        }
        value.assign(buf.data());  // NUL-terminated or NUL-padded
        while (!value.empty() && value.back() == ' ') value.pop_back();  // space-padded (MATLAB, Fortran)
      }
      break;
    }
    case H5T_FLOAT: {
      double v;
      H5Aread(a, H5T_NATIVE_DOUBLE, &v);
      value = detail::fmt_double(v);
      break;
    }
    case H5T_INTEGER: {
      long long v;
      H5Aread(a, H5T_NATIVE_LLONG, &v);
      value = std::to_string(v);
      break;
    }
    default:
      out->error = std::string("attribute '") + name + "' is neither a string nor a number";
      return -1;
  }
  out->kv.emplace_back(name, value);
  return 0;
}

}  // namespace

Reader::Reader(const std::string& path, LogMeta& meta) : p_(std::make_unique<Impl>()) {
  quiet();
  Impl& r = *p_;
  r.path = path;
  r.file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (r.file < 0) throw LogError(path + ": cannot open as HDF5 (corrupt or truncated file?)");
  try {
    AttrList attrs;
    hsize_t idx = 0;
    // Creation order when the writer tracked it (imuforge does), else by name (h5py, MATLAB).
    if (H5Aiterate2(r.file, H5_INDEX_CRT_ORDER, H5_ITER_INC, &idx, collect_attr, &attrs) < 0) {
      if (!attrs.error.empty()) r.fail(attrs.error);
      attrs = AttrList{};
      idx = 0;
      if (H5Aiterate2(r.file, H5_INDEX_NAME, H5_ITER_INC, &idx, collect_attr, &attrs) < 0)
        r.fail(attrs.error.empty() ? std::string("cannot list root attributes") : attrs.error);
    }
    meta = LogMeta{};
    meta.format_version = 0;
    for (const auto& [k, v] : attrs.kv) detail::apply_meta(meta, k, v, path + ": attribute '" + k + "'");
    if (meta.format_version != kLogFormatVersion)
      r.fail("not an imuforge log v1 (no root attribute format_version = 1)");

    r.cols = columns(meta.table_axes);
    // Optional table columns beyond table_axes are read when present, as in CSV.
    for (int t = meta.table_axes; t < 3; ++t) {
      r.cols.push_back({"tbl_angle_" + std::to_string(t), false});
      r.cols.push_back({"tbl_rate_" + std::to_string(t), false});
    }
    bool have_n = false;
    for (std::size_t c = 0; c < r.cols.size(); ++c) {
      const std::string& name = r.cols[c].name;
      const bool required = c < 16;
      if (H5Lexists(r.file, name.c_str(), H5P_DEFAULT) <= 0) {
        if (required) r.fail("lacks dataset '/" + name + "'");
        r.ds.push_back(-1);
        continue;
      }
      hid_t d = H5Dopen2(r.file, name.c_str(), H5P_DEFAULT);
      r.ds.push_back(d);
      if (d < 0) r.fail("'/" + name + "' is not a dataset");
      Handle space(H5Dget_space(d), H5Sclose);
      Handle type(H5Dget_type(d), H5Tclose);
      hsize_t dims[2] = {0, 0};
      if (H5Sget_simple_extent_ndims(space) != 1) r.fail("dataset '/" + name + "' is not one-dimensional");
      H5Sget_simple_extent_dims(space, dims, nullptr);
      const H5T_class_t cls = H5Tget_class(type);
      if (r.cols[c].integer ? cls != H5T_INTEGER : (cls != H5T_FLOAT && cls != H5T_INTEGER))
        r.fail("dataset '/" + name + "' has type class " + std::to_string(cls) + ", expected " +
               (r.cols[c].integer ? "integer" : "a number"));
      if (!have_n) {
        r.n = dims[0];
        have_n = true;
      } else if (dims[0] != r.n) {
        r.fail("dataset '/" + name + "' has " + std::to_string(dims[0]) + " rows, '/t_s' has " + std::to_string(r.n));
      }
    }
    r.dbuf.resize(r.cols.size());
    r.ibuf.resize(r.cols.size());
  } catch (...) {
    r.close_all();
    throw;
  }
}

Reader::~Reader() {
  if (p_) p_->close_all();
}

std::uint64_t Reader::rows() const { return p_->n; }

void Reader::rewind() { p_->pos = 0; }

bool Reader::next(LogRow& row) {
  Impl& r = *p_;
  if (r.pos >= r.n) return false;
  if (r.pos < r.buf_start || r.pos >= r.buf_start + r.buf_len) r.load(r.pos);
  const std::size_t i = static_cast<std::size_t>(r.pos - r.buf_start);
  auto where = [&](std::size_t c) { return "row " + std::to_string(r.pos) + " of dataset '/" + r.cols[c].name + "'"; };
  row.t_s = r.dbuf[0][i];
  if (!std::isfinite(row.t_s)) r.fail(where(0) + ": t_s is not finite");
  row.segment = r.ibuf[1][i];
  if (row.segment < -1) r.fail(where(1) + ": segment below -1");
  row.temp_C = r.dbuf[2][i];
  row.chamber_C = r.dbuf[3][i];
  int present = 0;
  for (std::size_t c = 4; c < 10; ++c) present += std::isnan(r.dbuf[c][i]) ? 0 : 1;
  if (present != 0 && present != 6) r.fail(where(4) + ": f_ref/w_ref must be all numbers or all NaN");
  row.has_ref = present == 6;
  for (int k = 0; k < 3; ++k) {
    row.f_ref[k] = row.has_ref ? r.dbuf[4 + k][i] : 0.0;
    row.w_ref[k] = row.has_ref ? r.dbuf[7 + k][i] : 0.0;
    if (row.has_ref && (!std::isfinite(row.f_ref[k]) || !std::isfinite(row.w_ref[k])))
      r.fail(where(4 + k) + ": reference is not finite");
  }
  for (int k = 0; k < 6; ++k) row.raw[k] = r.ibuf[10 + k][i];
  for (std::size_t c = 16; c < r.cols.size(); ++c) {
    const double v = r.ds[c] < 0 ? std::nan("") : r.dbuf[c][i];
    const std::size_t t = (c - 16) / 2;
    if ((c - 16) % 2 == 0) row.table_angle_rad[t] = v;
    else row.table_rate_rad_s[t] = v;
  }
  ++r.pos;
  return true;
}

}  // namespace imuforge::io::h5
