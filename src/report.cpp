// Quality tables, histograms and the per-tet field file (see report.hpp).
#include "tetopt/report.hpp"

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>

#include "tetopt/io.hpp"

namespace tetopt {

namespace {
std::string fmt(const char* f, double x) {
  if (std::isnan(x)) {
    const int w = std::atoi(f + 1);  // the field width of "%9.4f" and the like
    return std::string(static_cast<size_t>(w > 1 ? w - 1 : 0), ' ') + "-";
  }
  char b[64];
  std::snprintf(b, sizeof b, f, x);
  return b;
}
std::string bar(int64_t n, int64_t max, int width) {
  if (max <= 0 || n <= 0) return "";
  const int w = std::max<int>(1, static_cast<int>(std::llround(static_cast<double>(n) * width / max)));
  return std::string(static_cast<size_t>(w), '#');
}
}  // namespace

std::string format_stats_table(const QualityStats& s) {
  std::ostringstream o;
  o << "  vertices " << s.vertices << ", tets " << s.tets << " (interior " << s.kind_count[0] << ", boundary "
    << s.boundary_tets << ", all-boundary " << s.all_boundary_tets << "), regions " << s.regions << "\n";
  o << "                 worst α    mean α\n";
  o << "  overall      " << fmt("%9.4f", s.alpha_worst) << " " << fmt("%9.4f", s.alpha_mean) << "\n";
  o << "  boundary     " << fmt("%9.4f", s.alpha_boundary_worst) << " " << fmt("%9.4f", s.alpha_boundary_mean)
    << "\n";
  o << "  interior     " << fmt("%9.4f", s.alpha_interior_worst) << " " << fmt("%9.4f", s.alpha_interior_mean)
    << "\n";
  o << "  dihedral     " << fmt("%.2f", s.dihedral_min) << "° .. " << fmt("%.2f", s.dihedral_max) << "°\n";
  o << "  α<0.1: " << s.alpha_below_01 << "  α<0.2: " << s.alpha_below_02 << "  α<0.3: " << s.alpha_below_03
    << "  inverted/flat: " << s.inverted_or_flat << "  tets with an angle <5°: " << s.dihedral_below_5
    << "  >175°: " << s.dihedral_above_175 << "\n";
  if (s.measures.computed) o << format_measures_table(s.measures);
  return o.str();
}

std::string format_measures_table(const MeasureStats& ms) {
  std::ostringstream o;
  o << "  measure (better)                        worst       mean      ideal  fail counts\n";
  for (const MeasureInfo& mi : kMeasures) {
    if (mi.per_face && !ms.faces_measured) continue;
    const MeasureSummary& x = ms[mi.id];
    const bool deg = mi.unit[0] != '\0';
    const char* f = deg ? "%10.2f" : "%10.4f";
    char name[64];
    std::snprintf(name, sizeof name, "%s (%s)", mi.key, mi.better == Better::Higher ? "higher" : "lower");
    char head[80];
    std::snprintf(head, sizeof head, "  %-36s", name);
    o << head << fmt(f, x.worst) << " " << fmt(f, x.mean) << " " << fmt(f, mi.ideal) << " ";
    for (int k = 0; k < mi.n_thresholds; ++k)
      o << " " << mi.thresholds[k].meaning << ": " << x.fail[static_cast<size_t>(k)]
        << (k + 1 < mi.n_thresholds ? "," : "");
    o << "\n";
    if (mi.bands.n > 0) {
      o << "  " << std::string(36, ' ') << " bands:";
      for (int k = 0; k < mi.bands.n; ++k) o << " " << mi.bands.name[k] << " " << x.band[static_cast<size_t>(k)];
      o << "\n";
    }
  }
  if (ms.faces_measured)
    o << "  faces: " << ms.interior_faces << " interior, " << ms.boundary_faces
      << " boundary; checkMesh's average non-orthogonality " << fmt("%.2f", ms.non_orthogonality_checkmesh_average)
      << "°, skewness worst interior " << fmt("%.4f", ms.skewness_interior_worst) << ", boundary "
      << fmt("%.4f", ms.skewness_boundary_worst) << "\n";
  return o.str();
}

std::string format_before_after(const QualityStats& b, const QualityStats& a, double seconds) {
  std::ostringstream o;
  o << "                 overall α           boundary α          dihedral (deg)\n";
  o << "                 worst     mean      worst     mean      min      max\n";
  auto row = [&](const char* name, const QualityStats& s) {
    o << "  " << name << fmt("%9.4f", s.alpha_worst) << " " << fmt("%9.4f", s.alpha_mean) << " "
      << fmt("%9.4f", s.alpha_boundary_worst) << " " << fmt("%9.4f", s.alpha_boundary_mean) << "  "
      << fmt("%7.2f", s.dihedral_min) << "  " << fmt("%7.2f", s.dihedral_max) << "\n";
  };
  row("before       ", b);
  row("after        ", a);
  o << "  tets " << b.tets << " -> " << a.tets << ", all-boundary " << b.all_boundary_tets << " -> "
    << a.all_boundary_tets << ", α<0.1: " << b.alpha_below_01 << " -> " << a.alpha_below_01
    << ", time " << fmt("%.3f", seconds) << " s\n";
  return o.str();
}

std::string format_histograms(const QualityStats& s) {
  std::ostringstream o;
  const int64_t ma = *std::max_element(s.alpha_histogram.begin(), s.alpha_histogram.end());
  o << "  α histogram\n";
  for (size_t i = 0; i < s.alpha_histogram.size(); ++i) {
    char b[64];
    std::snprintf(b, sizeof b, "  %.1f-%.1f %10lld ", i / 10.0, (i + 1) / 10.0,
                  static_cast<long long>(s.alpha_histogram[i]));
    o << b << bar(s.alpha_histogram[i], ma, 40) << "\n";
  }
  const int64_t md = *std::max_element(s.dihedral_histogram.begin(), s.dihedral_histogram.end());
  o << "  dihedral angle histogram (degrees)\n";
  for (size_t i = 0; i < s.dihedral_histogram.size(); ++i) {
    char b[64];
    std::snprintf(b, sizeof b, "  %3zu-%3zu %10lld ", i * 10, (i + 1) * 10,
                  static_cast<long long>(s.dihedral_histogram[i]));
    o << b << bar(s.dihedral_histogram[i], md, 40) << "\n";
  }
  if (s.measures.computed) o << format_measure_histograms(s.measures);
  return o.str();
}

std::string format_measure_histograms(const MeasureStats& ms) {
  std::ostringstream o;
  for (const MeasureInfo& mi : kMeasures) {
    if (mi.id == Measure::Alpha) continue;  // format_histograms' first one
    if (mi.per_face && !ms.faces_measured) continue;
    const MeasureSummary& x = ms[mi.id];
    if (x.histogram.empty()) continue;
    const bool deg = mi.unit[0] != '\0';
    o << "  " << mi.key << " histogram (" << (mi.per_face ? "one per face" : "one per tet")
      << "; the first bin holds the values below it, the last those above)\n";
    // At most 10 rows: adjacent bins merged (the JSON and HTML keep them all).
    const size_t n = x.histogram.size(), group = (n + 9) / 10;
    std::vector<int64_t> rows;
    for (size_t i = 0; i < n; ++i) {
      if (i % group == 0) rows.push_back(0);
      rows.back() += x.histogram[i];
    }
    const int64_t mx = *std::max_element(rows.begin(), rows.end());
    for (size_t r = 0; r < rows.size(); ++r) {
      const double w = (mi.hist_hi - mi.hist_lo) / static_cast<double>(n);
      const double lo = mi.hist_lo + w * static_cast<double>(r * group);
      const double hi = mi.hist_lo + w * static_cast<double>(std::min(n, (r + 1) * group));
      char b[80];
      std::snprintf(b, sizeof b, deg ? "  %6.1f-%-6.1f %10lld " : "  %6.3f-%-6.3f %10lld ", lo, hi,
                    static_cast<long long>(rows[r]));
      o << b << bar(rows[r], mx, 40) << "\n";
    }
  }
  return o.str();
}

namespace {
// Length of the well-formed UTF-8 sequence at s[i] (RFC 3629, section 4:
// no overlong forms, no surrogates, nothing past U+10FFFF), 0 if there is none.
size_t utf8_length(const std::string& s, size_t i) {
  const auto b = [&](size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char c = b(i);
  if (c < 0x80) return 1;
  const size_t n = c >= 0xC2 && c <= 0xDF ? 2 : c >= 0xE0 && c <= 0xEF ? 3 : c >= 0xF0 && c <= 0xF4 ? 4 : 0;
  if (n == 0 || i + n > s.size()) return 0;
  for (size_t k = 1; k < n; ++k)
    if ((b(i + k) & 0xC0) != 0x80) return 0;
  const unsigned char d = b(i + 1);
  if ((c == 0xE0 && d < 0xA0) || (c == 0xED && d > 0x9F) || (c == 0xF0 && d < 0x90) || (c == 0xF4 && d > 0x8F)) return 0;
  return n;
}
}  // namespace

std::string json_string(const std::string& s) {
  // JSON text is Unicode (RFC 8259, section 8.1): a byte that is not part of
  // well-formed UTF-8 (a file name in another encoding) becomes U+FFFD.
  std::string o = "\"";
  for (size_t i = 0; i < s.size();) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    const size_t n = utf8_length(s, i);
    if (n == 0) { o += "\\ufffd"; ++i; continue; }
    if (n > 1) { o.append(s, i, n); i += n; continue; }
    if (c == '"' || c == '\\') { o += '\\'; o += static_cast<char>(c); }
    else if (c == '\n') o += "\\n";
    else if (c == '\t') o += "\\t";
    else if (c < 0x20 || c == 0x7F) { char b[8]; std::snprintf(b, sizeof b, "\\u%04x", c); o += b; }
    else o += static_cast<char>(c);
    ++i;
  }
  return o + "\"";
}

std::string valid_utf8(const std::string& s) {
  std::string o;
  o.reserve(s.size());
  for (size_t i = 0; i < s.size();) {
    const size_t n = utf8_length(s, i);
    if (n == 0) {
      o += "\xEF\xBF\xBD";  // U+FFFD
      ++i;
    } else {
      o.append(s, i, n);
      i += n;
    }
  }
  return o;
}

std::string json_string_list(const std::vector<std::string>& v) {
  std::string o = "[";
  for (size_t i = 0; i < v.size(); ++i) o += (i ? ", " : "") + json_string(v[i]);
  return o + "]";
}

namespace {
// RFC 4648 base64.
std::string base64(const unsigned char* p, size_t n) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string o;
  o.reserve((n + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < n; i += 3) {
    const uint32_t v = (p[i] << 16) | (p[i + 1] << 8) | p[i + 2];
    o += k[v >> 18]; o += k[(v >> 12) & 63]; o += k[(v >> 6) & 63]; o += k[v & 63];
  }
  if (i + 1 == n) {
    const uint32_t v = p[i] << 16;
    o += k[v >> 18]; o += k[(v >> 12) & 63]; o += "==";
  } else if (i + 2 == n) {
    const uint32_t v = (p[i] << 16) | (p[i + 1] << 8);
    o += k[v >> 18]; o += k[(v >> 12) & 63]; o += k[(v >> 6) & 63]; o += '=';
  }
  return o;
}
// VTK binary DataArray: UInt64 byte count header followed by the data, all base64.
template <class T>
std::string vtk_b64(const std::vector<T>& v) {
  std::string raw(sizeof(uint64_t) + v.size() * sizeof(T), '\0');
  const uint64_t nb = v.size() * sizeof(T);
  std::memcpy(raw.data(), &nb, sizeof nb);
  if (!v.empty()) std::memcpy(raw.data() + sizeof nb, v.data(), nb);
  return base64(reinterpret_cast<const unsigned char*>(raw.data()), raw.size());
}
}  // namespace

Status write_cell_fields_vtu(const std::string& path, const TetMesh& m, const std::vector<CellField>& fields) {
  const int32_t nt = m.nt();
  std::ostringstream o;
  o << "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
       "header_type=\"UInt64\">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\""
    << m.nv() << "\" NumberOfCells=\"" << nt << "\">\n";
  o << "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"binary\">\n"
    << vtk_b64(m.xyz) << "\n</DataArray>\n</Points>\n<Cells>\n";
  std::vector<int64_t> conn(m.tets.begin(), m.tets.end()), off(nt);
  for (int32_t t = 0; t < nt; ++t) off[t] = 4 * static_cast<int64_t>(t + 1);
  std::vector<uint8_t> types(nt, 10);
  o << "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"binary\">\n" << vtk_b64(conn) << "\n</DataArray>\n";
  o << "<DataArray type=\"Int64\" Name=\"offsets\" format=\"binary\">\n" << vtk_b64(off) << "\n</DataArray>\n";
  o << "<DataArray type=\"UInt8\" Name=\"types\" format=\"binary\">\n" << vtk_b64(types) << "\n</DataArray>\n";
  o << "</Cells>\n<CellData>\n";
  for (const CellField& f : fields) {
    if (f.values.size() != static_cast<size_t>(nt))
      return Status::error(ErrorCode::Invariant, path + ": field " + f.name + " has the wrong size");
    if (f.integer) {
      std::vector<int32_t> v(f.values.begin(), f.values.end());
      o << "<DataArray type=\"Int32\" Name=\"" << f.name << "\" format=\"binary\">\n" << vtk_b64(v)
        << "\n</DataArray>\n";
    } else {
      o << "<DataArray type=\"Float64\" Name=\"" << f.name << "\" format=\"binary\">\n" << vtk_b64(f.values)
        << "\n</DataArray>\n";
    }
  }
  o << "</CellData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";
  return write_file_atomic(path, o.str());
}

std::vector<CellField> quality_cell_fields(const TetMesh& m, int threads) {
  TetQualityFields q = compute_fields(m);
  std::vector<CellField> f;
  f.push_back({"alpha", std::move(q.alpha), false});
  f.push_back({"dihedral_min", std::move(q.dihedral_min), false});
  f.push_back({"dihedral_max", std::move(q.dihedral_max), false});
  f.push_back({"kind", std::vector<double>(m.tet_kind.begin(), m.tet_kind.end()), true});
  f.push_back({"region", std::vector<double>(m.tet_ref.begin(), m.tet_ref.end()), true});
  // The other measures of measures.hpp; a face measure as the worst over
  // the tet's faces.
  for (const MeasureInfo& mi : kMeasures) {
    if (mi.id == Measure::Alpha || mi.id == Measure::DihedralMin || mi.id == Measure::DihedralMax) continue;
    if (mi.per_face && m.adj.size() != m.tets.size()) continue;
    std::string name = mi.key;
    if (mi.id == Measure::NonOrthogonality) name = "non_orthogonality_max";
    if (mi.id == Measure::FaceSkewness) name = "face_skewness_max";
    f.push_back({name, compute_measure_field(m, mi.id, threads), false});
  }
  return f;
}

}  // namespace tetopt
