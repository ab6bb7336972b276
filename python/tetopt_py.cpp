// tetopt._tetopt — the pybind11 layer under the `tetopt` Python package.
//
// Thin wrappers over the library: NumPy arrays in, NumPy arrays out.  The
// public, documented API is python/tetopt/__init__.py (and its .pyi stubs);
// this module only converts and validates.
//
// Copies: every input array is copied once into the TetMesh vectors the
// algorithms own and grow (no intermediate copy for float64 / any integer
// dtype, strided or not); every output array takes over its std::vector
// (moved into a capsule), so results are never copied.
//
// Validation happens here, before any library call, with 0-based indices in
// the messages (Python's numbering): wrong shape or dtype, index out of
// range, NaN / infinite coordinates, inconsistent optional arrays all raise
// ValueError.  check_arrays() then runs as a second line of defence.
// Library errors map to exceptions: Io -> OSError, Parse / InvalidMesh /
// Unsupported -> ValueError, Invariant (a bug) -> RuntimeError.
//
// The GIL is released around improve(), reading, writing and the quality
// statistics.  improve() runs on a worker thread while the calling thread
// waits for it in slices of kSignalPollMs with the GIL released, and between
// slices runs Python's signal handlers (PyErr_CheckSignals): on Ctrl-C it
// sets the `interrupted` flag that improve() polls between phases and
// inside the passes, joins the worker (no thread is left running) and
// raises KeyboardInterrupt.  The log and progress callbacks run on the
// worker with the GIL taken for them.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "tetopt/conventions.hpp"
#include "tetopt/improve.hpp"
#include "tetopt/io.hpp"
#include "tetopt/measures.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/status.hpp"

// The diagnosis ("why is this tet still bad?") is optional: older trees of
// the library do not have it.
#if __has_include("tetopt/diagnose.hpp")
#include "tetopt/diagnose.hpp"
#define TETOPT_PY_HAVE_DIAGNOSE 1
#else
#define TETOPT_PY_HAVE_DIAGNOSE 0
#endif

namespace py = pybind11;

namespace {

using tetopt::ErrorCode;
using tetopt::Status;
using tetopt::TetMesh;

// ---------------------------------------------------------------- errors

[[noreturn]] void raise_os_error(const std::string& msg) {
  PyErr_SetString(PyExc_OSError, msg.c_str());
  throw py::error_already_set();
}

/// Turns a failed Status into the matching Python exception.
void throw_status(const Status& s, const std::string& prefix = "") {
  if (s.ok()) return;
  const std::string msg = prefix.empty() ? s.message : prefix + ": " + s.message;
  switch (s.code) {
    case ErrorCode::Io: raise_os_error(msg);
    case ErrorCode::Invariant: throw std::runtime_error("invariant failure (a bug in tetopt): " + msg);
    case ErrorCode::OutOfMemory: PyErr_SetString(PyExc_MemoryError, msg.c_str()); throw py::error_already_set();
    default: throw py::value_error(msg);
  }
}


// ---------------------------------------------------------------- NumPy in

std::string dtype_name(const py::array& a) { return py::str(a.dtype()).cast<std::string>(); }

std::string shape_str(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  if (a.ndim() == 1) s += ",";
  return s + ")";
}

/// Any array-like as a NumPy array in native byte order (no copy when it
/// already is one).  The readers below take the elements' bytes as they
/// are: a big-endian '>i4' ref of 1 read as 16777216 before.
py::array as_array(py::handle obj, const std::string& name) {
  py::array a;
  if (py::isinstance<py::array>(obj)) {
    a = py::reinterpret_borrow<py::array>(obj);
  } else {
    try {
      a = py::module_::import("numpy").attr("asarray")(obj);
    } catch (py::error_already_set& e) {
      throw py::value_error(name + ": cannot be converted to an array (" + std::string(e.what()) + ")");
    }
  }
  if (!a.dtype().attr("isnative").cast<bool>()) a = a.attr("astype")(a.dtype().attr("newbyteorder")("="));
  return a;
}

/// Requires shape (n, cols), or (n,) when cols == 0.  `optional_empty`
/// accepts any empty array (e.g. [] for "none").
bool check_shape(const py::array& a, const std::string& name, int cols, bool optional_empty) {
  if (optional_empty && a.size() == 0) return false;
  const bool ok = cols == 0 ? a.ndim() == 1 : (a.ndim() == 2 && a.shape(1) == cols);
  if (!ok) {
    const std::string want = cols == 0 ? "(n,)" : "(n, " + std::to_string(cols) + ")";
    throw py::value_error(name + ": expected shape " + want + ", got " + shape_str(a));
  }
  return true;
}

template <class T>
void copy_ints_typed(const py::array& a, std::vector<int32_t>& out, const std::string& name, int64_t lo,
                     int64_t hi, const std::string& range_what) {
  const py::ssize_t rows = a.shape(0), cols = a.ndim() == 2 ? a.shape(1) : 1;
  out.resize(static_cast<size_t>(rows * cols));
  auto put = [&](py::ssize_t i, py::ssize_t j, T x) {
    const auto v = static_cast<long double>(x);  // exact for every 64-bit integer
    if (v < static_cast<long double>(lo) || v >= static_cast<long double>(hi)) {
      std::string where = name + "[" + std::to_string(i) + (a.ndim() == 2 ? ", " + std::to_string(j) : "") + "]";
      std::string val;
      if constexpr (std::is_signed_v<T>) val = std::to_string(static_cast<long long>(x));
      else val = std::to_string(static_cast<unsigned long long>(x));
      if (range_what.empty())
        throw py::value_error(where + " = " + val + " does not fit a 32-bit signed integer");
      throw py::value_error(where + " = " + val + " is out of range: " + range_what);
    }
    out[static_cast<size_t>(i * cols + j)] = static_cast<int32_t>(x);
  };
  if (a.ndim() == 1) {
    auto r = a.unchecked<T, 1>();
    for (py::ssize_t i = 0; i < rows; ++i) put(i, 0, r(i));
  } else {
    auto r = a.unchecked<T, 2>();
    for (py::ssize_t i = 0; i < rows; ++i)
      for (py::ssize_t j = 0; j < cols; ++j) put(i, j, r(i, j));
  }
}

/// Copies an integer array of shape (n, cols) (or (n,) when cols == 0) into
/// `out`, checking lo <= value < hi.  `range_what` explains the range in the
/// error message; empty means "fits int32".  Returns false (out cleared) for
/// an optional empty array.
bool get_ints(py::handle obj, std::vector<int32_t>& out, const std::string& name, int cols, bool optional,
              int64_t lo = std::numeric_limits<int32_t>::min(),
              int64_t hi = int64_t{std::numeric_limits<int32_t>::max()} + 1, const std::string& range_what = "") {
  out.clear();
  if (obj.is_none()) {
    if (optional) return false;
    throw py::value_error(name + ": required, got None");
  }
  py::array a = as_array(obj, name);
  if (!check_shape(a, name, cols, optional)) return false;
  const char kind = a.dtype().kind();
  const auto size = a.itemsize();
  if (kind == 'i') {
    if (size == 1) copy_ints_typed<int8_t>(a, out, name, lo, hi, range_what);
    else if (size == 2) copy_ints_typed<int16_t>(a, out, name, lo, hi, range_what);
    else if (size == 4) copy_ints_typed<int32_t>(a, out, name, lo, hi, range_what);
    else if (size == 8) copy_ints_typed<int64_t>(a, out, name, lo, hi, range_what);
    else throw py::value_error(name + ": unsupported integer dtype " + dtype_name(a));
  } else if (kind == 'u') {
    if (size == 1) copy_ints_typed<uint8_t>(a, out, name, lo, hi, range_what);
    else if (size == 2) copy_ints_typed<uint16_t>(a, out, name, lo, hi, range_what);
    else if (size == 4) copy_ints_typed<uint32_t>(a, out, name, lo, hi, range_what);
    else if (size == 8) copy_ints_typed<uint64_t>(a, out, name, lo, hi, range_what);
    else throw py::value_error(name + ": unsupported integer dtype " + dtype_name(a));
  } else {
    throw py::value_error(name + ": expected an integer dtype, got " + dtype_name(a));
  }
  return true;
}

/// Index arrays into a set of `n` things called `what`.
bool get_index_array(py::handle obj, std::vector<int32_t>& out, const std::string& name, int cols, bool optional,
                     int64_t n, const std::string& what) {
  const std::string range = n == 0 ? what + " is empty" :
      what + " has " + std::to_string(n) + " entries (valid indices 0.." + std::to_string(n - 1) + ")";
  return get_ints(obj, out, name, cols, optional, 0, n, range);
}

/// Coordinates (n, 3): float64 read in place, other real / integer dtypes
/// converted; every value must be finite.
void get_points(py::handle obj, std::vector<double>& xyz, const std::string& name = "points") {
  if (obj.is_none()) throw py::value_error(name + ": required, got None");
  py::array a = as_array(obj, name);
  check_shape(a, name, 3, false);
  const char kind = a.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u')
    throw py::value_error(name + ": expected a real (float64) dtype, got " + dtype_name(a));
  if (!(kind == 'f' && a.itemsize() == 8)) a = py::array_t<double, py::array::forcecast>::ensure(a);
  if (!a) throw py::value_error(name + ": cannot be converted to float64");
  const py::ssize_t n = a.shape(0);
  xyz.resize(static_cast<size_t>(3 * n));
  auto r = a.unchecked<double, 2>();
  for (py::ssize_t i = 0; i < n; ++i)
    for (py::ssize_t j = 0; j < 3; ++j) {
      const double x = r(i, j);
      if (!std::isfinite(x))
        throw py::value_error(name + "[" + std::to_string(i) + "] has a NaN or infinite coordinate");
      xyz[static_cast<size_t>(3 * i + j)] = x;
    }
}

// ---------------------------------------------------------------- NumPy out

/// Moves v into a NumPy array of the given shape (no copy).
template <class T>
py::array_t<T> to_numpy(std::vector<T>&& v, std::vector<py::ssize_t> shape) {
  auto* owned = new std::vector<T>(std::move(v));
  py::capsule owner(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  if (owned->empty()) {
    // A null pointer would make NumPy allocate; give it a valid one.
    owned->reserve(1);
  }
  return py::array_t<T>(shape, owned->data(), owner);
}

py::array_t<int32_t> rows(std::vector<int32_t>&& v, int cols) {
  const auto n = static_cast<py::ssize_t>(v.size() / static_cast<size_t>(cols));
  return to_numpy(std::move(v), {n, static_cast<py::ssize_t>(cols)});
}

py::array_t<int32_t> vec(std::vector<int32_t>&& v) {
  const auto n = static_cast<py::ssize_t>(v.size());
  return to_numpy(std::move(v), {n});
}

// ---------------------------------------------------------------- Mesh dict

const char* format_names[] = {"", "medit", "meditb", "gmsh", "vtk", "vtu", "tetgen"};

int format_from_name(const std::string& s) {
  for (int i = 0; i < 7; ++i)
    if (s == format_names[i]) return i;
  throw py::value_error("source_format: expected one of '', 'medit', 'meditb', 'gmsh', 'vtk', 'vtu', 'tetgen', got '" +
                        s + "'");
}

py::handle get_key(const py::dict& d, const char* key) {
  return d.contains(key) ? py::handle(d[key]) : py::handle(Py_None);
}

/// Fills m from a dict with the fields of tetopt.Mesh (see __init__.py).
/// Every array is validated; optional ones may be None or empty.
TetMesh mesh_from_dict(const py::dict& d) {
  TetMesh m;
  get_points(get_key(d, "points"), m.xyz);
  const int64_t nv = m.nv();
  get_index_array(get_key(d, "tets"), m.tets, "tets", 4, false, nv, "points");
  const int64_t nt = m.nt();
  if (nt == 0) throw py::value_error("tets: the mesh has no tetrahedra");
  auto sized = [](std::vector<int32_t>& v, size_t n, const std::string& name, const std::string& of) {
    if (v.empty()) v.assign(n, 0);
    else if (v.size() != n)
      throw py::value_error(name + ": expected " + std::to_string(n) + " entries (one per " + of + "), got " +
                            std::to_string(v.size()));
  };
  get_ints(get_key(d, "refs"), m.tet_ref, "refs", 0, true);
  sized(m.tet_ref, static_cast<size_t>(nt), "refs", "tet");
  get_ints(get_key(d, "point_refs"), m.vert_ref, "point_refs", 0, true);
  if (!m.vert_ref.empty()) sized(m.vert_ref, static_cast<size_t>(nv), "point_refs", "point");
  get_index_array(get_key(d, "triangles"), m.tris, "triangles", 3, true, nv, "points");
  get_ints(get_key(d, "triangle_refs"), m.tri_ref, "triangle_refs", 0, true);
  sized(m.tri_ref, m.tris.size() / 3, "triangle_refs", "triangle");
  get_index_array(get_key(d, "edges"), m.edges, "edges", 2, true, nv, "points");
  get_ints(get_key(d, "edge_refs"), m.edge_ref, "edge_refs", 0, true);
  sized(m.edge_ref, m.edges.size() / 2, "edge_refs", "edge");
  get_index_array(get_key(d, "required_vertices"), m.required_vertices, "required_vertices", 0, true, nv, "points");
  get_index_array(get_key(d, "required_triangles"), m.required_tris, "required_triangles", 0, true, m.ntri(),
                  "triangles");
  get_index_array(get_key(d, "required_edges"), m.required_edges, "required_edges", 0, true,
                  static_cast<int64_t>(m.edges.size() / 2), "edges");
  get_index_array(get_key(d, "corners"), m.corners, "corners", 0, true, nv, "points");
  get_index_array(get_key(d, "ridges"), m.ridges, "ridges", 0, true, static_cast<int64_t>(m.edges.size() / 2),
                  "edges");
  get_ints(get_key(d, "tet_entities"), m.tet_entity, "tet_entities", 0, true);
  if (!m.tet_entity.empty()) sized(m.tet_entity, static_cast<size_t>(nt), "tet_entities", "tet");
  get_ints(get_key(d, "triangle_entities"), m.tri_entity, "triangle_entities", 0, true);
  if (!m.tri_entity.empty()) sized(m.tri_entity, m.tris.size() / 3, "triangle_entities", "triangle");

  py::handle groups = get_key(d, "groups");
  if (!groups.is_none()) {
    for (py::handle g : groups) {
      py::tuple t;
      try {
        t = py::tuple(py::reinterpret_borrow<py::object>(g));
      } catch (py::error_already_set&) {
        throw py::value_error("groups: each entry must be a (dim, tag, name) tuple");
      }
      if (t.size() != 3 || !py::isinstance<py::int_>(t[0]) || !py::isinstance<py::int_>(t[1]) ||
          !py::isinstance<py::str>(t[2]))
        throw py::value_error("groups: each entry must be a (dim, tag, name) tuple, got " +
                              py::repr(g).cast<std::string>());
      tetopt::PhysicalName pn;
      pn.dim = t[0].cast<int>();
      pn.tag = t[1].cast<int>();
      pn.name = t[2].cast<std::string>();
      if (pn.dim < 0 || pn.dim > 3) throw py::value_error("groups: dim must be 0..3, got " + std::to_string(pn.dim));
      m.physical_names.push_back(std::move(pn));
    }
  }

  py::handle pdata = get_key(d, "point_data");
  if (!pdata.is_none()) {
    if (!py::isinstance<py::dict>(pdata)) throw py::value_error("point_data: expected a dict name -> array");
    for (auto item : py::reinterpret_borrow<py::dict>(pdata)) {
      const std::string key = py::str(item.first).cast<std::string>();
      const std::string name = "point_data['" + key + "']";
      py::array a = as_array(item.second, name);
      if (a.ndim() < 1 || a.ndim() > 2 || a.shape(0) != nv)
        throw py::value_error(name + ": expected shape (" + std::to_string(nv) + ",) or (" + std::to_string(nv) +
                              ", k), got " + shape_str(a));
      const char kind = a.dtype().kind();
      if (kind != 'f' && kind != 'i' && kind != 'u')
        throw py::value_error(name + ": expected a real or integer dtype, got " + dtype_name(a));
      TetMesh::PointField f;
      f.name = key;
      f.components = a.ndim() == 2 ? static_cast<int>(a.shape(1)) : 1;
      if (f.components < 1) throw py::value_error(name + ": needs at least one component");
      f.integer = kind != 'f';
      auto conv = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
      f.values.assign(conv.data(), conv.data() + conv.size());
      m.point_fields.push_back(std::move(f));
    }
  }

  py::handle flipped = get_key(d, "flipped_on_read");
  m.flipped_on_read = !flipped.is_none() && py::bool_(py::reinterpret_borrow<py::object>(flipped));
  py::handle fmt = get_key(d, "source_format");
  if (!fmt.is_none()) {
    if (!py::isinstance<py::str>(fmt)) throw py::value_error("source_format: expected a str");
    m.source_format = format_from_name(fmt.cast<std::string>());
  }
  throw_status(tetopt::check_arrays(m, "mesh"));
  return m;
}

/// All fields of m as a dict of NumPy arrays (m's vectors are moved out).
py::dict mesh_to_dict(TetMesh&& m) {
  py::dict d;
  const auto nv = static_cast<py::ssize_t>(m.nv());
  d["points"] = to_numpy(std::move(m.xyz), {nv, 3});
  d["tets"] = rows(std::move(m.tets), 4);
  d["refs"] = vec(std::move(m.tet_ref));
  if (m.vert_ref.empty()) m.vert_ref.assign(static_cast<size_t>(nv), 0);
  d["point_refs"] = vec(std::move(m.vert_ref));
  d["triangles"] = rows(std::move(m.tris), 3);
  d["triangle_refs"] = vec(std::move(m.tri_ref));
  d["edges"] = rows(std::move(m.edges), 2);
  d["edge_refs"] = vec(std::move(m.edge_ref));
  d["required_vertices"] = vec(std::move(m.required_vertices));
  d["required_triangles"] = vec(std::move(m.required_tris));
  d["required_edges"] = vec(std::move(m.required_edges));
  d["corners"] = vec(std::move(m.corners));
  d["ridges"] = vec(std::move(m.ridges));
  d["tet_entities"] = vec(std::move(m.tet_entity));
  d["triangle_entities"] = vec(std::move(m.tri_entity));
  py::list groups;
  for (const auto& pn : m.physical_names) groups.append(py::make_tuple(pn.dim, pn.tag, pn.name));
  d["groups"] = groups;
  py::dict pdata;
  for (auto& f : m.point_fields) {
    const int c = std::max(1, f.components);
    std::vector<py::ssize_t> shape = c == 1 ? std::vector<py::ssize_t>{nv} : std::vector<py::ssize_t>{nv, c};
    if (f.values.size() != static_cast<size_t>(nv) * static_cast<size_t>(c))
      throw py::value_error("point field " + f.name + " has the wrong number of values");
    if (f.integer) {
      std::vector<int64_t> iv(f.values.begin(), f.values.end());
      pdata[py::str(f.name)] = to_numpy(std::move(iv), shape);
    } else {
      pdata[py::str(f.name)] = to_numpy(std::move(f.values), shape);
    }
  }
  d["point_data"] = pdata;
  d["flipped_on_read"] = m.flipped_on_read;
  const int fmt = m.source_format;
  d["source_format"] = (fmt >= 0 && fmt < 7) ? format_names[fmt] : "";
  return d;
}

/// Orientation, then topology: the steps load_mesh does in the CLI.
/// Inverted or flat tets are kept (quality() measures them; improve()
/// untangles them first, as `tetopt improve` does).
tetopt::OrientationReport prepare(TetMesh& m) {
  tetopt::OrientationReport orient = tetopt::normalize_orientation(m);
  Status s;
  {
    py::gil_scoped_release nogil;
    s = tetopt::check_measurable(m);
    if (s) s = tetopt::build_topology(m);
    if (s) s = tetopt::orient_consistently(m, false, &orient);
  }
  if (!s) throw py::value_error(s.message);
  return orient;
}

// ---------------------------------------------------------------- improve

struct PyImproveOptions {
  std::string mode = "best", optimizer = "paper";
  double weight = 0.75, threshold = 0.3;
  long long iterations = 10, seed = 0, threads = 0;
  bool check = true;
  bool diagnose = false;
  bool allow_insert = false, allow_remove = false;
  std::string objective = "alpha";
  bool guard = true;
  bool polish = false;
  double size = 0;
  bool remesh = true;
  double gradation = 0;  // ImproveOptions::gradation
};

/// The diagnosis of m as JSON (the CLI's "diagnosis" object, `max_list`
/// worst tets) and the per-tet class; runs without the GIL.
std::string diagnosis_json(const TetMesh& m, double threshold, size_t max_list, std::vector<uint8_t>* classes,
                           bool all_measures) {
#if TETOPT_PY_HAVE_DIAGNOSE
  py::gil_scoped_release nogil;
  tetopt::DiagnoseOptions dopt;
  dopt.threshold = threshold;
  dopt.mesh_bound = true;
  dopt.all_measures = all_measures;  // as the CLI: quality always, improve for a non-alpha objective
  tetopt::Diagnosis d = tetopt::diagnose(m, dopt);
  if (classes) *classes = std::move(d.tet_class);
  return tetopt::diagnosis_to_json(d, max_list, 2);
#else
  (void)m, (void)threshold, (void)max_list, (void)classes, (void)all_measures;
  throw std::runtime_error("this build of tetopt has no diagnosis (tetopt/diagnose.hpp)");
#endif
}

tetopt::ImproveOptions to_options(const PyImproveOptions& p) {
  tetopt::ImproveOptions o;
  if (p.mode == "best") o.mode = tetopt::ImproveMode::Best;
  else if (p.mode == "combined") o.mode = tetopt::ImproveMode::Combined;
  else if (p.mode == "smooth") o.mode = tetopt::ImproveMode::Smooth;
  else if (p.mode == "topo") o.mode = tetopt::ImproveMode::Topo;
  else throw py::value_error("mode: expected 'best', 'combined', 'smooth' or 'topo', got '" + p.mode + "'");
  if (p.optimizer == "paper") o.maxmin_optimizer = false;
  else if (p.optimizer == "maxmin") o.maxmin_optimizer = true;
  else throw py::value_error("optimizer: expected 'paper' or 'maxmin', got '" + p.optimizer + "'");
  if (!(p.weight >= 0.5 && p.weight < 1.0))
    throw py::value_error("weight: must satisfy 0.5 <= weight < 1, got " + py::repr(py::float_(p.weight)).cast<std::string>());
  if (!(p.threshold > 0 && p.threshold <= 1))
    throw py::value_error("threshold: must be in (0, 1], got " + py::repr(py::float_(p.threshold)).cast<std::string>());
  // At least one round: 0 ran one anyway (the report said rounds 1).
  if (p.iterations < 1 || p.iterations > 1000000)
    throw py::value_error("iterations: must be in 1..1000000, got " + std::to_string(p.iterations));
  if (p.seed < 0) throw py::value_error("seed: must be >= 0, got " + std::to_string(p.seed));
  if (p.threads < 0 || p.threads > 1024)
    throw py::value_error("threads: must be in 0..1024, got " + std::to_string(p.threads));
  o.weight = p.weight;
  o.threshold = p.threshold;
  o.iterations = static_cast<int>(p.iterations);
  o.seed = static_cast<uint64_t>(p.seed);
  o.threads = static_cast<int>(p.threads);
  o.check_invariants = p.check;
  o.allow_insert = p.allow_insert;
  o.allow_remove = p.allow_remove;
  if (!tetopt::parse_objective(p.objective.c_str(), o.objective))
    throw py::value_error("objective: expected 'alpha', 'sine', 'jacobian', 'skewness' or 'openfoam', got '" +
                          p.objective + "'");
  o.guard = p.guard;
  o.polish = p.polish;
  o.size = p.size;
  o.remesh = p.remesh;
  o.gradation = p.gradation;
  return o;
}

const char* level_name(tetopt::LogLevel l) {
  switch (l) {
    case tetopt::LogLevel::Debug: return "debug";
    case tetopt::LogLevel::Info: return "info";
    case tetopt::LogLevel::Progress: return "progress";
    case tetopt::LogLevel::Warning: return "warning";
  }
  return "info";
}

/// How often the waiting thread runs Python's signal handlers during improve().
constexpr int kSignalPollMs = 10;

/// Runs improve() on a prepared mesh on a worker thread, the GIL released;
/// returns the report JSON (the CLI's --report content).  Ctrl-C: see the
/// top of this file.  Exceptions from the user's callbacks are re-raised
/// after improve() has returned (a callback that raises also stops the run).
/// A progress callback returning False stops the run: the report says
/// "stopped_early": true and the mesh is valid and checked.
/// As `tetopt improve` (without --keep-order), the tets of each region are
/// then put together again, regions in the input's order (one Gmsh block
/// per entity), each region's tets in improve's order.
std::string run_improve(TetMesh& m, tetopt::ImproveOptions& opt, const py::object& log, const py::object& progress,
                        std::chrono::steady_clock::time_point t0, const std::string& input) {
  std::atomic<bool> stop{false};
  std::optional<py::error_already_set> pending;  // destroyed with the GIL held
  tetopt::LogFn fn;
  if (!log.is_none())
    fn = [&](tetopt::LogLevel lvl, const std::string& msg) {
      py::gil_scoped_acquire gil;
      if (pending) return;
      try {
        log(level_name(lvl), msg);
      } catch (py::error_already_set& e) {
        pending.emplace(std::move(e));
        stop = true;
      }
    };
  if (!progress.is_none())
    opt.progress = [&](const tetopt::ImproveProgress& p) {
      py::gil_scoped_acquire gil;
      if (pending) return false;
      try {
        py::object r = progress(p.phase, p.round, p.fraction, p.worst);
        // None (a callback that only prints) goes on; False stops.
        return r.is_none() || PyObject_IsTrue(r.ptr()) != 0;
      } catch (py::error_already_set& e) {
        pending.emplace(std::move(e));
        stop = true;
        return false;
      }
    };
  tetopt::ImproveReport rep;
  Status s;
  tetopt::MeasureStats measures_before, measures_after;  // the report's measures_before_after, as the CLI's
  std::exception_ptr failure;
  std::mutex mu;
  std::condition_variable cv;
  bool done = false;
  {
    py::gil_scoped_release nogil;
    std::thread worker([&] {
      try {
        measures_before = tetopt::compute_measure_stats(m, opt.threads);
        const std::vector<tetopt::RegionKey> regions = tetopt::region_key_order(m);
        s = tetopt::improve(m, opt, rep, fn, &stop);
        std::vector<int32_t> new_id;
        if (s.mesh_valid() && !stop && regions.size() > 1 && tetopt::group_tets_by_region(m, regions, &new_id)) {
          if (rep.after.worst_tet >= 0 && rep.after.worst_tet < static_cast<int32_t>(new_id.size()))
            rep.after.worst_tet = new_id[static_cast<size_t>(rep.after.worst_tet)];
          if (Status b = tetopt::build_topology(m, opt.threads); !b) s = b;
        }
        if (s.mesh_valid() && !stop) measures_after = tetopt::compute_measure_stats(m, opt.threads);
      } catch (...) {
        failure = std::current_exception();
      }
      std::lock_guard<std::mutex> lk(mu);
      done = true;
      cv.notify_all();
    });
    bool interrupted = false;
    for (;;) {
      {
        std::unique_lock<std::mutex> lk(mu);
        if (cv.wait_for(lk, std::chrono::milliseconds(kSignalPollMs), [&] { return done; })) break;
      }
      if (interrupted) continue;
      py::gil_scoped_acquire gil;
      if (PyErr_CheckSignals() != 0) {  // a handler raised (KeyboardInterrupt): stop, then re-raise
        interrupted = true;
        py::error_already_set e;
        if (!pending) pending.emplace(std::move(e));
        stop = true;
      }
    }
    worker.join();
  }
  if (pending) throw std::move(*pending);
  if (failure) std::rethrow_exception(failure);
  if (!s.stopped()) throw_status(s, "improve");
  std::string js = tetopt::report_to_json(rep, opt, input, "");
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // The arrays are improved in the order given (the CLI may put a large
  // scattered mesh in Morton order first; here the caller owns the order).
  // No file is written here: nothing is dropped on a write.
  js.insert(js.size() - 2, ",\n  \"seconds_end_to_end\": " + std::to_string(total) +
                               ",\n  \"tets_reordered\": false,\n  \"dropped_on_write\": [],\n  \"measures_before_after\": " +
                               tetopt::measures_before_after_json(measures_before, measures_after));
  return js;
}

/// The CLI's improve report keeps the 1000 worst tets of the diagnosis, and
/// says before it what --allow-insert could buy ("insertion_hint", issue 27):
/// {"insertion_hint": ..., "diagnosis": ...}, which _with_diagnosis unpacks.
py::object improve_diagnosis(const TetMesh& m, const tetopt::ImproveOptions& opt, const PyImproveOptions& popt) {
  if (!popt.diagnose) return py::none();
#if TETOPT_PY_HAVE_DIAGNOSE
  std::string dj, hj;
  {
    py::gil_scoped_release nogil;
    tetopt::DiagnoseOptions dopt;
    dopt.threshold = opt.threshold;
    dopt.mesh_bound = true;
    dopt.all_measures = opt.objective != tetopt::Objective::Alpha;
    dopt.walls = false;  // as tetopt improve's summary (DiagnoseOptions::walls)
    const tetopt::Diagnosis d = tetopt::diagnose(m, dopt);
    double worst = INFINITY;
    for (int32_t t = 0; t < m.nt(); ++t) worst = std::min(worst, tetopt::tet_alpha(m, t));
    hj = tetopt::insertion_hint_to_json(
        tetopt::insertion_hint(d, worst, opt.mode == tetopt::ImproveMode::Best && !opt.allow_insert));
    dj = tetopt::diagnosis_to_json(d, 1000, 2);
  }
  return py::str("{\"insertion_hint\": " + hj + ", \"diagnosis\": " + dj + "}");
#else
  return py::str(diagnosis_json(m, opt.threshold, 1000, nullptr, opt.objective != tetopt::Objective::Alpha));
#endif
}

py::tuple improve_arrays(py::handle points, py::handle tets, py::handle refs, py::handle constrained_faces,
                         const PyImproveOptions& popt, const py::object& log, const py::object& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  tetopt::ImproveOptions opt = to_options(popt);
  TetMesh m;
  get_points(points, m.xyz);
  get_index_array(tets, m.tets, "tets", 4, false, m.nv(), "points");
  if (m.nt() == 0) throw py::value_error("tets: the mesh has no tetrahedra");
  if (get_ints(refs, m.tet_ref, "refs", 0, true)) {
    if (m.tet_ref.size() != m.tets.size() / 4)
      throw py::value_error("refs: expected " + std::to_string(m.nt()) + " entries (one per tet), got " +
                            std::to_string(m.tet_ref.size()));
  } else {
    m.tet_ref.assign(static_cast<size_t>(m.nt()), 0);
  }
  get_index_array(constrained_faces, m.tris, "constrained_faces", 3, true, m.nv(), "points");
  m.tri_ref.assign(m.tris.size() / 3, 0);
  throw_status(tetopt::check_arrays(m, "mesh"));
  // Inverted or flat tets are untangled by improve(), as in the CLI.
  const tetopt::OrientationReport orient = prepare(m);
  const std::string js = run_improve(m, opt, log, progress, t0, "<arrays>");
  py::object dj = improve_diagnosis(m, opt, popt);
  if (orient.flipped)  // hand the tets back in the caller's (negative) convention
    for (int32_t t = 0; t < m.nt(); ++t) std::swap(m.tets[4 * size_t(t) + tetopt::kFlipA], m.tets[4 * size_t(t) + tetopt::kFlipB]);
  const auto nv = static_cast<py::ssize_t>(m.nv());
  return py::make_tuple(to_numpy(std::move(m.xyz), {nv, 3}), rows(std::move(m.tets), 4), vec(std::move(m.tet_ref)),
                        js, dj);
}

py::tuple improve_mesh(const py::dict& d, const PyImproveOptions& popt, const py::object& log,
                       const py::object& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  tetopt::ImproveOptions opt = to_options(popt);
  TetMesh m = mesh_from_dict(d);
  prepare(m);  // improve() untangles inverted or flat tets, as in the CLI
  const std::string js = run_improve(m, opt, log, progress, t0, "<mesh>");
  py::object dj = improve_diagnosis(m, opt, popt);
  return py::make_tuple(mesh_to_dict(std::move(m)), js, dj);
}

// ---------------------------------------------------------------- quality

py::tuple quality_mesh(const py::dict& d, bool diagnose, double threshold) {
  if (!(threshold > 0 && threshold <= 1))  // checked as the CLI's --threshold, used or not
    throw py::value_error("threshold: must be in (0, 1], got " + py::repr(py::float_(threshold)).cast<std::string>());
  TetMesh m = mesh_from_dict(d);
  prepare(m);
  tetopt::QualityStats st;
  tetopt::TetQualityFields f;
  {
    py::gil_scoped_release nogil;
    st = tetopt::compute_stats(m, 1, /*measures=*/true);  // as `tetopt quality --json`
    f = tetopt::compute_fields(m);
  }
  const auto nt = static_cast<py::ssize_t>(m.nt());
  std::vector<int8_t> kind(m.tet_kind.begin(), m.tet_kind.end());
  py::object dj = py::none(), classes = py::none();
  if (diagnose) {  // as `tetopt quality --json`: the 100 worst tets
    std::vector<uint8_t> cls;
    dj = py::str(diagnosis_json(m, threshold, 100, &cls, true));
    classes = to_numpy(std::vector<int8_t>(cls.begin(), cls.end()), {nt});
  }
  return py::make_tuple(tetopt::stats_to_json(st), dj, classes, to_numpy(std::move(f.alpha), {nt}),
                        to_numpy(std::move(f.dihedral_min), {nt}), to_numpy(std::move(f.dihedral_max), {nt}),
                        to_numpy(std::move(kind), {nt}));
}

// ---------------------------------------------------------------- files

std::string path_str(const py::handle& p) {
  py::object fs = py::module_::import("os").attr("fspath")(p);
  if (!py::isinstance<py::str>(fs)) throw py::value_error("path: expected a str or os.PathLike of str");
  std::string s = fs.cast<std::string>();
  // The C library would stop at the byte: the message named a shorter path.
  if (const size_t nul = s.find('\0'); nul != std::string::npos)
    throw py::value_error("path: contains a NUL character (after '" + s.substr(0, nul) + "')");
  return s;
}

py::tuple read_file(const py::handle& path) {
  const std::string p = path_str(path);
  TetMesh m;
  tetopt::OrientationReport orient;
  Status s;
  {
    py::gil_scoped_release nogil;
    s = tetopt::read_mesh(p, m, &orient);
  }
  throw_status(s);
  return py::make_tuple(mesh_to_dict(std::move(m)), vec(std::move(orient.inverted)), vec(std::move(orient.flat_tets)));
}

/// Writes the mesh; returns what the format cannot hold and left out
/// (tetopt::dropped_by_format), for the Python side's warning.
py::list write_file(const py::handle& path, const py::dict& d, int msh_version, bool binary, int meshb_version) {
  const std::string p = path_str(path);
  if (tetopt::format_from_path(p) == tetopt::Format::Unknown)
    throw py::value_error(p + ": unknown extension (use .mesh .meshb .msh .vtk .vtu .node/.ele)");
  if (msh_version != 22 && msh_version != 41)
    throw py::value_error("msh_version: expected 22 or 41, got " + std::to_string(msh_version));
  if (meshb_version < 2 || meshb_version > 4)
    throw py::value_error("meshb_version: expected 2, 3 or 4, got " + std::to_string(meshb_version));
  TetMesh m = mesh_from_dict(d);
  tetopt::WriteOptions wo;
  wo.msh_version = msh_version;
  wo.binary = binary;
  wo.meditb_version = meshb_version;
  const std::vector<std::string> lost = tetopt::dropped_by_format(m, tetopt::format_from_path(p), wo);
  Status s;
  {
    py::gil_scoped_release nogil;
    s = tetopt::write_mesh(p, m, wo);
  }
  throw_status(s);
  py::list out;
  for (const std::string& x : lost) out.append(x);
  return out;
}

}  // namespace

PYBIND11_MODULE(_tetopt, mod) {
  mod.doc() = "Low-level bindings of the tetopt C++ library; use the `tetopt` package instead.";
  mod.attr("__version__") = "0.1.0";

  py::class_<PyImproveOptions>(mod, "ImproveOptions", "Options of improve() (see tetopt.improve).")
      .def(py::init<>())
      .def_readwrite("mode", &PyImproveOptions::mode)
      .def_readwrite("optimizer", &PyImproveOptions::optimizer)
      .def_readwrite("weight", &PyImproveOptions::weight)
      .def_readwrite("threshold", &PyImproveOptions::threshold)
      .def_readwrite("iterations", &PyImproveOptions::iterations)
      .def_readwrite("seed", &PyImproveOptions::seed)
      .def_readwrite("threads", &PyImproveOptions::threads)
      .def_readwrite("check", &PyImproveOptions::check)
      .def_readwrite("diagnose", &PyImproveOptions::diagnose)
      .def_readwrite("allow_insert", &PyImproveOptions::allow_insert)
      .def_readwrite("allow_remove", &PyImproveOptions::allow_remove)
      .def_readwrite("objective", &PyImproveOptions::objective)
      .def_readwrite("guard", &PyImproveOptions::guard)
      .def_readwrite("polish", &PyImproveOptions::polish)
      .def_readwrite("size", &PyImproveOptions::size)
      .def_readwrite("remesh", &PyImproveOptions::remesh)
      .def_readwrite("gradation", &PyImproveOptions::gradation);
  mod.attr("HAVE_DIAGNOSE") = py::bool_(TETOPT_PY_HAVE_DIAGNOSE != 0);

  mod.def("improve_arrays", &improve_arrays, py::arg("points"), py::arg("tets"), py::arg("refs"),
          py::arg("constrained_faces"), py::arg("options"), py::arg("log"), py::arg("progress") = py::none(),
          "improve_arrays(points, tets, refs, constrained_faces, options, log, progress) -> (points, tets, refs, report_json, diagnosis_json|None)");
  mod.def("improve_mesh", &improve_mesh, py::arg("mesh"), py::arg("options"), py::arg("log"),
          py::arg("progress") = py::none(),
          "improve_mesh(mesh_dict, options, log, progress) -> (mesh_dict, report_json, diagnosis_json|None)");
  mod.def("quality_mesh", &quality_mesh, py::arg("mesh"), py::arg("diagnose"), py::arg("threshold"),
          "quality_mesh(mesh_dict, diagnose, threshold) -> (stats_json, diagnosis_json|None, classes|None, alpha, "
          "dihedral_min, dihedral_max, kind)");
  mod.def("read", &read_file, py::arg("path"), "read(path) -> (mesh_dict, inverted_ids, flat_ids)");
  mod.def("write", &write_file, py::arg("path"), py::arg("mesh"), py::arg("msh_version"), py::arg("binary"),
          py::arg("meshb_version"), "write(path, mesh_dict, msh_version, binary, meshb_version)");
  mod.def("validate_mesh", [](const py::dict& d) { mesh_from_dict(d); }, py::arg("mesh"),
          "Raises ValueError when the mesh dict is not a valid tetopt mesh.");
}
