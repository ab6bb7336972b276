// Progress and cancellation of improve() (improve.hpp: ImproveOptions::progress,
// the `interrupted` abort flag, ErrorCode::Stopped).
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "tetopt/generate.hpp"
#include "tetopt/improve.hpp"
#include "tetopt/invariants.hpp"
#include "tetopt/mesh.hpp"

using namespace tetopt;

namespace {

TetMesh jittered_box(int n) {
  BoxMeshOptions o;
  o.nx = o.ny = o.nz = n;
  o.jitter = 0.4;
  o.seed = 11;
  o.regions = 2;
  TetMesh m = make_box_mesh(o);
  EXPECT_TRUE(build_topology(m));
  return m;
}

struct Seen {
  std::string phase;
  int round;
  double fraction, worst;
};

}  // namespace

TEST(Progress, CallbackSeesEveryPhaseAndDoesNotChangeTheResult) {
  const TetMesh input = jittered_box(8);
  TetMesh plain = input;
  ImproveReport plain_rep;
  ASSERT_TRUE(improve(plain, ImproveOptions{}, plain_rep));

  TetMesh m = input;
  ImproveOptions o;
  std::vector<Seen> seen;
  o.progress = [&](const ImproveProgress& p) {
    seen.push_back({p.phase, p.round, p.fraction, p.worst});
    return true;
  };
  ImproveReport rep;
  const Status s = improve(m, o, rep);
  ASSERT_TRUE(s.ok()) << s.message;
  EXPECT_FALSE(rep.stopped_early);
  ASSERT_GE(seen.size(), 4u);
  EXPECT_EQ(seen.front().phase, "start");
  EXPECT_EQ(seen.back().phase, "done");
  EXPECT_EQ(seen.back().fraction, 1.0);
  bool flips = false, smooth = false;
  for (size_t i = 0; i < seen.size(); ++i) {
    flips |= seen[i].phase == "flips";
    smooth |= seen[i].phase == "smooth";
    EXPECT_GE(seen[i].fraction, 0.0);
    EXPECT_LE(seen[i].fraction, 1.0);
    if (i > 0) {
      EXPECT_GE(seen[i].fraction, seen[i - 1].fraction) << seen[i].phase;
    }
    if (seen[i].phase == "flips") {
      EXPECT_GE(seen[i].round, 1);
      EXPECT_TRUE(seen[i].worst > 0 && seen[i].worst <= 1) << seen[i].worst;
    }
  }
  EXPECT_TRUE(flips && smooth);
  EXPECT_EQ(seen.back().worst, rep.after.alpha_worst);
  // The callback only watches: same mesh, bit for bit.
  ASSERT_EQ(m.xyz.size(), plain.xyz.size());
  EXPECT_EQ(0, std::memcmp(m.xyz.data(), plain.xyz.data(), m.xyz.size() * sizeof(double)));
  EXPECT_EQ(m.tets, plain.tets);
}

TEST(Progress, FalseStopsEarlyWithAValidCheckedMesh) {
  const TetMesh input = jittered_box(8);
  TetMesh full = input;
  ImproveReport full_rep;
  ASSERT_TRUE(improve(full, ImproveOptions{}, full_rep));
  ASSERT_GE(full_rep.rounds, 2);

  TetMesh m = input;
  ImproveOptions o;
  int calls = 0;
  o.progress = [&](const ImproveProgress& p) {
    ++calls;
    return !(p.round == 1 && std::string(p.phase) == "flips");  // stop after round 1's flips
  };
  ImproveReport rep;
  const Status s = improve(m, o, rep);
  EXPECT_EQ(s.code, ErrorCode::Stopped) << s.message;
  EXPECT_TRUE(s.stopped());
  EXPECT_FALSE(s.ok());
  EXPECT_TRUE(s.mesh_valid());
  EXPECT_TRUE(rep.stopped_early);
  EXPECT_EQ(rep.rounds, 1);
  EXPECT_LT(rep.rounds, full_rep.rounds);
  EXPECT_EQ(rep.smooth_moves, 0);  // stopped before round 1's smoothing
  EXPECT_GT(rep.flip23 + rep.flip32 + rep.edge_removals + rep.multi_face_removals, 0);
  // The final proof ran and passed; the after statistics are the mesh's.
  EXPECT_TRUE(rep.invariants_checked);
  EXPECT_TRUE(rep.invariants_ok) << rep.invariant_message;
  EXPECT_TRUE(validate(m, ValidateLevel::Full)) << validate(m, ValidateLevel::Full).message;
  EXPECT_GE(rep.after.alpha_worst, rep.before.alpha_worst);
  EXPECT_EQ(rep.after.tets, m.nt());
  // Called up to the stop and not after ("done" is skipped): start,
  // all-boundary, flips.
  EXPECT_EQ(calls, 3);
  const std::string js = report_to_json(rep, o, "in", "out");
  EXPECT_NE(js.find("\"stopped_early\": true"), std::string::npos);
}

TEST(Progress, FalseAtStartLeavesTheMeshAsItWas) {
  const TetMesh input = jittered_box(5);
  TetMesh m = input;
  ImproveOptions o;
  o.progress = [](const ImproveProgress&) { return false; };
  ImproveReport rep;
  const Status s = improve(m, o, rep);
  EXPECT_TRUE(s.stopped()) << s.message;
  EXPECT_EQ(rep.rounds, 0);
  EXPECT_EQ(m.tets, input.tets);
  EXPECT_EQ(0, std::memcmp(m.xyz.data(), input.xyz.data(), m.xyz.size() * sizeof(double)));
  EXPECT_TRUE(rep.invariants_ok);
}

TEST(Progress, InterruptedAbortsInsideAPassWithAValidMesh) {
  const TetMesh input = jittered_box(10);
  for (ImproveMode mode : {ImproveMode::Best, ImproveMode::Combined, ImproveMode::Smooth, ImproveMode::Topo}) {
    TetMesh m = input;
    const InvariantSnapshot snap = capture_invariants(m);
    ImproveOptions o;
    o.mode = mode;
    std::atomic<bool> stop{false};
    // The flag is raised from the first phase boundary after the start, as
    // a signal handler would: the run must end without another phase.
    std::vector<std::string> phases;
    o.progress = [&](const ImproveProgress& p) {
      phases.push_back(p.phase);
      if (std::string(p.phase) != "start") stop = true;
      return true;
    };
    ImproveReport rep;
    const Status s = improve(m, o, rep, {}, &stop);
    EXPECT_TRUE(s.stopped()) << mode_name(mode) << ": " << s.message;
    EXPECT_TRUE(rep.stopped_early);
    EXPECT_FALSE(rep.invariants_checked);  // an abort skips the proof
    ASSERT_EQ(phases.size(), 2u) << mode_name(mode);
    // ... but the mesh keeps every promise.
    ensure_vertex_tets(m);
    EXPECT_TRUE(check_invariants(m, snap)) << mode_name(mode);
    EXPECT_TRUE(validate(m, ValidateLevel::Full)) << mode_name(mode);
  }
}

TEST(Progress, InterruptedInsideAPassEndsThatPass) {
  // The flag raised while a pass runs (from its log line, as a signal could
  // at any time): that pass does no further pass / sweep, and no other
  // phase runs.
  const TetMesh input = jittered_box(10);
  for (const std::string trigger : {"topo flip pass 1:", "smooth phase 1 sweep 1:"}) {
    TetMesh m = input;
    ImproveOptions o;
    o.mode = trigger[0] == 's' ? ImproveMode::Smooth : ImproveMode::Topo;
    o.iterations = 10;
    std::atomic<bool> stop{false};
    std::vector<std::string> lines;
    LogFn log = [&](LogLevel, const std::string& msg) {
      lines.push_back(msg);
      if (msg.rfind(trigger, 0) == 0) stop = true;
    };
    ImproveReport rep;
    const Status s = improve(m, o, rep, log, &stop);
    EXPECT_TRUE(s.stopped()) << trigger << ": " << s.message;
    ASSERT_FALSE(lines.empty());
    EXPECT_EQ(lines.back().rfind(trigger, 0), 0u) << trigger << ": last line '" << lines.back() << "'";
    EXPECT_TRUE(validate(m, ValidateLevel::Full));
  }
  // Without the flag, the same runs go on past that line.
  for (const std::string trigger : {"topo flip pass 1:", "smooth phase 1 sweep 1:"}) {
    TetMesh m = input;
    ImproveOptions o;
    o.mode = trigger[0] == 's' ? ImproveMode::Smooth : ImproveMode::Topo;
    std::vector<std::string> lines;
    ImproveReport rep;
    ASSERT_TRUE(improve(m, o, rep, [&](LogLevel, const std::string& msg) { lines.push_back(msg); }));
    ASSERT_FALSE(lines.empty());
    EXPECT_NE(lines.back().rfind(trigger, 0), 0u) << trigger;
  }
}

TEST(Progress, InterruptedBeforeTheRunChangesNothing) {
  const TetMesh input = jittered_box(6);
  TetMesh m = input;
  std::atomic<bool> stop{true};
  ImproveReport rep;
  const Status s = improve(m, ImproveOptions{}, rep, {}, &stop);
  EXPECT_TRUE(s.stopped());
  EXPECT_EQ(rep.smooth_moves + rep.flip23 + rep.flip32 + rep.edge_removals, 0);
  EXPECT_EQ(m.tets, input.tets);
}
