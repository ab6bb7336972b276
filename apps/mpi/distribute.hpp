// tetopt-mpi: partition a global mesh, cut it into parts with frozen
// interfaces, and put the improved parts back together.  No MPI here: these
// functions are plain data transformations, the driver (main.cpp) moves the
// bytes.
//
// The promise in parallel.  A part is a TetMesh of its tets with local vertex
// numbers.  In it every vertex constrained in the global mesh, and every vertex
// shared with another part (the partition interface), is listed as required;
// every face constrained in the global mesh is listed as a triangle; every
// listed edge with both ends in the part is listed.  Faces on the partition cut
// lie on one tet of the part and so are constrained there by construction.
// improve() on a part therefore moves only vertices that are interior to the
// part and free in the global mesh, and keeps every cut face: the parts fit
// back together into a conforming mesh whose constrained entities are those of
// the input, bit for bit.  main.cpp proves it at the end with
// check_invariants against the snapshot of the input.
#pragma once
#include <atomic>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "tetopt/improve.hpp"
#include "tetopt/mesh.hpp"

#include "detail/parallel.hpp"

namespace tetopt_mpi {

/// Byte buffer writer / reader for the messages (native endianness: all
/// ranks of one run share one architecture).
struct Writer {
  std::string buf;
  template <class T> void put(const T& v) { buf.append(reinterpret_cast<const char*>(&v), sizeof(T)); }
  template <class T> void put_vec(const std::vector<T>& v) {
    put<uint64_t>(v.size());
    if (!v.empty()) buf.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
};
struct Reader {
  const std::string& buf;
  size_t pos = 0;
  bool ok = true;
  explicit Reader(const std::string& b) : buf(b) {}
  template <class T> T get() {
    T v{};
    if (pos + sizeof(T) > buf.size()) { ok = false; return v; }
    std::memcpy(&v, buf.data() + pos, sizeof(T));
    pos += sizeof(T);
    return v;
  }
  template <class T> std::vector<T> get_vec() {
    const uint64_t n = get<uint64_t>();
    std::vector<T> v;
    if (!ok || n > (buf.size() - pos) / sizeof(T)) { ok = false; return v; }
    v.resize(n);
    if (n) std::memcpy(v.data(), buf.data() + pos, n * sizeof(T));  // data() may be null when n == 0
    pos += n * sizeof(T);
    return v;
  }
};

/// How the partitioner weights the dual graph (see partition_tets).
struct PartitionOptions {
  int parts = 1;
  int seed = 0;
  double threshold = 0.3;        ///< tets with alpha below it weigh more (work balance)
  /// Per vertex of g (nullptr in round 1): 1 near the previous round's
  /// interface, 2 near the worst tets.  Dual edges whose face touches a
  /// flagged vertex are made expensive to cut (2 more than 1), so the new
  /// interface avoids the tets frozen in the previous round and leaves the
  /// worst tets, with room around them, inside one part.
  const std::vector<uint8_t>* avoid = nullptr;
  /// Per tet (nullptr: all): only these are partitioned and improved; the
  /// others form group `parts`, kept unchanged by rank 0.
  const std::vector<uint8_t>* active = nullptr;
  /// Per tet (nullptr: computed here): alpha, for the work weights.
  const std::vector<double>* alpha = nullptr;
  int threads = 1;  ///< for building the graph (0: all cores); same result for any
  /// Above this many active tets the dual graph is contracted by groups of
  /// tets with the same smallest vertex before METIS (faster, a more ragged
  /// cut); at or below, METIS gets the dual graph itself.
  int64_t contract_above = 250000;
};

/// Part id (0..parts-1, or parts for an inactive tet) of every tet of g
/// (topology built), from METIS (METIS_PartGraphKway on the dual graph of the
/// active tets, or on its contraction, see PartitionOptions::contract_above).
/// Returns an empty vector and sets err when METIS fails.  contracted
/// (optional): set to whether METIS got the contracted graph.
std::vector<int32_t> partition_tets(const tetopt::TetMesh& g, const PartitionOptions& opt, std::string& err,
                                    bool* contracted = nullptr);

/// Moves the tets within two vertex layers of each seed tet (in the given
/// order; earlier seeds win) into the seed's part, so no cut passes through
/// a seed's vertices or those of its neighbours.  Tets of the kept group
/// (part id kept_id) are left alone.  Returns the number of tets moved.
int64_t pull_in(const tetopt::TetMesh& g, std::vector<int32_t>& part, int32_t kept_id,
                const std::vector<int32_t>& seeds);

/// One part as rank 0 keeps it: the global ids of its vertices (local id =
/// index), and the serialised part mesh to send.
struct PartPlan {
  std::vector<int32_t> gids;
  std::vector<uint8_t> fixed;   ///< per local vertex: 1 when listed required in the part
  int64_t tets = 0, interface_vertices = 0;
};

/// Builds the plan and message of parts 0..parts-1 (tets with part id ==
/// parts form the kept group: no plan, no message).  A vertex is required
/// in a part when it is constrained in g or lies in two or more groups (kept
/// group included).  shared_out (nv of g) gets 1 on the vertices that lie in
/// two or more of the parts 0..parts-1 (the interface of this round).
void build_parts(const tetopt::TetMesh& g, const std::vector<int32_t>& part, int parts,
                 std::vector<PartPlan>& plans, std::vector<std::string>& messages,
                 std::vector<uint8_t>& shared_out);

/// Decodes a part message into a mesh with topology built.
tetopt::Status decode_part(const std::string& msg, tetopt::TetMesh& m);

/// A worker's answer: status, the improve report's numbers, and the improved part.
std::string encode_result(const tetopt::Status& s, const tetopt::ImproveReport& rep, double seconds,
                          const tetopt::TetMesh& m);
struct PartResult {
  int code = 0;
  std::string message;
  double seconds = 0;  ///< improve wall time on the worker
  tetopt::ImproveReport rep;  ///< counts and seconds (stats not carried)
  std::vector<double> xyz;
  std::vector<int32_t> tets, tet_ref, tet_entity;
};
bool decode_result(const std::string& msg, PartResult& r);


/// Replaces g's tets by the kept ones (part id == plans.size(), unchanged,
/// first) and the parts' (in part order), and moves/appends vertices; checks
/// that every vertex listed required in a part kept its bits.  Rebuilds g's
/// topology with `threads` threads (0 = all cores; the result is the same
/// for every count).
tetopt::Status merge_parts(tetopt::TetMesh& g, const std::vector<int32_t>& part, const std::vector<PartPlan>& plans,
                           std::vector<PartResult>& results, int threads = 1);

/// Sets flags[v] = 1 (flags has g.nv() entries) for the four vertices of
/// every tet t of g with pred(t), over fixed blocks of tets on `threads`
/// threads (0 = all cores).  Several threads may store the same 1 into one
/// flag (std::atomic_ref, relaxed), so the flags are the serial ones for
/// every count.
template <class Pred>
void mark_tet_vertices(const tetopt::TetMesh& g, std::vector<uint8_t>& flags, int threads, const Pred& pred);

/// Marks, in a vector of g.nv() flags (seed is padded with zeros to g.nv()), the vertices of every tet that has a
/// vertex flagged in `seed` (one layer of tets around it); in parallel, the same flags for every thread count.
std::vector<uint8_t> dilate(const tetopt::TetMesh& g, std::vector<uint8_t> seed, int threads = 1);

/// Tets of g with a vertex flagged in `flags` (counted in parallel blocks).
int64_t count_touching(const tetopt::TetMesh& g, std::vector<uint8_t> flags, int threads = 1);

template <class Pred>
void mark_tet_vertices(const tetopt::TetMesh& g, std::vector<uint8_t>& flags, int threads, const Pred& pred) {
  tetopt::detail::parallel_for_each(g.nt(), threads, [&](int64_t ti) {
    const auto t = static_cast<int32_t>(ti);
    if (!pred(t)) return;
    const int32_t* v = g.tet(t);
    for (int k = 0; k < 4; ++k) std::atomic_ref<uint8_t>(flags[v[k]]).store(1, std::memory_order_relaxed);
  });
}

}  // namespace tetopt_mpi
