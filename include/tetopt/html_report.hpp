// tetopt/html_report.hpp — one self-contained HTML page about a mesh or a run.
//
// The page needs nothing but itself: inline CSS, inline SVG charts, a few
// lines of inline script (a log/linear toggle for the histograms; the page
// reads fully without it), system fonts only, no network.  It shows what the
// paper's Figures 5 and 8 show — the distribution of alpha and of the
// dihedral angles, before and after — plus the statistics in the paper's
// columns (Tables 1–3), time per phase, operation counts, the diagnosis of
// every tet left below the threshold (diagnose.hpp) with the worst ones
// listed, and the boundary-unchanged verdict.
//
// A "Measures" section shows every measure of measures.hpp (table
// id="measures", one <tr data-measure="KEY"> each: worst, mean, the counts
// failing the documented thresholds with their sources) and its histogram.
//
// Structure the tests rely on: each histogram is an <svg class="hist"> with
// id "hist-alpha", "hist-dihedral" or "hist-KEY" (KEY a measure's JSON key:
// hist-sine_min, hist-non_orthogonality, ...) holding one <rect class="bar
// ..."> per bin and series (data-count = the count); the script sets
// data-report-ready="1" on <html> when it has run.
//
// A "Where they are" view (view3d.hpp; issue 30), inside the diagnosis
// section when HtmlReportInput::mesh is given: the boundary surface and the
// poor tets drawn with three.js, which the library carries (inlined at build
// time from node_modules, cmake/view3d.cmake), so the page still needs no
// network.  Its data is one <script type="application/json" id="tv-data">;
// the rows of the worst-tets table carry data-tet="ID" (0-based) and fly the
// camera to their tet when clicked; the script sets data-view-ready="1" on
// <html> after its first frame.  Built with TETOPT_VIEW3D=OFF, the section
// says the view is not built in.
//
// Pure formatting: nothing here modifies a mesh or prints.
#pragma once
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "tetopt/diagnose.hpp"
#include "tetopt/improve.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/status.hpp"
#include "tetopt/view3d.hpp"

namespace tetopt {

/// Counts of values in equal bins over [lo, hi]; values outside go to the
/// first or last bin.
struct Histogram {
  double lo = 0, hi = 1;
  std::vector<int64_t> counts;
};

/// alpha of every tet and the six dihedral angles of every tet, binned.
struct QualityHistograms {
  Histogram alpha;     ///< over [0, 1]; alpha <= 0 goes to the first bin
  Histogram dihedral;  ///< over [0, 180] degrees, 6 angles per tet
};

/// Bins the tets of m: `alpha_bins` over [0,1], `dihedral_bins` over [0,180].
QualityHistograms quality_histograms(const TetMesh& m, int alpha_bins = 20, int dihedral_bins = 36);

/// What the page shows.  Pointers may be null: the matching section then
/// says "not applicable" (e.g. `tetopt quality` has no run and no "after").
struct HtmlReportInput {
  std::string title = "tetopt report";
  std::string input, output;        ///< file names as given
  QualityStats before;
  QualityHistograms before_hist;
  bool has_after = false;
  QualityStats after;
  QualityHistograms after_hist;
  const ImproveReport* run = nullptr;
  const ImproveOptions* options = nullptr;
  double seconds_end_to_end = NAN;  ///< reading + improving + writing (NaN: not shown)
  const Diagnosis* diagnosis = nullptr;
  /// What --allow-insert could buy (diagnose.hpp); shown in the diagnosis
  /// section as <p id="insertion-hint"> when show is set; null: none.
  const InsertionHint* insertion_hint = nullptr;
  size_t max_tets_listed = 50;      ///< rows of the worst-tets table
  /// The 3D view: the mesh the diagnosis describes (after the run, for
  /// improve), with its topology; null: no view.  Needs `diagnosis` too.
  const TetMesh* mesh = nullptr;
  /// improve: the input's tets below the threshold (view_poor_tets before
  /// the run, ids in the input's numbering); null: no "before" in the view.
  const ViewTets* poor_before = nullptr;
  size_t view_surface_budget = 300000;  ///< boundary triangles drawn before decimating (view_surface)
  /// Poor tets in the view, the worst first: all for one set, half each
  /// when there is a "before" (the caller makes poor_before with half).
  /// With the surface budget this bounds the page: about 7 MB of surface,
  /// 6 MB of tets and 0.8 MB of three.js at most.
  size_t view_max_tets = 50000;
};

/// The page as one string (UTF-8).
std::string html_report(const HtmlReportInput& in);

/// Writes html_report(in) to path atomically.
Status write_html_report(const std::string& path, const HtmlReportInput& in);

}  // namespace tetopt
