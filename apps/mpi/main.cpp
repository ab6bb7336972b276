// tetopt-mpi: distributed improvement (issue 11).
//
//   mpirun -np K tetopt-mpi improve IN -o OUT [options]
//
// Rank 0 reads IN and builds its topology, then for each round:
//   partition   METIS_PartGraphKway on the tet dual graph (distribute.cpp);
//               from round 2 on, dual edges near the previous interface are
//               expensive to cut, so the tets frozen in one round are free in
//               the next (the interface moves, as in ParMmg)
//   scatter     rank 0 sends part p to rank p (part 0 stays on rank 0)
//   improve     every rank runs tetopt::improve on its part; interface
//               vertices and everything constrained globally are required
//   gather      the ranks send their improved parts back; rank 0 merges them
//               into the global mesh and rebuilds its topology
// A round after the first with at most --local-below active tets (the band
// around the last cut and the poor tets) skips partition and messages: rank
// 0 improves it alone with every core of its node.
// Each round's threshold is max(G, min(0.6, worst alpha + 0.1 + 0.1 x rounds
// in a row without gain)); rounds stop after --rounds, after two rounds in
// a row that did not raise the worst alpha by 0.001, or after one such
// round that was local.  Then rank 0 proves the
// promise on the whole mesh (check_invariants against the snapshot of IN)
// and writes OUT; nothing is written when the proof fails.
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <csignal>
#include <limits>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "../cli/cli.hpp"
#include "../cli/hugepages.hpp"
#include "../cli/improve_args.hpp"
#include "detail/parallel.hpp"
#include "distribute.hpp"
#include "tetopt/improve.hpp"
#include "tetopt/invariants.hpp"
#include "tetopt/io.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/report.hpp"

using namespace tetopt;
using namespace tetopt_mpi;

namespace {

// Rank 0 alone reads, merges, measures and writes while the other ranks wait
// (asleep between MPI_Iprobe calls), so those phases use every core of its
// node; their results do not depend on the thread count.
constexpr int kRank0Threads = 0;

constexpr int kExitOk = 0, kExitUsage = 1, kExitInput = 2, kExitInvariant = 3, kExitOutput = 4;
constexpr int kTagPart = 1, kTagStop = 2, kTagResult = 3, kTagWrite = 4;

const char* kHelp =
    "usage: mpirun -np K tetopt-mpi improve IN -o OUT [options]\n"
    "\n"
    "Improves IN on K MPI ranks and writes one mesh OUT (any format tetopt writes).\n"
    "Rank 0 reads IN, partitions its tets with METIS, sends each rank a part whose\n"
    "interface with the other parts is frozen, and merges the improved parts back;\n"
    "then the interfaces move (re-partition avoiding the previous interface) and\n"
    "the next round frees what the last one froze.  The real boundary, region\n"
    "interfaces, listed entities and refs stay bit-identical, as in tetopt improve;\n"
    "the whole result is checked before writing (exit 3 and nothing written if not).\n"
    "\n"
    "Rank 0 reads, partitions and merges while the other ranks wait, and uses every\n"
    "core it may run on for that; Open MPI binds each rank to one core when K is\n"
    "at most 2, so on one machine run `mpirun --bind-to none -np K ...` (flange_large,\n"
    "2 ranks on 2 cores: 11.8-12.2 s bound, 9.6-10.1 s with --bind-to none).\n"
    "\n"
    "options (as tetopt improve):\n"
    "  -o, --output OUT     output mesh (required; never IN, as no output is: exit 1)\n"
    "  --mode M             best (default), combined, smooth, topo\n"
    "  --optimizer O        paper (default) or maxmin\n"
    "  --weight C           0.5 <= C < 1 (default 0.75)\n"
    "  --threshold G        poor-tet threshold (default 0.3)\n"
    "  --iterations N       rounds inside each improve run (default 10)\n"
    "  --seed S             visiting order and METIS seed (default 0)\n"
    "  --threads T          worker threads per rank (default 1)\n"
    "  --allow-insert       (mode best only) may insert free vertices\n"
    "  --allow-remove       (mode best only) may remove free vertices (dropped after the merge)\n"
    "  --size H, --gradation R, --no-remesh  accepted as by tetopt improve; tetopt-mpi\n"
    "                       never runs the remesher: its --allow-insert inserts in the\n"
    "                       worst tets' cavities\n"
    "  --objective M        alpha (default), sine, jacobian, skewness or openfoam: what\n"
    "                       every stage optimises (tetopt improve --help); openfoam's\n"
    "                       face pass runs in each part, part faces fixed\n"
    "  --no-guard           let operations worsen the part's worst on the other measures\n"
    "  --polish             each part ends with the guarded mean polish (tetopt improve --help)\n"
    "  --report FILE.json   per-round phase times, bytes, quality; before/after stats\n"
    "  --msh-version V      22 or 41    --binary  binary .msh/.vtk\n"
    "  --meshb-version V    2, 3 (default) or 4 for .meshb output\n"
    "  --reorder-above N    rank 0 puts a mesh of N tets or more (default 1000000)\n"
    "                       whose tets follow no spatial order in Morton order first\n"
    "  --write-boundary     list the boundary and interface triangles IN does not list,\n"
    "                       as groups boundary_REGION and interface_A_B with new refs\n"
    "  --keep-order         keep IN's tet order (wins over --reorder-above)\n"
    "  --no-check           skip the per-part proof inside improve (the final global\n"
    "                       proof always runs)\n"
    "  -q, --quiet          print nothing but errors    -v, --verbose  per-rank detail\n"
    "  --                   ends the options: IN may start with '-'\n"
    "options of tetopt-mpi:\n"
    "  --rounds R           partition rounds (default 8; stops earlier after two\n"
    "                       rounds in a row that do not raise the worst alpha\n"
    "                       by 0.001, or one such round that was local).\n"
    "                       A round's threshold is max(G, min(0.6, worst + 0.1 +\n"
    "                       0.1 x rounds in a row without gain))\n"
    "  --contract-above N   give METIS the dual graph contracted by groups of tets\n"
    "                       with the same smallest vertex when a round has more\n"
    "                       than N active tets (default 250000; 0: always): about\n"
    "                       5x faster partitioning, a more ragged cut\n"
    "  --local-below N      a round after the first with at most N active tets\n"
    "                       (default 250000; 0: never) runs on rank 0 alone with\n"
    "                       every core of its node: no cut, no partition, no\n"
    "                       messages (the late rounds clean up a thin band)\n"
    "  --per-rank DIR       also write DIR/part_<rank>.vtu (a partition of the result,\n"
    "                       fields rank, region, alpha) and DIR/parts.pvtu\n";

// The options of tetopt improve (in, out, report, opt, wo, quiet, verbose;
// parsed by apps/cli/improve_args.cpp, as in tetopt improve) plus tetopt-mpi's own.
struct Args : tetopt_cli::ImproveArgs {
  std::string per_rank;
  int rounds = 8;
  int64_t contract_above = tetopt_mpi::PartitionOptions{}.contract_above;
  // A later round with at most this many active tets runs on rank 0 alone,
  // with every core of its node (see the round loop).
  int64_t local_below = 250000;
};

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// 0 ok, >0 exit code (usage), -1 help printed.  The improve options are
// parsed by the parser of tetopt improve; --rounds and --per-rank here.
int parse_args(int argc, char** argv, Args& a, std::string& err) {
  std::vector<std::string> v = tetopt_cli::split_equals(std::vector<std::string>(argv + 1, argv + argc));
  if (v.empty() || v[0] == "-h" || v[0] == "--help") return -1;
  if (v[0] != "improve") { err = "tetopt-mpi: unknown command '" + v[0] + "' (only 'improve')"; return kExitUsage; }
  v.erase(v.begin());
  const std::vector<tetopt_cli::ExtraOption> extra = {
      {{"--per-rank"}, true, [&](const std::string& s, std::string&) { a.per_rank = s; return true; }},
      {{"--rounds"}, true, [&](const std::string& s, std::string& e) {
         int64_t n = 0;
         if (!tetopt_cli::parse_whole("--rounds", s, 1, 1000, n, e)) return false;
         a.rounds = static_cast<int>(n);
         return true;
       }},
      {{"--contract-above"}, true, [&](const std::string& s, std::string& e) {
         return tetopt_cli::parse_whole("--contract-above", s, 0, int64_t{1} << 53, a.contract_above, e);
       }},
      {{"--local-below"}, true, [&](const std::string& s, std::string& e) {
         return tetopt_cli::parse_whole("--local-below", s, 0, int64_t{1} << 53, a.local_below, e);
       }},
  };
  switch (tetopt_cli::parse_improve_args(v, {"tetopt-mpi", "tetopt-mpi"}, extra, a, err)) {
    case tetopt_cli::ImproveArgsResult::Ok:
      // The remesher (issue 27) is tetopt improve's: in a part its splits
      // and collapses stop at the frozen cut, and on the test box -np 2
      // ended at 0.4694 against 0.5472 for one process.  Here
      // --allow-insert is the cavity insertion of the worst tets.
      a.opt.remesh = false;
      return 0;
    case tetopt_cli::ImproveArgsResult::Help: return -1;
    default: return kExitUsage;
  }
}

// Waits for a message from src without spinning a core (4 ranks share 2
// cores here; a busy-polling MPI_Recv would steal time from the workers).
int probe_polite(int src, MPI_Status& st) {
  int flag = 0;
  for (int spins = 0;; ++spins) {
    MPI_Iprobe(src, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
    if (flag) return st.MPI_TAG;
    std::this_thread::sleep_for(std::chrono::microseconds(spins < 100 ? 50 : 1000));
  }
}

std::string recv_bytes(const MPI_Status& probed, double* seconds) {
  int count = 0;
  MPI_Get_count(&probed, MPI_BYTE, &count);
  std::string buf(static_cast<size_t>(count), '\0');
  const double t0 = now();
  MPI_Recv(buf.data(), count, MPI_BYTE, probed.MPI_SOURCE, probed.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  if (seconds) *seconds += now() - t0;
  return buf;
}

bool send_bytes(const std::string& b, int dst, int tag, double* seconds) {
  if (b.size() > static_cast<size_t>(INT_MAX)) return false;
  const double t0 = now();
  MPI_Send(b.data(), static_cast<int>(b.size()), MPI_BYTE, dst, tag, MPI_COMM_WORLD);
  if (seconds) *seconds += now() - t0;
  return true;
}

// A part message as sent: the round's threshold, the whole mesh's guard
// extremes (guard.hpp; NaN when guards are off), then the part.
using Floor = std::array<double, tetopt::kTetMeasureCount>;
std::string frame(double gamma, const Floor& floor, std::string msg) {
  msg.insert(0, reinterpret_cast<const char*>(floor.data()), sizeof(double) * floor.size());
  msg.insert(0, reinterpret_cast<const char*>(&gamma), sizeof gamma);
  return msg;
}

// Improves one framed part; returns the encoded result.
std::string improve_part(const std::string& framed, ImproveOptions opt, TetMesh& part, double& seconds,
                         Status& st) {
  const double t0 = now();
  ImproveReport rep;
  double gamma = 0;
  Floor floor;
  const size_t head = sizeof gamma + sizeof(double) * floor.size();
  if (framed.size() < head) {
    st = Status::error(ErrorCode::InvalidMesh, "truncated part message");
  } else {
    std::memcpy(&gamma, framed.data(), sizeof gamma);
    std::memcpy(floor.data(), framed.data() + sizeof gamma, sizeof(double) * floor.size());
    opt.guard_floor = floor;
    // Insertion (when allowed) in every round: improve() aims it at the tets
    // within 0.05 of the part's worst alpha, so it stays cheap at the raised
    // thresholds of later rounds.
    opt.threshold = gamma;
    // The part's rounds start at the round's threshold (no trials from 0.3
    // up: improve.hpp, ImproveOptions::threshold_trials).
    opt.threshold_trials = false;
    // Removed vertices must keep their ids until rank 0 merges the parts;
    // rank 0 drops them once, after the final proof.
    opt.keep_vertex_ids = true;
    st = decode_part(framed.substr(head), part);
  }
  if (st && part.nt() > 0) st = improve(part, opt, rep);  // an empty part has nothing to do
  // improve() is called once.  (It used to be called up to twice more in a
  // part with a cut, while a call still changed 0.2% of the tets: best mode
  // then stopped after two rounds without gain of the worst alpha, which in
  // a part is often frozen at the cut.  Since best mode raises its threshold
  // after such rounds instead, the extra calls only repeated smoothing
  // moves: flange_large at 2 ranks, round 1 improve 5.8-8.4 s -> 4.2 s with
  // the same worst and mean alpha; on the test boxes, seeds 0-3 at 2 and 4
  // ranks, one run in 16 below 5% of the single process either way.)
  seconds = now() - t0;
  return encode_result(st, rep, seconds, part);
}

Status write_part_vtu(const std::string& dir, int rank, const TetMesh& part) {
  std::vector<CellField> f(3);
  f[0].name = "rank";
  f[0].integer = true;
  f[0].values.assign(static_cast<size_t>(part.nt()), rank);
  f[1].name = "region";
  f[1].integer = true;
  f[1].values.assign(part.tet_ref.begin(), part.tet_ref.end());
  f[2].name = "alpha";
  f[2].values = compute_fields(part).alpha;
  return write_cell_fields_vtu(dir + "/part_" + std::to_string(rank) + ".vtu", part, f);
}

Status write_pvtu(const std::string& dir, int parts) {
  std::string s =
      "<?xml version=\"1.0\"?>\n"
      "<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
      "  <PUnstructuredGrid GhostLevel=\"0\">\n"
      "    <PCellData>\n"
      "      <PDataArray type=\"Int32\" Name=\"rank\"/>\n"
      "      <PDataArray type=\"Int32\" Name=\"region\"/>\n"
      "      <PDataArray type=\"Float64\" Name=\"alpha\"/>\n"
      "    </PCellData>\n"
      "    <PPoints>\n"
      "      <PDataArray type=\"Float64\" NumberOfComponents=\"3\"/>\n"
      "    </PPoints>\n";
  for (int p = 0; p < parts; ++p) s += "    <Piece Source=\"part_" + std::to_string(p) + ".vtu\"/>\n";
  s += "  </PUnstructuredGrid>\n</VTKFile>\n";
  return write_file_atomic(dir + "/parts.pvtu", s);
}

struct RoundLog {
  int round = 0;
  double threshold = 0;
  double t_partition = 0, t_extract = 0, t_scatter = 0, t_improve_own = 0, t_gather_wait = 0,
         t_gather_transfer = 0, t_merge = 0, t_stats = 0, t_total = 0;
  double improve_max = 0, improve_min = 0, improve_sum = 0;
  std::vector<double> improve_per_rank;
  std::vector<int64_t> tets_per_rank, interface_vertices_per_rank, flips_per_rank, improve_rounds_per_rank;
  int64_t bytes_scatter = 0, bytes_gather = 0;
  int64_t pulled_tets = 0;                     ///< tets moved next to a worst tet after METIS
  bool graph_contracted = false;               ///< METIS got the contracted dual graph
  bool worst_frozen = false;                   ///< the worst tet touched this round's interface
  bool local = false;                          ///< the round ran on rank 0 alone (--local-below)
  int64_t active_tets = 0;                     ///< tets sent out to be improved this round
  int64_t frozen_tets = 0, refrozen_tets = 0;  ///< tets touching the interface; of those, also the previous one
  int64_t insertions = 0, flips = 0, pair_flips = 0, smooth_moves = 0;
  QualityStats after;
};

std::string num(double x) {
  if (!std::isfinite(x)) return "null";
  char b[64];
  std::snprintf(b, sizeof b, "%.9g", x);
  return b;
}

std::string round_json(const RoundLog& r) {
  auto arr = [](const auto& v) {
    std::string s = "[";
    for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + num(static_cast<double>(v[i]));
    return s + "]";
  };
  std::string s = "    {\"round\": " + std::to_string(r.round) + ", \"threshold\": " + num(r.threshold);
  s += ", \"seconds\": {\"partition\": " + num(r.t_partition) + ", \"extract\": " + num(r.t_extract) +
       ", \"scatter\": " + num(r.t_scatter) + ", \"improve_rank0\": " + num(r.t_improve_own) +
       ", \"gather_wait\": " + num(r.t_gather_wait) + ", \"gather_transfer\": " + num(r.t_gather_transfer) +
       ", \"merge\": " + num(r.t_merge) + ", \"stats\": " + num(r.t_stats) + ", \"total\": " + num(r.t_total) +
       ", \"improve_max\": " + num(r.improve_max) + ", \"improve_min\": " + num(r.improve_min) +
       ", \"improve_sum\": " + num(r.improve_sum) + "}";
  s += ", \"improve_seconds_per_rank\": " + arr(r.improve_per_rank);
  s += ", \"active_tets\": " + std::to_string(r.active_tets) + ", \"pulled_tets\": " + std::to_string(r.pulled_tets);
  s += std::string(", \"local\": ") + (r.local ? "true" : "false");
  s += std::string(", \"graph_contracted\": ") + (r.graph_contracted ? "true" : "false");
  s += std::string(", \"worst_tet_at_interface\": ") + (r.worst_frozen ? "true" : "false");
  s += ", \"tets_per_rank\": " + arr(r.tets_per_rank);
  s += ", \"interface_vertices_per_rank\": " + arr(r.interface_vertices_per_rank);
  s += ", \"flips_per_rank\": " + arr(r.flips_per_rank);
  s += ", \"improve_rounds_per_rank\": " + arr(r.improve_rounds_per_rank);
  s += ", \"bytes_scatter\": " + std::to_string(r.bytes_scatter) + ", \"bytes_gather\": " + std::to_string(r.bytes_gather);
  s += ", \"frozen_tets\": " + std::to_string(r.frozen_tets) + ", \"refrozen_tets\": " + std::to_string(r.refrozen_tets);
  s += ", \"insertions\": " + std::to_string(r.insertions) + ", \"flips\": " + std::to_string(r.flips) +
       ", \"pair_flips\": " + std::to_string(r.pair_flips) +
       ", \"smooth_moves\": " + std::to_string(r.smooth_moves);
  s += ", \"alpha_worst\": " + num(r.after.alpha_worst) + ", \"alpha_mean\": " + num(r.after.alpha_mean) +
       ", \"alpha_below_03\": " + std::to_string(r.after.alpha_below_03) + "}";
  return s;
}

void stop_workers(int size) {
  int zero = 0;
  for (int p = 1; p < size; ++p) MPI_Send(&zero, 1, MPI_INT, p, kTagStop, MPI_COMM_WORLD);
}

// ---------------------------------------------------------------- workers
int worker(const Args& a, int rank) {
  int rc = 0;  // per-rank file errors, reported to rank 0 at the stop
  for (;;) {
    MPI_Status st;
    const int tag = probe_polite(0, st);
    if (tag == kTagStop) {
      int ignored = 0;
      MPI_Recv(&ignored, 1, MPI_INT, 0, kTagStop, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      int all = 0;
      MPI_Reduce(&rc, &all, 1, MPI_INT, MPI_MAX, 0, MPI_COMM_WORLD);
      return kExitOk;
    }
    const std::string msg = recv_bytes(st, nullptr);
    TetMesh part;
    if (tag == kTagWrite) {  // this rank's piece of the final mesh
      Status s = decode_part(msg, part);
      if (s) s = write_part_vtu(a.per_rank, rank, part);
      if (!s) { std::fprintf(stderr, "tetopt-mpi: rank %d: %s\n", rank, tetopt_cli::shown(s.message).c_str()); rc = 1; }
      continue;
    }
    double secs = 0;
    Status s;
    const std::string res = improve_part(msg, a.opt, part, secs, s);
    if (a.verbose) std::fprintf(stderr, "rank %d: %d tets improved in %.3f s\n", rank, part.nt(), secs);
    send_bytes(res, 0, kTagResult, nullptr);
  }
}

// ---------------------------------------------------------------- rank 0
// alpha of every tet into al, and the three numbers the rounds look at (the
// full statistics are computed once, at the end).
// The alphas in parallel (rank 0 has every core while the others wait), the
// sums in tet order: the same numbers for every thread count.
// al[k] = alpha of tet k for k >= from (the tets before are known: the kept
// tets, which merge_parts puts first and unchanged), then the statistics.
QualityStats alpha_scan(const TetMesh& g, std::vector<double>& al, int32_t from = 0) {
  QualityStats q;
  al.resize(static_cast<size_t>(g.nt()));
  tetopt::detail::parallel_for_each(g.nt() - from, kRank0Threads, [&](int64_t j) {
    const int32_t k = from + static_cast<int32_t>(j);
    al[k] = tet_alpha(g, k);
  });
  double sum = 0, worst = std::numeric_limits<double>::infinity();
  for (int32_t k = 0; k < g.nt(); ++k) {
    const double x = al[k];
    sum += x;
    worst = std::min(worst, x);
    q.alpha_below_03 += x < 0.3;
  }
  q.tets = g.nt();
  q.alpha_worst = worst;
  q.alpha_mean = g.nt() ? sum / g.nt() : 0;
  return q;
}

// Vertices the cut should stay away from: around the previous interface
// (level 1; its tets were frozen last round) and around the worst tets
// (level 2: the worst tet and those below both the round's threshold and the
// 1st percentile of alpha; two layers of tets around them).  A tet
// frozen next to a cut keeps its shape while its free neighbours settle
// around it, which can trap the next round in a worse optimum.
std::vector<uint8_t> avoid_flags(const TetMesh& g, const std::vector<double>& al, const std::vector<uint8_t>& prev_shared,
                                 double threshold, double worst) {
  std::vector<uint8_t> avoid =
      prev_shared.empty() ? std::vector<uint8_t>(static_cast<size_t>(g.nv()), 0) : dilate(g, prev_shared, kRank0Threads);
  std::vector<double> sorted = al;
  const size_t q = sorted.size() / 100;
  std::nth_element(sorted.begin(), sorted.begin() + q, sorted.end());
  const double poor = std::max(worst, std::min(threshold, sorted[q]));
  std::vector<uint8_t> bad(static_cast<size_t>(g.nv()), 0);
  mark_tet_vertices(g, bad, kRank0Threads, [&](int32_t k) { return al[k] < poor; });
  bad = dilate(g, dilate(g, std::move(bad), kRank0Threads), kRank0Threads);
  for (size_t v = 0; v < bad.size(); ++v)
    if (bad[v]) avoid[v] = 2;
  return avoid;
}

int leader(const Args& a, int size) {
  const double t_start = now();
  auto say = [&](const char* fmt, auto... xs) {
    if (!a.quiet) { std::printf(fmt, xs...); std::fflush(stdout); }
  };
  // Before any work: the workers are told to stop and join the final reduce.
  auto give_up = [&](const std::string& message, int code) {  // an empty message: printed already
    if (!message.empty()) std::fprintf(stderr, "tetopt-mpi: %s\n", tetopt_cli::shown(message).c_str());
    stop_workers(size);
    int rc = 0, all = 0;
    MPI_Reduce(&rc, &all, 1, MPI_INT, MPI_MAX, 0, MPI_COMM_WORLD);
    return code;
  };
  // The files are distinct and the outputs can be written (as in tetopt
  // improve), checked before any work: "--report IN" replaced the input
  // mesh with the report, and "--report OUT" the improved mesh.
  // -o IN is refused as --report IN is (true, false: OUT is a mesh, and not IN).
  if (const int rc =
          tetopt_cli::check_paths("tetopt-mpi", {{"IN", a.in}, {"-o", a.out}, {"--report", a.report}}, true, false);
      rc != kExitOk)
    return give_up("", rc);
  TetMesh g;
  // As in tetopt improve (worth_sorting, --reorder-above, --keep-order),
  // the tets of a large mesh in no spatial order are put in Morton order of
  // their centroids first: rank 0's passes over the whole mesh (dual graph,
  // extraction, merge) then walk stars in cache.  flange_large comes in no
  // spatial order, and at 2 ranks its round-1 partition took 0.85-1.00 s
  // unsorted against 0.49-0.52 s sorted, extraction 0.26-0.33 s against
  // 0.13-0.17 s, the whole run 11.9-12.9 s against 10.0 s (two runs each).  The tet order of OUT was
  // never IN's (flips, and the parts merged in turn).  A topology error
  // names tets by their number in IN, so a failure after the sort is
  // reproduced on IN's order for its message.
  std::vector<int32_t> order;  // order[id] = id in IN, when the tets were put in Morton order
  OrientationReport orient;
  Status s = tetopt_cli::load_for_improve(a.in, g, orient, kRank0Threads, a.keep_order ? -1 : a.reorder_above, &order,
                                          [](const std::string& p, TetMesh& m, OrientationReport* o, int t) {
                                            return read_mesh(p, m, o, t);
                                          });
  if (!s) return give_up(s.message, kExitInput);
  if (a.write_boundary && add_boundary_triangles(g) > 0) {  // issue 28
    s = build_topology(g, kRank0Threads);
    if (!s) return give_up(s.message, kExitInput);
  }
  if (a.verbose && !order.empty())
    std::fprintf(stderr, "tets put in Morton order of their centroids (IN's order is scattered; --keep-order keeps it)\n");
  const double t_read = now() - t_start;
  const std::vector<std::string> dropped = tetopt_cli::warn_dropped(a.out, g, a.wo, a.quiet);
  const InvariantSnapshot snap = capture_invariants(g, kRank0Threads);
  std::vector<uint8_t> used_in(static_cast<size_t>(g.nv()), 0);  // vertices a tet of IN uses
  for (int32_t v : g.tets) used_in[v] = 1;
  QualityStats before = compute_stats(g, kRank0Threads);
  // The input's worst tet by its number in IN.
  if (!order.empty() && before.worst_tet >= 0 && before.worst_tet < static_cast<int32_t>(order.size()))
    before.worst_tet = order[static_cast<size_t>(before.worst_tet)];
  say("%s: %d vertices, %d tets, %d ranks; read in %.3f s\n", a.in.c_str(), g.nv(), g.nt(), size, t_read);

  std::vector<RoundLog> logs;
  std::vector<uint8_t> prev_shared;  // interface vertices of the previous round
  int exit_code = kExitOk;
  std::string failure;
  std::vector<double> al;  // alpha of every tet of g, current
  QualityStats cur = alpha_scan(g, al);
  int stale = 0;  // rounds in a row that did not raise the worst alpha
  for (int round = 1; round <= a.rounds; ++round) {
    RoundLog L;
    L.round = round;
    const double r0 = now();
    // The round's threshold: the user's, or 0.1 above the current worst
    // alpha once the worst tet is past it, plus 0.1 for every round in a row
    // that did not raise the worst alpha (at most 0.6).  improve's own rising
    // threshold stops early in a part whose worst tet is frozen at the cut (it
    // sees no progress), so the rounds carry the rise across partitions.
    // (Rising by a fixed 0.1 a round, or keeping the user's threshold, gave
    // worse results on generated boxes: docs/mpi.md.)
    const double gamma = std::max(a.opt.threshold, std::min(0.6, cur.alpha_worst + 0.1 + 0.1 * stale));
    L.threshold = gamma;
    // ---- partition.  Round 1 improves every tet.  Later rounds improve only
    // where there is something left to do: the band around the previous
    // interface (three layers of vertices; its tets were frozen) and the tets
    // below this round's threshold (with the tets around their vertices'
    // neighbours).  The other tets
    // stay on rank 0 unchanged; the faces between them and the band are
    // frozen like the cut.
    std::vector<uint8_t> active;
    if (round > 1) {
      std::vector<uint8_t> near = prev_shared;
      near.resize(static_cast<size_t>(g.nv()), 0);
      near = dilate(g, dilate(g, dilate(g, std::move(near), kRank0Threads), kRank0Threads), kRank0Threads);
      std::vector<uint8_t> poor(static_cast<size_t>(g.nv()), 0);
      mark_tet_vertices(g, poor, kRank0Threads, [&](int32_t k) { return al[k] < gamma; });
      poor = dilate(g, std::move(poor), kRank0Threads);
      active.assign(static_cast<size_t>(g.nt()), 0);
      tetopt::detail::parallel_for_each(g.nt(), kRank0Threads, [&](int64_t k) {
        const int32_t* v = g.tet(static_cast<int32_t>(k));
        active[k] = near[v[0]] || poor[v[0]] || near[v[1]] || poor[v[1]] || near[v[2]] || poor[v[2]] ||
                    near[v[3]] || poor[v[3]];
      });
      L.active_tets = tetopt::detail::parallel_count(g.nt(), kRank0Threads, [&](int64_t k) { return active[k] != 0; });
      if (L.active_tets < size) {
        say("round %d: nothing left to improve\n", round);
        break;
      }
    } else {
      L.active_tets = g.nt();
    }
    // A later round with few active tets (a thin band around the last cut
    // and the poor tets) runs on rank 0 alone, with every core of its node:
    // no partition, no messages, and no cut, so no tet is frozen but those
    // next to the kept ones.  On flange_large at 2 ranks, rounds 3 to 5
    // (17k-35k active tets) each cost 0.3-0.4 s of partition, extraction,
    // messages and merge beside 0.1-0.3 s of improve, and each new cut froze
    // tets that the next round had to free again.
    L.local = size > 1 && round > 1 && L.active_tets <= a.local_below;
    const int nparts = L.local ? 1 : size;
    std::vector<int32_t> part;
    if (L.local) {
      part.resize(static_cast<size_t>(g.nt()));
      tetopt::detail::parallel_for_each(g.nt(), kRank0Threads, [&](int64_t k) { part[k] = active[k] ? 0 : 1; });
    } else {
      std::vector<uint8_t> avoid;
      if (size > 1) avoid = avoid_flags(g, al, prev_shared, gamma, cur.alpha_worst);
      PartitionOptions po;
      po.parts = size;
      po.seed = static_cast<int>(a.opt.seed % 1000003) + round;
      po.threshold = gamma;
      po.avoid = avoid.empty() ? nullptr : &avoid;
      po.active = active.empty() ? nullptr : &active;
      po.alpha = &al;
      po.threads = kRank0Threads;
      po.contract_above = a.contract_above;
      std::string err;
      part = partition_tets(g, po, err, &L.graph_contracted);
      if (part.empty()) { failure = err; exit_code = kExitInput; break; }
      if (size > 1) {
        // METIS's cut may still pass next to a worst tet (the weights are a
        // preference); the 32 worst tets below the threshold take their
        // neighbourhoods into their own part.
        std::vector<int32_t> seeds;
        for (int32_t k = 0; k < g.nt(); ++k)
          if (al[k] < gamma || al[k] == cur.alpha_worst) seeds.push_back(k);
        const size_t n = std::min<size_t>(32, seeds.size());
        std::partial_sort(seeds.begin(), seeds.begin() + static_cast<std::ptrdiff_t>(n), seeds.end(),
                          [&](int32_t x, int32_t y) { return al[x] < al[y] || (al[x] == al[y] && x < y); });
        seeds.resize(n);
        L.pulled_tets = pull_in(g, part, size, seeds);
      }
    }
    L.t_partition = now() - r0;
    // ---- extract the parts (plus the kept group, not sent)
    double t = now();
    std::vector<PartPlan> plans;
    std::vector<std::string> msgs;
    std::vector<uint8_t> shared;
    build_parts(g, part, nparts, plans, msgs, shared);
    L.t_extract = now() - t;
    L.frozen_tets = count_touching(g, shared, kRank0Threads);
    {  // is the worst tet touching this round's interface?
      const int32_t w = static_cast<int32_t>(std::min_element(al.begin(), al.end()) - al.begin());
      for (int j = 0; j < 4; ++j) L.worst_frozen |= shared[g.tet(w)[j]] != 0;
    }
    if (!prev_shared.empty()) {
      prev_shared.resize(static_cast<size_t>(g.nv()), 0);
      L.refrozen_tets = tetopt::detail::parallel_count(g.nt(), kRank0Threads, [&](int64_t k) {
        const int32_t* v = g.tet(static_cast<int32_t>(k));
        bool now_f = false, before_f = false;
        for (int j = 0; j < 4; ++j) { now_f |= shared[v[j]] != 0; before_f |= prev_shared[v[j]] != 0; }
        return now_f && before_f;
      });
    }
    for (int p = 0; p < size; ++p) {
      L.tets_per_rank.push_back(p < nparts ? plans[p].tets : 0);
      L.interface_vertices_per_rank.push_back(p < nparts ? plans[p].interface_vertices : 0);
    }
    // ---- scatter
    // Guards: every part is held to the whole mesh's extremes as they are
    // now (one measure pass on rank 0), not to its own better ones.
    Floor floor;
    floor.fill(NAN);
    if (a.opt.guard) {
      tetopt::Guard whole;
      tetopt::Guard::take(g, kRank0Threads, whole);
      for (int k = 0; k < tetopt::kTetMeasureCount; ++k)
        floor[static_cast<size_t>(k)] = whole.extreme(static_cast<tetopt::Measure>(k));
    }
    for (int p = 0; p < nparts; ++p)
      msgs[p] = frame(gamma, floor, std::move(msgs[p]));
    bool sent = true;
    for (int p = 1; p < nparts && sent; ++p) {
      L.bytes_scatter += static_cast<int64_t>(msgs[p].size());
      sent = send_bytes(msgs[p], p, kTagPart, &L.t_scatter);
    }
    if (!sent) { failure = "a part message exceeds 2 GiB (not supported)"; exit_code = kExitInput; break; }
    // ---- improve part 0 here
    double own_secs = 0;
    Status own_st;
    TetMesh own;
    ImproveOptions own_opt = a.opt;
    if (L.local) own_opt.threads = kRank0Threads;
    std::string own_res = improve_part(msgs[0], own_opt, own, own_secs, own_st);
    own = TetMesh{};
    L.t_improve_own = own_secs;
    std::string().swap(msgs[0]);
    // ---- gather
    std::vector<PartResult> results(static_cast<size_t>(nparts));
    t = now();
    decode_result(own_res, results[0]);
    std::string().swap(own_res);
    for (int got = 1; got < nparts; ++got) {
      MPI_Status st;
      probe_polite(MPI_ANY_SOURCE, st);
      const std::string b = recv_bytes(st, &L.t_gather_transfer);
      L.bytes_gather += static_cast<int64_t>(b.size());
      if (!decode_result(b, results[st.MPI_SOURCE])) {
        results[st.MPI_SOURCE].code = static_cast<int>(ErrorCode::Invariant);
        results[st.MPI_SOURCE].message = "truncated result message";
      }
    }
    L.t_gather_wait = now() - t - L.t_gather_transfer;
    msgs.clear();
    for (int p = 0; p < static_cast<int>(results.size()); ++p) {
      const PartResult& r = results[p];
      if (r.code != 0) {
        failure = "rank " + std::to_string(p) + ": " + r.message;
        exit_code = r.code == static_cast<int>(ErrorCode::Invariant) ? kExitInvariant : kExitInput;
      }
      L.improve_per_rank.push_back(r.seconds);
      L.insertions += r.rep.insertions;
      const int64_t fl = r.rep.flip23 + r.rep.flip32 + r.rep.edge_removals + r.rep.multi_face_removals +
                         r.rep.flip22 + r.rep.flip44;
      L.flips += fl;
      L.pair_flips += r.rep.pair_flips;
      L.flips_per_rank.push_back(fl);
      L.improve_rounds_per_rank.push_back(r.rep.rounds);
      L.smooth_moves += r.rep.smooth_moves;
    }
    if (exit_code != kExitOk) break;
    L.improve_max = *std::max_element(L.improve_per_rank.begin(), L.improve_per_rank.end());
    L.improve_min = *std::min_element(L.improve_per_rank.begin(), L.improve_per_rank.end());
    for (double x : L.improve_per_rank) L.improve_sum += x;
    // ---- merge
    t = now();
    // The kept tets' alpha, in the order merge_parts puts them first.
    int32_t nkept = 0;
    for (int32_t k = 0; k < g.nt(); ++k)
      if (part[k] == nparts) al[static_cast<size_t>(nkept++)] = al[k];
    s = merge_parts(g, part, plans, results, kRank0Threads);
    L.t_merge = now() - t;
    if (!s) { failure = s.message; exit_code = kExitInvariant; break; }
    t = now();
    std::vector<int32_t>().swap(part);
    L.after = alpha_scan(g, al, nkept);
    L.t_stats = now() - t;
    L.t_total = now() - r0;
    if (L.local)
      say("round %d (threshold %.2f, %lld tets active, on rank 0 alone): worst alpha %.4f -> %.4f, "
          "%lld tets below 0.3; select %.3f s, extract %.3f s, improve %.3f s, merge %.3f s\n",
          round, gamma, static_cast<long long>(L.active_tets), cur.alpha_worst, L.after.alpha_worst,
          static_cast<long long>(L.after.alpha_below_03), L.t_partition, L.t_extract, L.improve_max, L.t_merge);
    else
      say("round %d (threshold %.2f, %lld tets active): worst alpha %.4f -> %.4f, %lld tets below 0.3; "
          "partition %.3f s, extract %.3f s, scatter %.3f s (%.1f MB), improve %.3f s (max over ranks; min %.3f s), "
          "gather wait %.3f s + transfer %.3f s (%.1f MB), merge %.3f s; %lld tets frozen at the interface, "
          "%lld of them also frozen in the previous round%s\n",
          round, gamma, static_cast<long long>(L.active_tets), cur.alpha_worst, L.after.alpha_worst,
          static_cast<long long>(L.after.alpha_below_03), L.t_partition, L.t_extract, L.t_scatter,
          L.bytes_scatter / 1e6, L.improve_max, L.improve_min, L.t_gather_wait, L.t_gather_transfer,
          L.bytes_gather / 1e6, L.t_merge, static_cast<long long>(L.frozen_tets),
          static_cast<long long>(L.refrozen_tets), L.worst_frozen ? "; the worst tet was at the interface" : "");
    // A gain is a rise of the worst alpha by 0.001 or more: a tet locked near
    // alpha 0.0003 (aorta_vessel) otherwise "gains" 1e-5 a round while every
    // round re-improves most of the mesh.
    const bool gained = L.after.alpha_worst >= cur.alpha_worst + 1e-3;
    stale = gained ? 0 : stale + 1;
    cur = L.after;
    const bool was_local = L.local;
    logs.push_back(std::move(L));
    prev_shared = std::move(shared);
    // Two rounds in a row without gain end the run: the next cut frees other
    // tets (one run of 28 gained after such a round).  A local round has no
    // cut to move: after one without gain the run ends (22 runs on 11
    // meshes at 2 and 4 ranks: none gained after a local round without gain).
    if (stale >= 2 || (stale >= 1 && was_local)) break;
  }
  // ---- prove and write
  double t_check = 0, t_write = 0, t_parts = 0;
  if (exit_code == kExitOk) {
    const double t = now();
    s = check_invariants(g, snap, kRank0Threads);
    t_check = now() - t;
    if (!s) { failure = s.message; exit_code = kExitInvariant; }
  }
  if (exit_code == kExitOk && a.opt.allow_remove) {
    // A vertex no tet uses now was removed by a part, unless it was already
    // unused in IN (kept as it was): IN's vertices a tet used, and every
    // vertex inserted since (ids past IN's).
    std::vector<uint8_t> used(static_cast<size_t>(g.nv()), 0);
    for (int32_t v : g.tets) used[v] = 1;
    std::vector<int32_t> drop;
    for (int32_t v = 0; v < g.nv(); ++v)
      if (!used[v] && (v >= static_cast<int32_t>(used_in.size()) || used_in[v])) drop.push_back(v);
    s = compact_vertices(g, drop);
    if (!s) { failure = s.message; exit_code = kExitInvariant; }
  }
  if (exit_code == kExitOk) {
    const double t = now();
    WriteOptions wo = a.wo;
    wo.threads = kRank0Threads;
    s = write_mesh(a.out, g, wo);
    t_write = now() - t;
    if (!s) { failure = s.message; exit_code = kExitOutput; }
  }
  // ---- one piece of the final mesh per rank, written by that rank
  const bool write_parts = exit_code == kExitOk && !a.per_rank.empty();
  int rc = 0;
  if (write_parts) {
    const double t = now();
    std::error_code ec;
    std::filesystem::create_directories(a.per_rank, ec);
    PartitionOptions po;
    po.parts = size;
    po.seed = static_cast<int>(a.opt.seed % 1000003);
    po.threshold = a.opt.threshold;
    std::string err;
    std::vector<int32_t> part = partition_tets(g, po, err);
    if (part.empty()) {
      std::fprintf(stderr, "tetopt-mpi: %s\n", tetopt_cli::shown(err).c_str());
      rc = 1;
    } else {
      std::vector<PartPlan> plans;
      std::vector<std::string> msgs;
      std::vector<uint8_t> shared;
      build_parts(g, part, size, plans, msgs, shared);
      for (int p = 1; p < size; ++p) send_bytes(msgs[p], p, kTagWrite, nullptr);
      TetMesh own;
      s = decode_part(msgs[0], own);
      if (s) s = write_part_vtu(a.per_rank, 0, own);
      if (s) s = write_pvtu(a.per_rank, size);
      if (!s) { std::fprintf(stderr, "tetopt-mpi: %s\n", tetopt_cli::shown(s.message).c_str()); rc = 1; }
    }
    t_parts = now() - t;
  }
  stop_workers(size);
  int all = 0;
  MPI_Reduce(&rc, &all, 1, MPI_INT, MPI_MAX, 0, MPI_COMM_WORLD);
  if (exit_code == kExitOk && all) { exit_code = kExitOutput; failure = "writing the per-rank files failed"; }
  if (exit_code != kExitOk) {
    std::fprintf(stderr, "tetopt-mpi: %s: %s\n", tetopt_cli::shown(a.in).c_str(), tetopt_cli::shown(failure).c_str());
    if (exit_code == kExitInvariant) std::fputs("tetopt-mpi: invariant failure (a bug): nothing written\n", stderr);
    return exit_code;
  }
  const double total = now() - t_start;
  const double t_stats = now();
  const QualityStats after = compute_stats(g, kRank0Threads);
  const double t_final_stats = now() - t_stats;
  if (!a.quiet) {
    std::printf("%s -> %s (%d ranks, mode %s, %zu rounds)\n", tetopt_cli::shown(a.in).c_str(),
                tetopt_cli::shown(a.out).c_str(), size,
                mode_name(a.opt.mode), logs.size());
    std::printf("%s", format_before_after(before, after, total).c_str());
    std::printf("  time: read %.3f s, final check %.3f s, final statistics %.3f s, write %.3f s, per-rank files "
                "%.3f s, end to end %.3f s\n", t_read, t_check, t_final_stats, t_write, t_parts, total);
    std::printf("  boundary unchanged: yes (checked on the merged mesh: constrained vertices bit-identical, "
                "constrained faces identical, no inverted tet, region volumes kept)\n");
    if (write_parts) std::printf("  wrote %d pieces and %s/parts.pvtu\n", size, tetopt_cli::shown(a.per_rank).c_str());
  }
  if (!a.report.empty()) {
    int64_t bs = 0, bg = 0;
    for (const RoundLog& L : logs) { bs += L.bytes_scatter; bg += L.bytes_gather; }
    std::string js = "{\n  \"tool\": \"tetopt-mpi\",\n  \"input\": " + json_string(a.in) +
                     ",\n  \"output\": " + json_string(a.out) + ",\n  \"ranks\": " + std::to_string(size) +
                     ",\n  \"threads_per_rank\": " + std::to_string(a.opt.threads) +
                     ",\n  \"mode\": " + json_string(mode_name(a.opt.mode)) +
                     ",\n  \"tets_in\": " + std::to_string(before.tets) +
                     ",\n  \"seconds_read\": " + num(t_read) + ",\n  \"seconds_check\": " + num(t_check) +
                     ",\n  \"seconds_final_stats\": " + num(t_final_stats) +
                     ",\n  \"seconds_write\": " + num(t_write) + ",\n  \"seconds_per_rank_files\": " + num(t_parts) +
                     ",\n  \"seconds_end_to_end\": " + num(total) +
                     ",\n  \"tets_reordered\": " + (order.empty() ? "false" : "true") +
                     ",\n  \"dropped_on_write\": " + json_string_list(dropped) +
                     ",\n  \"bytes_scatter\": " + std::to_string(bs) + ",\n  \"bytes_gather\": " + std::to_string(bg) +
                     ",\n  \"invariants_ok\": true,\n  \"rounds\": [\n";
    for (size_t i = 0; i < logs.size(); ++i) js += round_json(logs[i]) + (i + 1 < logs.size() ? ",\n" : "\n");
    js += "  ],\n  \"before\": " + stats_to_json(before, 2) + ",\n  \"after\": " + stats_to_json(after, 2) + "\n}\n";
    s = write_file_atomic(a.report, js);
    if (!s) { std::fprintf(stderr, "tetopt-mpi: %s\n", tetopt_cli::shown(s.message).c_str()); return kExitOutput; }
  }
  return kExitOk;
}

// SIGTERM / SIGHUP / SIGINT (mpirun passes them on): the temporary files of
// rank 0's writes in progress are removed, then the signal's default action.
void on_terminating_signal(int sig) {
  remove_pending_temporaries();
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

}  // namespace

int main(int argc, char** argv) {
  tetopt_cli::reexec_with_huge_pages(argv);  // before MPI starts (same process id)
  tetopt_cli::keep_freed_memory();
  MPI_Init(&argc, &argv);
  for (const int sig : {SIGTERM, SIGHUP, SIGINT}) std::signal(sig, on_terminating_signal);
  // Past a file size limit (ulimit -f) a write fails with EFBIG (exit 4, the
  // temporary file removed) instead of SIGXFSZ killing rank 0 mid-write.
  std::signal(SIGXFSZ, SIG_IGN);
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  Args a;
  std::string err;
  const int prc = parse_args(argc, argv, a, err);
  int rc = kExitOk;
  if (prc == -1) {
    if (rank == 0) std::fputs(kHelp, stdout);
  } else if (prc > 0) {
    if (rank == 0) std::fprintf(stderr, "%s\n\n%s", tetopt_cli::shown(err).c_str(), kHelp);
    rc = prc;
  } else {
    rc = rank == 0 ? leader(a, size) : worker(a, rank);
  }
  MPI_Finalize();
  return rc;
}
