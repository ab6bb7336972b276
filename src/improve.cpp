// The combined improvement driver (see improve.hpp).
#include "tetopt/improve.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "tetopt/invariants.hpp"
#include "tetopt/report.hpp"

namespace tetopt {

namespace {
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
}  // namespace

const char* mode_name(ImproveMode m) {
  switch (m) {
    case ImproveMode::Smooth: return "smooth";
    case ImproveMode::Topo: return "topo";
    case ImproveMode::Combined: return "combined";
    case ImproveMode::Best: return "best";
  }
  return "?";
}

Status improve(TetMesh& m, const ImproveOptions& opt, ImproveReport& rep, const LogFn& log,
               const std::atomic<bool>* interrupted) {
  const auto t0 = Clock::now();
  (void)log;
  (void)interrupted;
  if (m.adj.size() != m.tets.size()) return Status::error(ErrorCode::Invariant, "improve: topology not built");
  rep = ImproveReport{};
  rep.before = compute_stats(m);
  InvariantSnapshot snap;
  if (opt.check_invariants) snap = capture_invariants(m);

  // Mode dispatch lands with the smoothing and topology modules.

  if (opt.check_invariants) {
    const auto tc = Clock::now();
    Status s = check_invariants(m, snap);
    rep.seconds_check = since(tc);
    rep.invariants_checked = true;
    rep.invariants_ok = s.ok();
    rep.invariant_message = s.message;
    if (!s) return s;
  }
  rep.after = compute_stats(m);
  rep.seconds_total = since(t0);
  return Status::success();
}

std::string report_to_json(const ImproveReport& r, const ImproveOptions& o, const std::string& input,
                           const std::string& output) {
  std::ostringstream j;
  char buf[64];
  auto num = [&](double x) {
    std::snprintf(buf, sizeof buf, "%.17g", x);
    return std::string(buf);
  };
  j << "{\n";
  j << "  \"tool\": \"tetopt\",\n  \"version\": \"0.1.0\",\n";
  j << "  \"input\": " << json_string(input) << ",\n  \"output\": " << json_string(output) << ",\n";
  j << "  \"options\": {\"mode\": \"" << mode_name(o.mode) << "\", \"optimizer\": \""
    << (o.maxmin_optimizer ? "maxmin" : "paper") << "\", \"weight\": " << num(o.weight)
    << ", \"threshold\": " << num(o.threshold) << ", \"iterations\": " << o.iterations << ", \"seed\": " << o.seed
    << ", \"threads\": " << o.threads << "},\n";
  j << "  \"before\": " << stats_to_json(r.before, 4) << ",\n";
  j << "  \"after\": " << stats_to_json(r.after, 4) << ",\n";
  j << "  \"operations\": {\"smoothing_moves\": " << r.smooth_moves << ", \"smoothing_tried\": " << r.smooth_tried
    << ", \"flip23\": " << r.flip23 << ", \"flip32\": " << r.flip32 << ", \"edge_removals\": " << r.edge_removals
    << ", \"multi_face_removals\": " << r.multi_face_removals << ", \"flip22\": " << r.flip22
    << ", \"flip44\": " << r.flip44 << ", \"all_boundary_removed\": " << r.all_boundary_removed
    << ", \"rounds\": " << r.rounds << "},\n";
  j << "  \"seconds\": {\"total\": " << num(r.seconds_total) << ", \"smoothing\": " << num(r.seconds_smooth)
    << ", \"topology\": " << num(r.seconds_topo) << ", \"invariant_check\": " << num(r.seconds_check) << "},\n";
  j << "  \"boundary_unchanged\": {\"checked\": " << (r.invariants_checked ? "true" : "false")
    << ", \"ok\": " << (r.invariants_ok ? "true" : "false") << ", \"message\": " << json_string(r.invariant_message)
    << "}\n}\n";
  return j.str();
}

}  // namespace tetopt
