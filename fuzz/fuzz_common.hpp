// Shared driver of the reader fuzz targets: what read_mesh does after a
// parse (refs filled, check_arrays, normalize_orientation), then the
// topology, a full validate(), and a write / re-read round trip that must
// give back the same coordinates (bit for bit), tets and refs.  Any
// disagreement aborts, so libFuzzer records the input as a crash.
//
// TETOPT_FUZZ_STRICT=1 (fuzz/check_seeds.sh) makes every refusal abort too,
// with the reader's reason: running a target on its seed files then checks
// that each seed is a valid file that reaches the topology checks and the
// round trip (a refused seed only teaches the fuzzer the refusal path).
#pragma once
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

#include "tetopt/invariants.hpp"
#include "tetopt/io.hpp"
#include "tetopt/mesh.hpp"

namespace tetopt_fuzz {

[[noreturn]] inline void die(const char* what, const std::string& msg = {}) {
  std::fprintf(stderr, "tetopt fuzz: %s %s\n", what, msg.c_str());
  std::abort();
}

/// Whether TETOPT_FUZZ_STRICT is set (read once).
inline bool strict() {
  static const bool s = [] {
    const char* e = std::getenv("TETOPT_FUZZ_STRICT");
    return e && *e && std::strcmp(e, "0") != 0;
  }();
  return s;
}

/// An input the reader (or a later check) rightly refused: 0 for libFuzzer,
/// an abort with the reason in strict mode.
inline int refused(const char* what, const std::string& msg = {}) {
  if (strict()) die(what, msg);
  return 0;
}

// Fuzz inputs are small; a mesh this large would only make the run slow.
inline constexpr int32_t kMaxTets = 20000;

/// The steps read_mesh performs after parsing.  Returns false when the mesh
/// is (rightly) rejected.
inline bool finish_read(tetopt::TetMesh& m, tetopt::Format f) {
  using namespace tetopt;
  m.source_format = static_cast<int>(f);
  if (m.vert_ref.empty()) m.vert_ref.assign(m.nv(), 0);
  if (m.tet_ref.empty()) m.tet_ref.assign(m.nt(), 0);
  if (m.tri_ref.size() < static_cast<size_t>(m.ntri())) m.tri_ref.resize(m.ntri(), 0);
  if (m.edge_ref.size() < m.edges.size() / 2) m.edge_ref.resize(m.edges.size() / 2, 0);
  if (Status s = check_arrays(m, "fuzz"); !s) return refused("check_arrays refused the mesh:", s.message) != 0;
  normalize_orientation(m);
  return true;
}

/// Topology and validation of an accepted mesh.
inline void check_topology(tetopt::TetMesh m) {
  using namespace tetopt;
  if (m.nt() > kMaxTets) return (void)refused("more tets than kMaxTets");
  OrientationReport r = normalize_orientation(m);
  if (strict() && !(r.inverted.empty() && r.flat_tets.empty())) die("strict: inverted or flat tets");
  // Non-manifold or duplicate tets: a clean refusal.
  if (Status s = build_topology(m); !s) return (void)refused("build_topology refused the mesh:", s.message);
  if (Status s = validate(m, ValidateLevel::Cheap); !s) die("validate(Cheap) after build_topology:", s.message);
  if (r.inverted.empty() && r.flat_tets.empty())
    if (Status s = validate(m, ValidateLevel::Full); !s) die("validate(Full) of a positive mesh:", s.message);
  InvariantSnapshot snap = capture_invariants(m);
  if (Status s = check_invariants(m, snap); !s) die("check_invariants of an unchanged mesh:", s.message);
}

inline void same_or_die(const tetopt::TetMesh& a, const tetopt::TetMesh& b, const char* fmt) {
  if (a.xyz.size() != b.xyz.size() ||
      (!a.xyz.empty() && std::memcmp(a.xyz.data(), b.xyz.data(), a.xyz.size() * sizeof(double)) != 0))
    die(fmt, "round trip changed the coordinates");
  if (a.tets != b.tets) die(fmt, "round trip changed the tets");
  if (a.tet_ref != b.tet_ref) die(fmt, "round trip changed the tet refs");
}

}  // namespace tetopt_fuzz
