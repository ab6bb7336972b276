// The self-contained HTML report (see html_report.hpp).
#include "tetopt/html_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>

#include "detail/view3d_assets.hpp"

#include "tetopt/conventions.hpp"
#include "tetopt/io.hpp"
#include "tetopt/report.hpp"

namespace tetopt {

QualityHistograms quality_histograms(const TetMesh& m, int alpha_bins, int dihedral_bins) {
  QualityHistograms h;
  h.alpha = {0.0, 1.0, std::vector<int64_t>(static_cast<size_t>(std::max(1, alpha_bins)), 0)};
  h.dihedral = {0.0, 180.0, std::vector<int64_t>(static_cast<size_t>(std::max(1, dihedral_bins)), 0)};
  auto bin = [](const Histogram& hh, double x) {
    const int n = static_cast<int>(hh.counts.size());
    if (!(x > hh.lo)) return 0;  // also NaN
    return std::min(n - 1, static_cast<int>((x - hh.lo) / (hh.hi - hh.lo) * n));
  };
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    const double *a = m.point(v[0]), *b = m.point(v[1]), *c = m.point(v[2]), *d = m.point(v[3]);
    h.alpha.counts[static_cast<size_t>(bin(h.alpha, alpha(a, b, c, d)))]++;
    double dh[6];
    dihedral_angles(a, b, c, d, dh);
    for (double x : dh) h.dihedral.counts[static_cast<size_t>(bin(h.dihedral, x))]++;
  }
  return h;
}

namespace {

std::string esc(const std::string& raw) {
  // The page says charset utf-8: a file name in another encoding would make
  // it malformed (its bytes were copied as they were).
  const std::string s = valid_utf8(raw);
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      case '\'': o += "&#39;"; break;
      default: o += c;
    }
  }
  return o;
}

std::string f(const char* fmt, double x) {
  if (std::isnan(x)) return "–";
  char b[64];
  std::snprintf(b, sizeof b, fmt, x);
  return b;
}

const char* kStyle = R"(
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,"Helvetica Neue",Arial,sans-serif;margin:24px auto;max-width:1120px;color:#1f2933;background:#fff;line-height:1.4}
h1{font-size:1.6em;margin:0 0 4px}h2{font-size:1.2em;margin:28px 0 8px;border-bottom:1px solid #d9e2ec;padding-bottom:4px}
.files{color:#52606d;font-family:ui-monospace,Menlo,Consolas,monospace;font-size:.9em}
table{border-collapse:collapse;margin:6px 0;font-size:.92em}th,td{border:1px solid #d9e2ec;padding:3px 8px;text-align:right}
th{background:#f0f4f8;font-weight:600}td.l,th.l{text-align:left}
.verdict{display:inline-block;padding:8px 14px;border-radius:6px;font-weight:600;margin-top:10px}
.ok{background:#e3f9e5;color:#05400a;border:1px solid #57ae5b}.bad{background:#ffe3e3;color:#610404;border:1px solid #e12d39}
.na{background:#f0f4f8;color:#334e68;border:1px solid #9fb3c8}
.charts{display:flex;flex-wrap:wrap;gap:16px}.chart{border:1px solid #d9e2ec;border-radius:6px;padding:8px}
svg text{font-size:11px;fill:#334e68}.s0{fill:#9fb3c8}.s1{fill:#2680c2}.bar:hover{fill:#f0b429}
.c1{color:#ab091e}.c2{color:#8d2b0b}.c3{color:#0b6e4f}
button{font:inherit;padding:3px 10px;margin:4px 0}.note{color:#52606d;font-size:.88em}
.view3d{border:1px solid #d9e2ec;border-radius:6px;padding:8px}#tv-canvas{position:relative;height:560px;background:#f5f7fa;overflow:hidden}
#tv-canvas canvas{display:block;width:100%;height:100%}.tv-msg{padding:24px;color:#52606d}
.tv-row{margin:4px 0;font-size:.9em}.tv-row label{margin-right:10px}#tv-legend{font-size:.85em;margin:6px 0}
.tv-key{display:inline-block;margin:0 10px 2px 0}.tv-key i{display:inline-block;width:11px;height:11px;margin-right:4px;vertical-align:-1px;border:1px solid #9fb3c8}
.tv-ramp{display:inline-block;width:120px;height:10px;vertical-align:-1px;border:1px solid #9fb3c8}
tr.tv-link{cursor:pointer}tr.tv-link:hover td{background:#fffbea}tr.tv-sel td{background:#fff3c4}
)";

const char* kScript = R"(
(function(){
  var scale = 'log';
  function apply(){
    var svgs = document.querySelectorAll('svg.hist');
    for (var i = 0; i < svgs.length; ++i) {
      var svg = svgs[i], max = +svg.getAttribute('data-max'), h = +svg.getAttribute('data-plot-h'),
          base = +svg.getAttribute('data-base'), bars = svg.querySelectorAll('rect.bar');
      for (var j = 0; j < bars.length; ++j) {
        var c = +bars[j].getAttribute('data-count');
        var fr = max <= 0 ? 0 : (scale === 'log' ? Math.log(1 + c) / Math.log(1 + max) : c / max);
        var hh = fr * h; if (c > 0 && hh < 1) hh = 1;
        bars[j].setAttribute('height', hh.toFixed(2)); bars[j].setAttribute('y', (base - hh).toFixed(2));
      }
      var axes = svg.querySelectorAll('g.yaxis');
      for (var k = 0; k < axes.length; ++k)
        axes[k].style.display = axes[k].getAttribute('data-scale') === scale ? '' : 'none';
    }
    var b = document.getElementById('scale-toggle');
    if (b) b.textContent = scale === 'log' ? 'show counts on a linear scale' : 'show counts on a log scale';
  }
  var btn = document.getElementById('scale-toggle');
  if (btn) btn.addEventListener('click', function(){ scale = scale === 'log' ? 'linear' : 'log'; apply(); });
  apply();
  document.documentElement.setAttribute('data-report-ready', '1');
})();
)";

// A grouped bar chart of one or two histograms over the same bins.  Heights
// are drawn on a log(1+count) scale (the bad tail is a handful of tets among
// millions); the script can switch to linear.
// axis: the x axis label; first_below: the first bin also holds the
// inverted and flat tets (alpha).
std::string svg_histogram(const std::string& id, const std::string& title, const std::string& unit,
                          const std::vector<const Histogram*>& series, const std::vector<std::string>& names,
                          int label_every, const char* label_fmt, const char* bar_fmt, const std::string& axis,
                          bool first_below) {
  const Histogram& h0 = *series[0];
  const size_t nb = h0.counts.size();
  const double W = 520, H = 250, ml = 52, mr = 10, mt = 26, mb = 40;
  const double pw = W - ml - mr, ph = H - mt - mb, base = mt + ph;
  int64_t max = 0;
  for (const Histogram* h : series)
    for (int64_t c : h->counts) max = std::max(max, c);
  std::ostringstream o;
  o << "<svg class=\"hist\" id=\"" << id << "\" xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\""
    << H << "\" viewBox=\"0 0 " << W << " " << H << "\" data-max=\"" << max << "\" data-plot-h=\"" << ph
    << "\" data-base=\"" << base << "\" data-bins=\"" << nb << "\" data-series=\"" << series.size()
    << "\" role=\"img\" aria-label=\"" << esc(title) << "\">\n";
  o << "<text x=\"" << ml << "\" y=\"16\" style=\"font-size:13px;font-weight:600\">" << esc(title) << "</text>\n";
  // Legend.
  for (size_t s = 0; s < series.size(); ++s) {
    const double lx = W - mr - 150 + 80.0 * static_cast<double>(s);
    o << "<rect class=\"s" << (series.size() == 1 ? 1 : s) << "\" x=\"" << lx << "\" y=\"7\" width=\"10\" height=\"10\"/>"
      << "<text x=\"" << lx + 14 << "\" y=\"16\">" << esc(names[s]) << "</text>\n";
  }
  // Y axes: log (default) and linear, one shown at a time.
  auto y_of = [&](double frac) { return base - frac * ph; };
  o << "<g class=\"yaxis\" data-scale=\"log\">";
  for (int64_t p = 1; max > 0 && p <= max * 10; p *= 10) {
    if (p > max) break;
    const double y = y_of(std::log1p(static_cast<double>(p)) / std::log1p(static_cast<double>(max)));
    o << "<line x1=\"" << ml << "\" x2=\"" << ml + pw << "\" y1=\"" << y << "\" y2=\"" << y
      << "\" stroke=\"#e4e7eb\"/><text x=\"" << ml - 4 << "\" y=\"" << y + 4 << "\" text-anchor=\"end\">" << p
      << "</text>";
  }
  o << "</g>\n<g class=\"yaxis\" data-scale=\"linear\" style=\"display:none\">";
  for (int k = 1; max > 0 && k <= 4; ++k) {
    const double v = static_cast<double>(max) * k / 4;
    const double y = y_of(static_cast<double>(k) / 4);
    o << "<line x1=\"" << ml << "\" x2=\"" << ml + pw << "\" y1=\"" << y << "\" y2=\"" << y
      << "\" stroke=\"#e4e7eb\"/><text x=\"" << ml - 4 << "\" y=\"" << y + 4 << "\" text-anchor=\"end\">"
      << std::llround(v) << "</text>";
  }
  o << "</g>\n";
  // Bars.
  const double bw = pw / static_cast<double>(nb);
  const double gap = std::min(2.0, bw * 0.15);
  const double sw = (bw - gap) / static_cast<double>(series.size());
  for (size_t i = 0; i < nb; ++i) {
    const double lo = h0.lo + (h0.hi - h0.lo) * static_cast<double>(i) / static_cast<double>(nb);
    const double hi = h0.lo + (h0.hi - h0.lo) * static_cast<double>(i + 1) / static_cast<double>(nb);
    for (size_t s = 0; s < series.size(); ++s) {
      const int64_t c = series[s]->counts[i];
      double hh = max > 0 ? std::log1p(static_cast<double>(c)) / std::log1p(static_cast<double>(max)) * ph : 0;
      if (c > 0 && hh < 1) hh = 1;
      char b[64];
      std::snprintf(b, sizeof b, "%.2f", hh);
      const double x = ml + bw * static_cast<double>(i) + gap / 2 + sw * static_cast<double>(s);
      o << "<rect class=\"bar s" << (series.size() == 1 ? 1 : s) << "\" x=\"" << x << "\" y=\"" << base - hh
        << "\" width=\"" << std::max(0.5, sw - 0.5) << "\" height=\"" << b << "\" data-count=\"" << c
        << "\"><title>" << esc(names[s]) << ": "
        // The first alpha bin also holds the values below it (quality_histograms).
        << (i == 0 && first_below ? "below " + f(bar_fmt, hi) + " (inverted and flat tets included)"
                                   : f(bar_fmt, lo) + "–" + f(bar_fmt, hi) + unit)
        << ": " << c << "</title></rect>";
    }
    o << "\n";
  }
  // X axis.
  o << "<line x1=\"" << ml << "\" x2=\"" << ml + pw << "\" y1=\"" << base << "\" y2=\"" << base
    << "\" stroke=\"#52606d\"/>\n";
  for (size_t i = 0; i <= nb; i += static_cast<size_t>(label_every)) {
    const double x = ml + bw * static_cast<double>(i);
    const double v = h0.lo + (h0.hi - h0.lo) * static_cast<double>(i) / static_cast<double>(nb);
    o << "<line x1=\"" << x << "\" x2=\"" << x << "\" y1=\"" << base << "\" y2=\"" << base + 4
      << "\" stroke=\"#52606d\"/><text x=\"" << x << "\" y=\"" << base + 16 << "\" text-anchor=\"middle\">"
      << f(label_fmt, v) << "</text>";
  }
  o << "\n<text x=\"" << ml + pw / 2 << "\" y=\"" << H - 6 << "\" text-anchor=\"middle\">" << esc(axis)
    << "</text>\n</svg>\n";
  return o.str();
}

void stats_tables(std::ostringstream& o, const HtmlReportInput& in) {
  std::vector<std::pair<std::string, const QualityStats*>> rows = {{in.has_after ? "before" : "mesh", &in.before}};
  if (in.has_after) rows.push_back({"after", &in.after});
  o << "<h2>Statistics</h2>\n<p class=\"note\">Columns of the paper's Tables 1–3 (Liu et al. 2012): α = "
       "6√6·V / (Σ face areas · longest edge); boundary elements are tets with at least one constrained "
       "vertex (kinds 1–4).</p>\n";
  o << "<table id=\"stats\"><tr><th class=\"l\"></th><th>nodes</th><th>elements</th><th>worst α</th><th>mean α</th>"
       "<th>worst α boundary</th><th>mean α boundary</th><th>min dihedral</th><th>max dihedral</th></tr>\n";
  for (const auto& [name, s] : rows)
    o << "<tr><td class=\"l\">" << name << "</td><td>" << s->vertices << "</td><td>" << s->tets << "</td><td>"
      << f("%.4f", s->alpha_worst) << "</td><td>" << f("%.4f", s->alpha_mean) << "</td><td>"
      << f("%.4f", s->alpha_boundary_worst) << "</td><td>" << f("%.4f", s->alpha_boundary_mean) << "</td><td>"
      << f("%.2f°", s->dihedral_min) << "</td><td>" << f("%.2f°", s->dihedral_max) << "</td></tr>\n";
  o << "</table>\n";
  o << "<table id=\"counts\"><tr><th class=\"l\"></th><th>interior</th><th>kind 1</th><th>kind 2</th><th>kind 3</th>"
       "<th>all-boundary (kind 4)</th><th>α&lt;0.1</th><th>α&lt;0.2</th><th>α&lt;0.3</th><th>inverted/flat</th>"
       "<th>angle &lt;5°</th><th>angle &gt;175°</th><th>regions</th></tr>\n";
  for (const auto& [name, s] : rows) {
    o << "<tr><td class=\"l\">" << name << "</td>";
    for (int k = 0; k < 5; ++k) o << "<td>" << s->kind_count[k] << "</td>";
    o << "<td>" << s->alpha_below_01 << "</td><td>" << s->alpha_below_02 << "</td><td>" << s->alpha_below_03
      << "</td><td>" << s->inverted_or_flat << "</td><td>" << s->dihedral_below_5 << "</td><td>"
      << s->dihedral_above_175 << "</td><td>" << s->regions << "</td></tr>\n";
  }
  o << "</table>\n";
}

// Every measure of measures.hpp: a table (worst, mean, threshold counts,
// source) and a histogram each.
void measures_section(std::ostringstream& o, const HtmlReportInput& in) {
  std::vector<std::pair<std::string, const MeasureStats*>> rows = {{in.has_after ? "before" : "mesh",
                                                                    &in.before.measures}};
  if (in.has_after && in.after.measures.computed) rows.push_back({"after", &in.after.measures});
  const bool faces = in.before.measures.faces_measured && (rows.size() == 1 || in.after.measures.faces_measured);
  const bool two = rows.size() == 2;
  o << "<h2>Measures</h2>\n<p class=\"note\">Every measure a tet is judged by (docs/measures.md): per tet, "
       "and per face as OpenFOAM's checkMesh defines them (cell centre = tet centroid). Worst is the minimum "
       "where higher is better and the maximum where lower is better. Fail counts use the thresholds the "
       "tools document; hover a count for its source.</p>\n";
  o << "<table id=\"measures\"><tr><th class=\"l\">measure</th><th class=\"l\">better</th><th>ideal</th>";
  for (const auto& r : rows) o << "<th>worst " << r.first << "</th><th>mean " << r.first << "</th>";
  o << "<th class=\"l\">fail counts";
  if (two) o << " (before → after)";
  o << "</th><th class=\"l\">formula</th></tr>\n";
  for (const MeasureInfo& mi : kMeasures) {
    if (mi.per_face && !faces) continue;
    const bool deg = mi.unit[0] != '\0';
    const char* fm = deg ? "%.2f°" : "%.4f";
    o << "<tr data-measure=\"" << mi.key << "\"><td class=\"l\" title=\"" << esc(mi.source) << "\">"
      << esc(mi.name) << "</td><td class=\"l\">" << (mi.better == Better::Higher ? "higher" : "lower")
      << "</td><td>" << f(fm, mi.ideal) << "</td>";
    for (const auto& r : rows) {
      const MeasureSummary& x = (*r.second)[mi.id];
      o << "<td>" << f(fm, x.worst) << "</td><td>" << f(fm, x.mean) << "</td>";
    }
    o << "<td class=\"l\">";
    for (int k = 0; k < mi.n_thresholds; ++k) {
      o << (k ? "; " : "") << "<span title=\"" << esc(mi.thresholds[k].source) << "\">" << esc(mi.thresholds[k].meaning)
        << ": ";
      for (size_t j = 0; j < rows.size(); ++j)
        o << (j ? " → " : "") << (*rows[j].second)[mi.id].fail[static_cast<size_t>(k)];
      o << "</span>";
    }
    if (mi.bands.n > 0) {
      o << "<br><span title=\"" << esc(mi.bands.source) << "\">bands:";
      for (int k = 0; k < mi.bands.n; ++k) {
        o << " " << mi.bands.name[k] << " ";
        for (size_t j = 0; j < rows.size(); ++j)
          o << (j ? " → " : "") << (*rows[j].second)[mi.id].band[static_cast<size_t>(k)];
      }
      o << "</span>";
    }
    o << "</td><td class=\"l\">" << esc(mi.formula) << "</td></tr>\n";
  }
  o << "</table>\n";
  if (faces) {
    o << "<p id=\"faces\">Faces: " << in.before.measures.interior_faces << " interior, "
      << in.before.measures.boundary_faces << " boundary";
    if (two) o << " (after: " << in.after.measures.interior_faces << ", " << in.after.measures.boundary_faces << ")";
    o << ". checkMesh's average non-orthogonality (acos of the mean cosine): "
      << f("%.2f°", in.before.measures.non_orthogonality_checkmesh_average);
    if (two) o << " → " << f("%.2f°", in.after.measures.non_orthogonality_checkmesh_average);
    o << ". Skewness counts boundary faces too (checkMesh's boundaryFaceSkewness); worst interior "
      << f("%.4f", in.before.measures.skewness_interior_worst) << ", boundary "
      << f("%.4f", in.before.measures.skewness_boundary_worst) << ".</p>\n";
  } else {
    o << "<p class=\"note\">Face measures not computed (no face adjacency).</p>\n";
  }
  o << "<p class=\"note\">In each histogram the first bin also holds the values below its range and the last "
       "those above it.</p>\n<div class=\"charts\">\n";
  std::vector<std::string> names = {rows[0].first};
  if (two) names.push_back("after");
  for (const MeasureInfo& mi : kMeasures) {
    if (mi.id == Measure::Alpha) continue;  // drawn above
    if (mi.per_face && !faces) continue;
    std::vector<Histogram> hs;
    for (const auto& r : rows) hs.push_back({mi.hist_lo, mi.hist_hi, (*r.second)[mi.id].histogram});
    if (hs[0].counts.empty()) continue;
    std::vector<const Histogram*> ser;
    for (const Histogram& h : hs) ser.push_back(&h);
    const bool deg = mi.unit[0] != '\0';
    const int nb = mi.hist_bins;
    o << "<div class=\"chart\">"
      << svg_histogram(std::string("hist-") + mi.key,
                       std::string(mi.key) + (mi.per_face ? " (per face)" : " (per tet)"), deg ? "°" : "",
                       ser, names, std::max(1, nb / (deg ? 6 : 5)), deg ? "%.0f" : "%.2g", deg ? "%.0f" : "%.3g",
                       std::string(mi.key) + (deg ? " (degrees)" : ""), false)
      << "</div>\n";
  }
  o << "</div>\n";
}

void run_tables(std::ostringstream& o, const HtmlReportInput& in) {
  o << "<h2>Run</h2>\n";
  if (!in.run) {
    o << "<p class=\"note\">No improvement run (this page describes one mesh).</p>\n";
    return;
  }
  const ImproveReport& r = *in.run;
  if (in.options)
    o << "<p>mode <b>" << mode_name(in.options->mode) << "</b>, optimiser "
      << (in.options->maxmin_optimizer ? "maxmin" : "paper") << ", C = " << f("%.2f", in.options->weight)
      << ", threshold γ = " << f("%.3g", in.options->threshold) << ", seed " << in.options->seed << ", threads "
      << in.options->threads << ", " << r.rounds << " rounds</p>\n";
  o << "<table id=\"times\"><tr><th class=\"l\">phase</th><th>seconds</th></tr>\n"
    << "<tr><td class=\"l\">smoothing</td><td>" << f("%.3f", r.seconds_smooth) << "</td></tr>\n"
    << "<tr><td class=\"l\">topology</td><td>" << f("%.3f", r.seconds_topo) << "</td></tr>\n"
    << "<tr><td class=\"l\">invariant check</td><td>" << f("%.3f", r.seconds_check) << "</td></tr>\n"
    << "<tr><td class=\"l\">improve total</td><td>" << f("%.3f", r.seconds_total) << "</td></tr>\n";
  if (in.diagnosis)
    o << "<tr><td class=\"l\">diagnosis (after)</td><td>" << f("%.3f", in.diagnosis->seconds) << "</td></tr>\n";
  if (!std::isnan(in.seconds_end_to_end))
    o << "<tr><td class=\"l\">end to end (read, improve, write)</td><td>" << f("%.3f", in.seconds_end_to_end)
      << "</td></tr>\n";
  o << "</table>\n";
  o << "<table id=\"operations\"><tr><th class=\"l\">operation</th><th>applied</th></tr>\n"
    << "<tr><td class=\"l\">smoothing moves (of " << r.smooth_tried << " tried)</td><td>" << r.smooth_moves
    << "</td></tr>\n"
    << "<tr><td class=\"l\">2-3 flips</td><td>" << r.flip23 << "</td></tr>\n"
    << "<tr><td class=\"l\">3-2 flips</td><td>" << r.flip32 << "</td></tr>\n"
    << "<tr><td class=\"l\">2-2 flips</td><td>" << r.flip22 << "</td></tr>\n"
    << "<tr><td class=\"l\">4-4 flips</td><td>" << r.flip44 << "</td></tr>\n"
    << "<tr><td class=\"l\">edge removals</td><td>" << r.edge_removals << "</td></tr>\n"
    << "<tr><td class=\"l\">multi-face removals</td><td>" << r.multi_face_removals << "</td></tr>\n"
    << "<tr><td class=\"l\">pairs of the flips above made together (a worse first step, then a better second)</td><td>"
    << r.pair_flips << "</td></tr>\n"
    << "<tr><td class=\"l\">all-boundary tets removed</td><td>" << r.all_boundary_removed << "</td></tr>\n"
    << "<tr><td class=\"l\">vertices inserted</td><td>" << r.insertions << "</td></tr>\n"
    << "<tr><td class=\"l\">vertices removed</td><td>" << r.removals << "</td></tr>\n"
    << "</table>\n";
}

// ---- the 3D view (view3d.hpp, src/view3d.js) ----

template <class T>
std::string b64(const std::vector<T>& v) {
  return base64(v.data(), v.size() * sizeof(T));
}

std::string json_number(double x) {
  if (!std::isfinite(x)) return "null";
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", x);
  return b;
}

void set_json(std::ostringstream& o, const char* name, const std::string& label, const ViewTets& t,
              const double surface_origin[3]) {
  o << "{\"name\":\"" << name << "\",\"label\":\"" << label << "\",\"below\":" << t.below << ",\"offset\":["
    << json_number(t.origin[0] - surface_origin[0]) << "," << json_number(t.origin[1] - surface_origin[1]) << ","
    << json_number(t.origin[2] - surface_origin[2]) << "],\"xyz\":\"" << b64(t.xyz) << "\",\"tets\":\"" << b64(t.tets)
    << "\",\"ids\":\"" << b64(t.ids) << "\",\"alpha\":\"" << b64(t.alpha) << "\",\"dihedral_min\":\""
    << b64(t.dihedral_min) << "\",\"dihedral_max\":\"" << b64(t.dihedral_max) << "\",\"kind\":\"" << b64(t.kind) << "\"";
  if (!t.cls.empty() || t.ids.empty())
    o << ",\"cls\":\"" << b64(t.cls) << "\",\"best_alpha\":\"" << b64(t.best_alpha) << "\",\"cap_face\":\""
      << b64(t.cap_face) << "\",\"constrained_faces\":\"" << b64(t.constrained_faces) << "\"";
  o << "}";
}

// The section's visible part: the canvas box, its controls, what it shows.
// The data and the code follow at the end of the page (view_scripts).
void view_section(std::ostringstream& o, const HtmlReportInput& in, const ViewSurface* sp, const ViewTets* ap) {
  o << "<h3 id=\"where\">Where they are</h3>\n";
  if (!sp || !ap) {
    o << "<p class=\"note\" id=\"tv-off\">The 3D view is not built into this tetopt (configured with "
         "TETOPT_VIEW3D=OFF).</p>\n";
    return;
  }
  o << "<div class=\"view3d\" id=\"view3d\"><div id=\"tv-canvas\"><p class=\"tv-msg\">The 3D view needs "
       "JavaScript and WebGL.</p></div>\n<div id=\"tv-controls\"></div><div id=\"tv-legend\"></div>"
       "<div id=\"tv-info\"></div></div>\n<p class=\"note\" id=\"tv-notes\">";
  const ViewSurface& surf = *sp;
  const ViewTets& after = *ap;
  if (surf.decimated)
    o << "<span id=\"tv-decimated\">The constrained surface (boundary, region interfaces, listed triangles) has "
      << surf.triangles_full << " triangles, more than the view's "
      << "budget of " << in.view_surface_budget << ": it draws " << surf.tris.size() / 3
      << ", decimated for display only (vertex clustering, Rossignac and Borrel 1993); the mesh is unchanged.</span> ";
  else
    o << "The view draws all " << surf.triangles_full
      << " constrained triangles (boundary, region interfaces, listed triangles). ";
  auto shown = [&](const char* label, const ViewTets& t) {
    o << label << ": " << t.ids.size() << " tets with α &lt; " << f("%.3g", in.diagnosis->threshold);
    if (static_cast<int64_t>(t.ids.size()) < t.below) o << " shown, the worst of " << t.below;
    o << ". ";
  };
  if (in.poor_before) shown("Before", *in.poor_before);
  shown(in.has_after ? "After" : "Mesh", after);
  o << "Only the constrained surface and the poor tets are in the page. The surface is drawn see-through (opacity slider) "
       "and can be cut by a plane; tets are coloured by the measure chosen.</p>\n";
}

void view_scripts(std::ostringstream& o, const HtmlReportInput& in, const ViewSurface& surf, const ViewTets& after) {
  const detail::View3dAssets& a = detail::view3d_assets();
  if (!a.built_in) return;
  o << "<script type=\"application/json\" id=\"tv-data\">{\"version\":1,\"threshold\":"
    << json_number(in.diagnosis->threshold) << ",\"threshold_text\":\"" << f("%.3g", in.diagnosis->threshold)
    << "\",\"class_names\":[";
  for (int c = 0; c < 4; ++c) o << (c ? "," : "") << "\"" << tet_class_name(static_cast<TetClass>(c)) << "\"";
  o << "],\"face_vertex\":[";
  for (int fi = 0; fi < 4; ++fi)
    o << (fi ? "," : "") << "[" << kFaceVertex[fi][0] << "," << kFaceVertex[fi][1] << "," << kFaceVertex[fi][2] << "]";
  o << "],\"surface\":{\"origin\":[" << json_number(surf.origin[0]) << "," << json_number(surf.origin[1]) << ","
    << json_number(surf.origin[2]) << "],\"diagonal\":" << json_number(surf.bbox_diagonal)
    << ",\"by_patch\":" << (surf.by_patch ? "true" : "false") << ",\"total\":" << surf.triangles_full
    << ",\"decimated\":" << (surf.decimated ? "true" : "false") << ",\"xyz\":\"" << b64(surf.xyz) << "\",\"tris\":\""
    << b64(surf.tris) << "\",\"groups\":[";
  for (size_t g = 0; g < surf.group_ref.size(); ++g)
    o << (g ? "," : "") << "[" << surf.group_ref[g] << "," << surf.group_start[g] << "," << surf.group_count[g] << "]";
  o << "]},\"sets\":[";
  if (in.poor_before) {
    set_json(o, "before", "before", *in.poor_before, surf.origin);
    o << ",";
  }
  set_json(o, in.has_after ? "after" : "mesh", in.has_after ? "after" : "mesh", after, surf.origin);
  o << "]";
  const MeshBound& b = in.diagnosis->bound;
  if (b.alpha_tet >= 0 && b.alpha_tet < in.mesh->nt() && b.alpha_face >= 0 && b.alpha_face < 4 && std::isfinite(b.alpha)) {
    // The triangle holding the mesh-wide bound, drawn whether or not its
    // tet is poor.
    o << ",\"bound\":{\"tet\":" << b.alpha_tet << ",\"face\":" << b.alpha_face << ",\"alpha\":" << json_number(b.alpha)
      << ",\"xyz\":[";
    const int32_t* tv = in.mesh->tet(b.alpha_tet);
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k)
        o << (i || k ? "," : "") << json_number(in.mesh->point(tv[kFaceVertex[b.alpha_face][i]])[k] - surf.origin[k]);
    o << "]}";
  }
  o << "}</script>\n";
  o << "<script type=\"text/plain\" id=\"tv-three-core\">" << a.three_core << "</script>\n"
    << "<script type=\"text/plain\" id=\"tv-three-module\">" << a.three_module << "</script>\n"
    << "<script type=\"text/plain\" id=\"tv-three-orbit\">" << a.orbit_controls << "</script>\n"
    << "<script type=\"module\">" << a.app << "</script>\n";
}

void diagnosis_section(std::ostringstream& o, const HtmlReportInput& in, const ViewSurface* surf,
                       const ViewTets* after) {
  o << "<h2>Why are the remaining tets bad?</h2>\n";
  const Diagnosis* d = in.diagnosis;
  if (!d) {
    o << "<p class=\"note\">Diagnosis not computed.</p>\n";
    return;
  }
  const int64_t below = d->count[1] + d->count[2] + d->count[3];
  o << "<p>" << below << " of " << d->tets << " tets have α &lt; " << f("%.3g", d->threshold)
    << (in.has_after ? " after improvement" : "") << ".</p>\n";
  o << "<table id=\"diagnosis\"><tr><th class=\"l\">class</th><th>tets</th><th class=\"l\">meaning</th></tr>\n"
    << "<tr><td class=\"l c1\">locked by its boundary triangle</td><td>" << d->count[1]
    << "</td><td class=\"l\">a constrained face admits no apex with α ≥ γ: no boundary-preserving method can "
       "lift this tet above γ</td></tr>\n"
    << "<tr><td class=\"l c2\">locked by its constrained neighbours</td><td>" << d->count[2]
    << "</td><td class=\"l\">all four vertices constrained (cannot be smoothed); only a topological change "
       "could help, and none was found</td></tr>\n"
    << "<tr><td class=\"l c3\">improvable (not reached)</td><td>" << d->count[3]
    << "</td><td class=\"l\">no bound forbids a better tet here; the method did not reach it</td></tr>\n"
    << "</table>\n";
  const MeshBound& b = d->bound;
  if (b.triangles > 0 && !std::isnan(b.alpha))
    o << "<p id=\"bound\">Bound from the " << b.triangles
      << " constrained triangles (best apex searched per triangle): any mesh keeping them has worst α ≤ <b>"
      << f("%.4f", b.alpha) << "</b>, smallest dihedral ≤ " << f("%.2f°", b.dihedral_min)
      << ", largest dihedral ≥ " << f("%.2f°", b.dihedral_max) << ". The α bound comes from a face of tet "
      << b.alpha_tet + 1 << " at (" << f("%.6g", b.alpha_location[0]) << ", " << f("%.6g", b.alpha_location[1])
      << ", " << f("%.6g", b.alpha_location[2]) << ").</p>\n";
  if (const InsertionHint* h = in.insertion_hint; h && h->show) {
    o << "<p id=\"insertion-hint\">Inserting vertices could lift the worst α from <b>" << f("%.4f", h->worst_alpha)
      << "</b> toward <b>" << f("%.4f", h->estimate)
      << "</b>, the bound above: this run kept the vertex set, and flips and smoothing stop short of it";
    if (h->tets > 0)
      o << " (" << h->tets << " tets below α " << f("%.3g", d->threshold) << " could gain from a new vertex"
        << (h->locked_by_neighbours > 0 ? ", " + std::to_string(h->locked_by_neighbours) + " of them with four "
                                           "constrained vertices and no flip left"
                                         : std::string())
        << ")";
    o << ". Try <code>" << esc(h->flag) << "</code> (the bound is a ceiling, not a promise).</p>\n";
  }
  if (in.mesh) view_section(o, in, surf, after);
  if (d->poor.empty()) return;
  const size_t nl = std::min(in.max_tets_listed, d->poor.size());
  o << "<p class=\"note\">The " << nl << " worst of them (tet ids 1-based as the command line prints them; the "
       "ParaView cell id is one less):</p>\n";
  o << "<table id=\"worst\"><tr><th>tet</th><th>α</th><th>min dihedral</th><th>max dihedral</th><th>kind</th>"
       "<th class=\"l\">class</th><th>best possible α</th><th>centroid x</th><th>y</th><th>z</th></tr>\n";
  for (size_t i = 0; i < nl; ++i) {
    const PoorTet& p = d->poor[i];
    const int c = static_cast<int>(p.cls);
    o << "<tr data-tet=\"" << p.tet << "\"><td>" << p.tet + 1 << "</td><td>" << f("%.4f", p.alpha) << "</td><td>" << f("%.2f", p.dihedral_min)
      << "</td><td>" << f("%.2f", p.dihedral_max) << "</td><td>" << p.kind << "</td><td class=\"l c" << c << "\">"
      << tet_class_name(p.cls) << "</td><td>"
      << (std::isnan(p.best_alpha) ? (p.constrained_faces > 0 ? "≥ " + f("%.3g", d->threshold) : std::string("–"))
                                  : f("%.4f", p.best_alpha))
      << "</td><td>" << f("%.6g", p.centroid[0]) << "</td><td>" << f("%.6g", p.centroid[1]) << "</td><td>"
      << f("%.6g", p.centroid[2]) << "</td></tr>\n";
  }
  o << "</table>\n";
}

}  // namespace

std::string html_report(const HtmlReportInput& in) {
  std::ostringstream o;
  o << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" << esc(in.title)
    << "</title>\n<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<style>" << kStyle
    << "</style>\n</head>\n<body>\n";
  o << "<h1>" << esc(in.title) << "</h1>\n<div class=\"files\">" << esc(in.input);
  if (!in.output.empty()) o << " → " << esc(in.output);
  o << "</div>\n";
  // Verdict first: it is the promise.
  if (in.run) {
    const ImproveReport& r = *in.run;
    if (!r.invariants_checked)
      o << "<div class=\"verdict na\" id=\"verdict\">boundary unchanged: not checked (--no-check)</div>\n";
    else if (r.invariants_ok)
      o << "<div class=\"verdict ok\" id=\"verdict\">boundary unchanged: yes — checked: constrained vertices "
           "bit-identical, constrained faces identical, "
        << (r.still_inverted > 0 ? "no new inverted or flat tet (exact predicate; " + std::to_string(r.still_inverted) +
                                       " input tets stay inverted or flat)"
                                 : std::string("no inverted tet (exact predicate)"))
        << ", region volumes kept</div>\n";
    else
      o << "<div class=\"verdict bad\" id=\"verdict\">boundary unchanged: NO — " << esc(r.invariant_message)
        << "</div>\n";
  } else {
    o << "<div class=\"verdict na\" id=\"verdict\">boundary unchanged: not applicable (no change made)</div>\n";
  }
  // Charts.
  o << "<h2>Distributions</h2>\n<button id=\"scale-toggle\" type=\"button\">show counts on a linear scale</button> "
       "<span class=\"note\">Bar heights use a log(1 + count) scale by default so a handful of bad tets "
       "stays visible; hover a bar for its count.</span>\n<div class=\"charts\">\n";
  std::vector<const Histogram*> sa = {&in.before_hist.alpha}, sd = {&in.before_hist.dihedral};
  std::vector<std::string> names = {in.has_after ? "before" : "mesh"};
  if (in.has_after) {
    sa.push_back(&in.after_hist.alpha);
    sd.push_back(&in.after_hist.dihedral);
    names.push_back("after");
  }
  const int abins = static_cast<int>(in.before_hist.alpha.counts.size());
  const int dbins = static_cast<int>(in.before_hist.dihedral.counts.size());
  o << "<div class=\"chart\">"
    << svg_histogram("hist-alpha", "α (one per tet)", "", sa, names, std::max(1, abins / 10), "%.1f", "%.2f", "α",
                     true)
    << "</div>\n";
  o << "<div class=\"chart\">"
    << svg_histogram("hist-dihedral", "dihedral angles (6 per tet)", "°", sd, names,
                     std::max(1, dbins / 6), "%.0f", "%.0f", "dihedral angle (degrees)", false)
    << "</div>\n</div>\n";
  stats_tables(o, in);
  if (in.before.measures.computed) measures_section(o, in);
  run_tables(o, in);
  // The 3D view's sets (view3d.hpp), when a mesh is given.
  std::unique_ptr<ViewSurface> surf;
  std::unique_ptr<ViewTets> after;
  if (in.mesh && in.diagnosis && detail::view3d_assets().built_in) {
    surf = std::make_unique<ViewSurface>(view_surface(*in.mesh, in.view_surface_budget));
    const size_t max_tets = in.poor_before ? in.view_max_tets / 2 : in.view_max_tets;
    after = std::make_unique<ViewTets>(view_diagnosed_tets(*in.mesh, *in.diagnosis, max_tets, surf->origin));
  }
  diagnosis_section(o, in, surf.get(), after.get());
  o << "<p class=\"note\">Written by tetopt. This page is self-contained: no network, no external scripts or "
       "fonts.</p>\n";
  o << "<script>" << kScript << "</script>\n";
  if (surf) view_scripts(o, in, *surf, *after);
  o << "</body>\n</html>\n";
  return o.str();
}

Status write_html_report(const std::string& path, const HtmlReportInput& in) {
  return write_file_atomic(path, html_report(in));
}

}  // namespace tetopt
