// tetopt improve.
#include <malloc.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <future>
#include <thread>

#include "cli.hpp"
#include "hugepages.hpp"
#include "improve_args.hpp"
#include "tetopt/diagnose.hpp"
#include "tetopt/html_report.hpp"
#include "tetopt/improve.hpp"
#include "tetopt/measures.hpp"
#include "tetopt/io.hpp"
#include "tetopt/report.hpp"

namespace tetopt_cli {

using namespace tetopt;

static const char* kImproveHelp =
    "usage: tetopt improve IN -o OUT [options]\n"
    "\n"
    "Improves the tets of IN and writes OUT.  Constrained vertices (on the boundary,\n"
    "on a region interface, on a listed triangle or edge, or required) never move,\n"
    "bit for bit; constrained faces are never removed; refs, names and listed\n"
    "entities come back unchanged (what OUT's format cannot hold, such as vertex\n"
    "refs in .msh, is named in a warning).  Before writing, tetopt proves it: same\n"
    "constrained vertices and faces, no inverted tet (exact predicate), same volume\n"
    "per region.  If that check fails nothing is written (exit 3).\n"
    "\n"
    "options:\n"
    "  -o, --output OUT     output mesh (format by extension; required).  Never IN,\n"
    "                       as no output is (exit 1, checked through links too):\n"
    "                       write elsewhere, then rename\n"
    "  --mode M             best (default): flips everywhere + both smoothers, rounds\n"
    "                         with rising thresholds until nothing improves\n"
    "                       combined: the paper's loop (smoothing, and topology\n"
    "                         optimisation for all-boundary tets)\n"
    "                       smooth: the paper's weighted smoothing alone\n"
    "                       topo: the quality-driven flip pass alone\n"
    "  --optimizer O        paper (gradient + golden-section line search, default)\n"
    "                       or maxmin (Freitag's nonsmooth max-min)\n"
    "  --weight C           weight of boundary elements in the objective,\n"
    "                       0.5 <= C < 1 (default 0.75; 0.5 = unweighted)\n"
    "  --threshold G        tets with alpha < G are poor (default 0.3; with --objective,\n"
    "                       the objective's q < G)\n"
    "  --objective M        what every stage optimises: alpha (default, the paper's),\n"
    "                       sine (Stellar's minimum sine of the dihedral angles),\n"
    "                       jacobian (Verdict's scaled Jacobian) or skewness (1 -\n"
    "                       Fluent's equivolume skewness); each scaled to 1 for the\n"
    "                       regular tet; or openfoam: alpha, then a pass that lowers\n"
    "                       OpenFOAM checkMesh's largest face non-orthogonality,\n"
    "                       every per-tet worst (alpha's too) kept\n"
    "  --no-guard           let operations create tets worse than the input's worst on\n"
    "                       measures other than the objective (by default no operation\n"
    "                       may: alpha, minimum sine, dihedral angles, scaled Jacobian,\n"
    "                       radius ratio, mean ratio, equivolume skewness; the report's\n"
    "                       \"guards\" says which measure refused how many operations)\n"
    "  --polish             end with a guarded pass for the mean quality: every free\n"
    "                       vertex tried at the mean of its neighbours, kept when the\n"
    "                       star's sum of 1/alpha falls and no measure's worst gets\n"
    "                       worse (demo impeller: mean alpha 0.704 -> 0.740, about a\n"
    "                       third more time); without it this runs only when the mean\n"
    "                       alpha fell below the input's\n"
    "  --iterations N       rounds (default 10)\n"
    "  --seed S             visiting order (default 0); same seed, same output\n"
    "  --threads K          worker threads (default 0 = all cores); the output is\n"
    "                       byte-identical for every K (--threads 1 on a shared machine)\n"
    "  --report FILE.json   write a machine-readable report: before/after statistics,\n"
    "                       operation counts, time per phase, the invariant check\n"
    "  --field OUT.vtu      write per-tet fields of OUT for ParaView (VTK XML: the name\n"
    "                       must end in .vtu): alpha, alpha_before\n"
    "                       (alpha of the same four vertices in IN; NaN for new tets),\n"
    "                       dihedral_min/max, kind, region, diagnosis (0 good, 1 locked\n"
    "                       by its boundary triangle, 2 locked by constrained\n"
    "                       neighbours, 3 improvable) and alpha_bound\n"
    "  --html FILE.html     write a self-contained HTML report: before/after histograms\n"
    "                       of alpha and dihedral angles, statistics, time per phase,\n"
    "                       operation counts, diagnosis, the boundary verdict, a 3D\n"
    "                       view of the poor tets before and after (docs/report.md)\n"
    "  --msh-version V      22 or 41 (Gmsh), fluent     --binary  binary .msh/.vtk/polyMesh\n"
    "  --meshb-version V    2, 3 (default) or 4 for .meshb output\n"
    "  --allow-insert       (mode best only) may insert new free vertices inside the\n"
    "                       volume; existing vertices keep their ids.  Off by default\n"
    "                       because some users need the vertex set unchanged.  Runs\n"
    "                       the interior remesher first, toward a size field (the\n"
    "                       boundary triangles' edge lengths, a point field named\n"
    "                       'size' in the input, or --size): circumcentres of tets\n"
    "                       too large for it (Delaunay refinement, never across a\n"
    "                       boundary or interface triangle), then long interior\n"
    "                       edges split and the remesher's short ones collapsed,\n"
    "                       with flips and smoothing; then insertion in the worst\n"
    "                       tets' cavities; also fills meshes that have no\n"
    "                       interior vertex at all (raw tetgen output)\n"
    "  --size H             with --allow-insert: target edge length H everywhere\n"
    "  --gradation R        with --allow-insert on a raw mesh (no interior vertex, as\n"
    "                       raw tetgen output): the interior's size grows away from\n"
    "                       the surface's by at most a factor R per edge length\n"
    "                       (MMG's hgrad; default 1.16); 1.3 or more: fewer, larger tets\n"
    "  --no-remesh          with --allow-insert: no remesher, insertion in the worst\n"
    "                       tets' cavities only (the former --allow-insert)\n"
    "  --allow-remove       (mode best only) may remove free vertices (contracting an edge\n"
    "                       of a poor tet) where that raises the worst alpha of their\n"
    "                       star; the other vertices keep their order.  Off by default\n"
    "  --no-check           skip the final invariant proof (not recommended)\n"
    "  --reorder-above N    a mesh of N tets or more (default 1000000) whose tets\n"
    "                       follow no spatial order (consecutive tets more than 8\n"
    "                       edge lengths apart on average: a shuffled mesh of a\n"
    "                       few thousand tets is not that far) is first put in\n"
    "                       Morton order of their centroids: faster (the passes walk\n"
    "                       neighbours in cache), a different, equally checked\n"
    "                       result; the report's tets_reordered says so\n"
    "  --write-boundary     list the boundary and interface triangles IN does not list,\n"
    "                       as groups boundary_REGION and interface_A_B with new refs\n"
    "                       (for OpenFOAM patches / faceZones, Fluent zones, Abaqus\n"
    "                       surfaces from a mesh without boundary triangles)\n"
    "  --keep-order         keep IN's tet order (wins over --reorder-above) and the\n"
    "                       order improve leaves: without it the tets of each region\n"
    "                       are put together (one Gmsh block per entity)\n"
    "  -q, --quiet          print nothing but errors    -v, --verbose  more detail\n"
    "  --                   ends the options: IN may start with '-'\n"
    "\n"
    "After the run every tet still below the threshold is diagnosed: locked by its\n"
    "boundary triangle (no apex over that constrained triangle reaches the threshold),\n"
    "locked by its constrained neighbours (all four vertices constrained and no flip\n"
    "found), or improvable (not reached); --report and --html list them.  In mode best\n"
    "without --allow-insert, when the worst alpha ends below 95% of the bound, a line\n"
    "says how far insertion could lift it (\"insertion_hint\" in --report, a sentence\n"
    "in --html).\n"
    "\n"
    "examples:\n"
    "  tetopt improve impeller.mesh -o impeller_opt.mesh\n"
    "  tetopt improve pump.msh -o pump_opt.msh --mode combined --weight 0.8 --report r.json\n";

int cmd_improve(const std::vector<std::string>& args) {
  ImproveArgs a;
  // All cores unless told otherwise: the output is the same for every count
  // (tetopt-mpi keeps 1 thread per rank).
  a.opt.threads = 0;
  std::string field, html;  // options of tetopt improve only
  const std::vector<ExtraOption> extra = {
      {{"--field"}, true, [&](const std::string& v, std::string&) { field = v; return true; }},
      {{"--html"}, true, [&](const std::string& v, std::string&) { html = v; return true; }},
  };
  std::string err;
  switch (parse_improve_args(args, {"tetopt improve", "tetopt"}, extra, a, err)) {
    case ImproveArgsResult::Ok: break;
    case ImproveArgsResult::Help: std::fputs(kImproveHelp, stdout); return kExitOk;
    case ImproveArgsResult::Error: std::fprintf(stderr, "%s\n", shown(err).c_str()); return kExitUsage;
    case ImproveArgsResult::ErrorWithHelp:
      std::fprintf(stderr, "%s\n\n%s", shown(err).c_str(), kImproveHelp);
      return kExitUsage;
  }
  const std::string &in = a.in, &out = a.out, &report_path = a.report;
  ImproveOptions& opt = a.opt;
  WriteOptions& wo = a.wo;
  const bool quiet = a.quiet, verbose = a.verbose;
  if (!field_is_vtu("tetopt improve", field)) return kExitUsage;
  // -o IN is refused as --report IN is (true, false: OUT is a mesh, and not IN).
  if (const int rc = check_paths("tetopt improve",
                                 {{"IN", in}, {"-o", out}, {"--report", report_path}, {"--field", field}, {"--html", html}},
                                 true, false);
      rc)
    return rc;
  const auto t0 = std::chrono::steady_clock::now();
  TetMesh m;
  std::vector<int32_t> order;  // order[id] = id in IN, when the tets were put in Morton order
  if (!load_mesh(in, m, quiet, opt.threads, &order, a.keep_order ? -1 : a.reorder_above)) return kExitInput;
  if (a.write_boundary && add_boundary_triangles(m) > 0) {
    const Status s0 = build_topology(m, opt.threads);  // the new triangles are constrained faces already; classify lists them
    if (!s0) { std::fprintf(stderr, "tetopt: %s: %s\n", shown(in).c_str(), shown(s0.message).c_str()); return kExitInput; }
  }
  if (verbose && !order.empty())
    std::fprintf(stderr, "tets put in Morton order of their centroids (IN's order is scattered; --keep-order keeps it)\n");
  // What improve's caches and passes add to the heap: 47-135 bytes per tet
  // on the shared meshes (impeller 57, flange_large 47); 50 is the estimate,
  // less what the heap has free already, while the per-tet arrays of 16
  // bytes still come from the heap.
  if (heap_serves(size_t{16} * static_cast<size_t>(m.nt()))) {
    const size_t want = size_t{50} * static_cast<size_t>(m.nt()), free_now = mallinfo2().fordblks;
    if (want > free_now) prefault_heap(want - free_now, opt.threads);
  }
  const std::vector<std::string> dropped = warn_dropped(out, m, wo, quiet);
  const bool tty = stderr_is_tty() && !quiet;
  // The progress line (a terminal only) comes from the library's progress
  // callback (ImproveOptions::progress), the one Python's improve(progress=)
  // gets; the passes' own progress messages are left to it.
  if (tty)
    opt.progress = [obj = objective_name(opt.objective)](const ImproveProgress& p) {
      if (p.round > 0)
        std::fprintf(stderr, "round %d (threshold %.2f), %s: %3.0f%%, worst %s %.4f\033[K\r", p.round, p.threshold, p.phase,
                     100 * p.fraction, obj, p.worst);
      else if (std::isnan(p.worst))  // not known yet (start)
        std::fprintf(stderr, "%s: %3.0f%%\033[K\r", p.phase, 100 * p.fraction);
      else
        std::fprintf(stderr, "%s: %3.0f%%, worst %s %.4f\033[K\r", p.phase, 100 * p.fraction, obj, p.worst);
      return true;
    };
  LogFn log = [&](LogLevel lvl, const std::string& msg) {
    if (quiet) return;
    if (lvl == LogLevel::Progress) {
      // Off a terminal, -v keeps the passes' progress messages as lines (each
      // round's worst and threshold): the log of a run in a batch job.
      if (verbose && !tty) std::fprintf(stderr, "%s\n", msg.c_str());
      return;
    } else if (lvl == LogLevel::Warning) {
      std::fprintf(stderr, "warning: %s\n", msg.c_str());
    } else if (lvl == LogLevel::Info || verbose) {
      std::fprintf(stderr, "%s\n", msg.c_str());
    }
  };
  // What the report and the field file need from the input mesh.
  TetValueMap alpha_before;
  if (!field.empty()) alpha_before = TetValueMap(m, compute_fields(m).alpha);
  QualityHistograms hist_before;
  ViewTets view_before;  // the 3D view's "before": the input's poor tets, numbered as in IN
  if (!html.empty()) {
    hist_before = quality_histograms(m);
    double origin[3];
    view_origin(m, origin);
    view_before = view_poor_tets(m, opt.threshold, HtmlReportInput{}.view_max_tets / 2, origin,
                                 order.empty() ? nullptr : &order, opt.threads);
  }
  // The report compares every measure of measures.hpp before and after,
  // the face measures (OpenFOAM's non-orthogonality and skewness, which the
  // guards do not hold per operation) included: two measure passes, only
  // when a report is asked for.
  MeasureStats measures_before;
  if (!report_path.empty()) measures_before = compute_measure_stats(m, opt.threads);
  // IN's regions in IN's order, to put each one's tets together again after
  // improve (issue 28); --keep-order keeps the order improve leaves.
  const std::vector<RegionKey> regions = a.keep_order ? std::vector<RegionKey>{} : region_key_order(m, order.empty() ? nullptr : &order);
  ImproveReport rep;
  Status s = improve(m, opt, rep, log, &g_interrupted);
  if (tty) std::fputs("\033[K", stderr);
  if (!s && !s.stopped()) {
    std::fprintf(stderr, "tetopt: %s: %s\n", shown(in).c_str(), shown(s.message).c_str());
    if (s.code == ErrorCode::Invariant) {
      std::fputs("tetopt: invariant failure (a bug in tetopt): nothing written\n", stderr);
      return kExitInvariant;
    }
    return kExitInput;
  }
  if (g_interrupted) {
    std::fputs("tetopt: interrupted; nothing written\n", stderr);
    return kExitInterrupted;
  }
  // The tets of one region together (one Gmsh block per entity, one Fluent
  // cell zone), each region's in the order improve left them.
  if (regions.size() > 1) {
    std::vector<int32_t> new_id;
    if (group_tets_by_region(m, regions, &new_id)) {
      if (rep.after.worst_tet >= 0 && rep.after.worst_tet < static_cast<int32_t>(new_id.size()))
        rep.after.worst_tet = new_id[static_cast<size_t>(rep.after.worst_tet)];
      s = build_topology(m, opt.threads);
      if (!s) {
        std::fprintf(stderr, "tetopt: %s: %s\n", shown(in).c_str(), shown(s.message).c_str());
        return kExitInvariant;
      }
    }
  }
  // The input's worst tet by its number in IN.
  if (!order.empty() && rep.before.worst_tet >= 0 && rep.before.worst_tet < static_cast<int32_t>(order.size()))
    rep.before.worst_tet = order[static_cast<size_t>(rep.before.worst_tet)];
  wo.threads = opt.threads;
  // The diagnosis and the writer only read the mesh: with more than one
  // thread the diagnosis (mostly the bound's serial triangle refinement)
  // runs beside the write instead of after it.
  const bool want_diag = !quiet || !field.empty() || !report_path.empty() || !html.empty();
  // The bound of every measure when the run optimises another than alpha.
  // Without the walls' search (DiagnoseOptions::walls): seconds on raw
  // thin-walled meshes, where the default mode itself takes a fraction of
  // one; `tetopt quality` gives the walled bound.
  const DiagnoseOptions dopt{opt.threshold, true, opt.threads, opt.objective != Objective::Alpha, false};
  const int cores = opt.threads > 0 ? opt.threads : static_cast<int>(std::thread::hardware_concurrency());
  std::future<Diagnosis> diag_beside;
  if (want_diag && cores > 1)
    diag_beside = std::async(std::launch::async, [&m, &dopt] { return diagnose(m, dopt); });
  s = write_mesh(out, m, wo);
  if (!s) { std::fprintf(stderr, "tetopt: %s\n", shown(s.message).c_str()); return kExitOutput; }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  Diagnosis diag;
  if (diag_beside.valid()) diag = diag_beside.get();
  else if (want_diag) diag = diagnose(m, dopt);
  // What --allow-insert could buy (diagnose.hpp, InsertionHint): mode best
  // without it, worst alpha below 95% of the bound.
  const InsertionHint hint =
      insertion_hint(diag, rep.after.alpha_worst, opt.mode == ImproveMode::Best && !opt.allow_insert && want_diag);
  if (!field.empty()) {
    std::vector<CellField> fields = quality_cell_fields(m);
    fields.insert(fields.begin() + 1, CellField{"alpha_before", alpha_before.lookup(m), false});
    for (CellField& c : diagnosis_cell_fields(diag, m.nt())) fields.push_back(std::move(c));
    s = write_cell_fields_vtu(field, m, fields);
    if (!s) { std::fprintf(stderr, "tetopt: %s\n", shown(s.message).c_str()); return kExitOutput; }
  }
  if (!report_path.empty()) {
    std::string js = report_to_json(rep, opt, in, out);
    // "measures_before_after": each measure's worst before and after, and
    // whether the run kept it (not worse).
    const std::string ba = measures_before_after_json(measures_before, compute_measure_stats(m, opt.threads));
    std::string dj = diagnosis_to_json(diag, 1000, 2);
    for (size_t p = dj.find('\n'); p != std::string::npos; p = dj.find('\n', p + 3)) dj.replace(p, 1, "\n  ");
    const size_t close = js.rfind('}');
    js.insert(close > 0 && js[close - 1] == '\n' ? close - 1 : close, ",\n  \"seconds_end_to_end\": " + std::to_string(total) +
                  ",\n  \"tets_reordered\": " + (order.empty() ? "false" : "true") + ",\n  \"dropped_on_write\": " +
                  json_string_list(dropped) + ",\n  \"measures_before_after\": " + ba + ",\n  \"insertion_hint\": " +
                  insertion_hint_to_json(hint) + ",\n  \"diagnosis\": " + dj);
    s = write_file_atomic(report_path, js);
    if (!s) { std::fprintf(stderr, "tetopt: %s\n", shown(s.message).c_str()); return kExitOutput; }
  }
  if (!html.empty()) {
    HtmlReportInput hin;
    hin.title = "tetopt improve: " + in;
    hin.input = in;
    hin.output = out;
    hin.before = rep.before;
    hin.before_hist = std::move(hist_before);
    hin.has_after = true;
    hin.after = rep.after;
    hin.after_hist = quality_histograms(m);
    hin.run = &rep;
    hin.options = &opt;
    hin.seconds_end_to_end = total;
    hin.diagnosis = &diag;
    hin.insertion_hint = &hint;
    hin.mesh = &m;  // the 3D view, with the input's poor tets beside the output's
    hin.poor_before = &view_before;
    s = write_html_report(html, hin);
    if (!s) { std::fprintf(stderr, "tetopt: %s\n", shown(s.message).c_str()); return kExitOutput; }
  }
  if (!quiet) {
    std::printf("%s -> %s (mode %s, objective %s, C = %.2f)\n", shown(in).c_str(), shown(out).c_str(),
                mode_name(opt.mode), objective_name(opt.objective), opt.weight);
    std::printf("%s", format_before_after(rep.before, rep.after, rep.seconds_total).c_str());
    std::printf("  operations: %lld smoothing moves, %lld 2-3, %lld 3-2, %lld edge removals, %lld multi-face "
                "removals, %lld 2-2, %lld 4-4 (%lld pairs of them made together); %lld all-boundary tets removed; "
                "%lld vertices inserted, %lld removed; %d rounds\n",
                static_cast<long long>(rep.smooth_moves), static_cast<long long>(rep.flip23),
                static_cast<long long>(rep.flip32), static_cast<long long>(rep.edge_removals),
                static_cast<long long>(rep.multi_face_removals), static_cast<long long>(rep.flip22),
                static_cast<long long>(rep.flip44), static_cast<long long>(rep.pair_flips),
                static_cast<long long>(rep.all_boundary_removed),
                static_cast<long long>(rep.insertions), static_cast<long long>(rep.removals), rep.rounds);
    if (rep.untangled > 0 || rep.still_inverted > 0)
      std::printf("  untangling: %lld inverted or flat input tets made positive, %lld could not be (ids in the log)\n",
                  static_cast<long long>(rep.untangled), static_cast<long long>(rep.still_inverted));
    // Guards (guard.hpp): which measure refused how many operations.
    if (rep.guard_on) {
      std::string by;
      int64_t total_refused = 0;
      for (int k = 0; k < kTetMeasureCount; ++k)
        if (const int64_t n = rep.guard_refused[static_cast<size_t>(k)]; n > 0) {
          total_refused += n;
          by += (by.empty() ? "" : ", ") + std::string(kMeasures[static_cast<size_t>(k)].key) + " " + std::to_string(n);
        }
      std::printf("  guards: %lld operations refused for making a measure worse than the mesh's worst%s%s%s "
                  "(--no-guard lifts them)\n",
                  static_cast<long long>(total_refused), by.empty() ? "" : " (", by.c_str(), by.empty() ? "" : ")");
      if (rep.after.alpha_mean < rep.before.alpha_mean)
        std::printf("  guards: the mean alpha fell from %.4f to %.4f and the polish could not restore it\n",
                    rep.before.alpha_mean, rep.after.alpha_mean);
    } else {
      std::printf("  guards: off (--no-guard)\n");
    }
    if (rep.face_pass_on)
      std::printf("  face pass (--objective openfoam): largest non-orthogonality %.2f -> %.2f degrees, %lld moves, "
                  "%lld face and %lld edge removals\n",
                  rep.non_orthogonality_before, rep.non_orthogonality_after, static_cast<long long>(rep.face_moves),
                  static_cast<long long>(rep.face_face_removals), static_cast<long long>(rep.face_edge_removals));
    // Why the largest face stays, when the pass can say (face_pass.hpp).
    if (rep.face_pass_on && rep.face_worst_move_floor >= 0)
      std::printf("    its largest face: no vertex move takes it below %.2f degrees (its apexes and two or three of its "
                  "vertices are constrained)\n",
                  rep.face_worst_move_floor);
    if (rep.face_pass_on && rep.face_worst_lowering > 0 &&
        rep.face_worst_constrained_refused == rep.face_worst_lowering)
      std::printf("    its largest face: each of the %d operations that would lower it creates a tet of four "
                  "constrained vertices that %s\n",
                  rep.face_worst_lowering, rep.guard_on ? "the guards refuse" : "the alpha floor refuses");
    std::printf("  time: smoothing %.3f s, topology %.3f s, invariant check %.3f s, end to end %.3f s\n",
                rep.seconds_smooth, rep.seconds_topo, rep.seconds_check, total);
    // Input tets that untangling could not make positive stay as they were
    // (the check accepts exactly those): "no inverted tet" would be false.
    const std::string inverted =
        rep.still_inverted > 0 ? "no new inverted or flat tet (" + std::to_string(rep.still_inverted) +
                                     " input tets stay inverted or flat)"
                               : std::string("no inverted tet");
    const std::string verdict = "yes (checked: constrained vertices bit-identical, constrained faces identical, " +
                                inverted + ", region volumes kept)";
    std::printf("  boundary unchanged: %s\n",
                rep.invariants_checked ? (rep.invariants_ok ? verdict.c_str() : "NO") : "not checked (--no-check)");
    std::printf("%s", format_diagnosis(diag, verbose ? 20 : 3).c_str());
    std::printf("%s", format_insertion_hint(hint).c_str());
    if (!html.empty()) std::printf("  wrote HTML report to %s\n", shown(html).c_str());
  }
  return kExitOk;
}

}  // namespace tetopt_cli
