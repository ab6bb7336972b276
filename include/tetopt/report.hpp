// tetopt/report.hpp — human and machine readable views of a mesh's quality.
//
// Text tables in the paper's columns, text histograms, and a per-tet field
// file (.vtu with cell data) for ParaView.  Pure formatting: nothing here
// modifies a mesh or prints; callers decide where the text goes.
#pragma once
#include <string>
#include <vector>

#include "tetopt/mesh.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/status.hpp"

namespace tetopt {

/// Multi-line table: counts, worst/mean alpha overall, boundary (kinds 1-4)
/// and interior, dihedral range, counts below thresholds; then
/// format_measures_table where s.measures was computed.
std::string format_stats_table(const QualityStats& s);

/// The measures of measures.hpp, one line each: worst, mean, ideal, the
/// counts failing the table's thresholds (and Fluent's skewness bands), and
/// the face counts (format_stats_table ends with it).
std::string format_measures_table(const MeasureStats& s);

/// Before/after table in the paper's Table 2 columns plus the dihedral range.
std::string format_before_after(const QualityStats& before, const QualityStats& after, double seconds);

/// Text histograms of alpha (10 bins) and dihedral angles (18 bins of 10 deg).
/// Then, where s.measures was computed, the histogram of every other
/// measure of measures.hpp (format_measure_histograms).
std::string format_histograms(const QualityStats& s);
std::string format_measure_histograms(const MeasureStats& s);

/// A named per-tet array written as VTU cell data.
struct CellField {
  std::string name;
  std::vector<double> values;  ///< nt values
  bool integer = false;
};

/// Writes the tets of m (positive orientation) with the given cell fields as
/// an XML .vtu (base64 binary, Float64 points); atomic (temporary + rename).
Status write_cell_fields_vtu(const std::string& path, const TetMesh& m, const std::vector<CellField>& fields);

/// The standard quality fields of m: alpha, dihedral_min, dihedral_max,
/// kind, region, then sine_min, scaled_jacobian, radius_ratio, mean_ratio,
/// equivolume_skewness (measures.hpp) and, where m has face adjacency,
/// non_orthogonality_max and face_skewness_max (the worst of the tet's
/// faces).  Requires topology.  threads: for the new fields (same values
/// for every count).
std::vector<CellField> quality_cell_fields(const TetMesh& m, int threads = 1);

/// JSON string literal (quotes and escapes).
std::string json_string(const std::string& s);
/// s with every byte that is not part of well-formed UTF-8 replaced by
/// U+FFFD (HTML and other text outputs; json_string does the same).
std::string valid_utf8(const std::string& s);
/// JSON array of string literals.
std::string json_string_list(const std::vector<std::string>& v);

}  // namespace tetopt
