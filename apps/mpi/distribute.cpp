// tetopt-mpi: partitioning, parts, merging (see distribute.hpp).
#include "distribute.hpp"

#include <metis.h>

#include <algorithm>

#include "tetopt/conventions.hpp"
#include "tetopt/quality.hpp"
#include "detail/parallel.hpp"

namespace tetopt_mpi {

using namespace tetopt;

namespace {
// Rounds with more active tets than this weigh tets with a constrained vertex
// more (see partition_tets).
constexpr int32_t kBalanceBoundaryAbove = 100000;
}  // namespace

std::vector<int32_t> partition_tets(const TetMesh& g, const PartitionOptions& opt, std::string& err, bool* contracted) {
  const int32_t ntg = g.nt();
  const bool all = !opt.active || opt.active->size() != static_cast<size_t>(ntg);
  // Inactive tets go to group `parts` (kept by rank 0, not improved).
  std::vector<int32_t> part(static_cast<size_t>(ntg), opt.parts);
  if (contracted) *contracted = false;
  std::vector<int32_t> tet_of;  // the active tets, in order
  for (int32_t t = 0; t < ntg; ++t)
    if (all || (*opt.active)[t]) tet_of.push_back(t);
  const int32_t nt = static_cast<int32_t>(tet_of.size());
  // One part, or too few tets to give every part one: part 0 takes them all
  // and the other parts are empty (their ranks return at once).
  if (opt.parts <= 1 || nt < opt.parts) {
    for (int32_t t : tet_of) part[t] = 0;
    return part;
  }
  // The dual graph of the active tets: one graph vertex per tet, one edge per
  // interior face.  Above opt.contract_above active tets it is contracted
  // once before METIS sees it: the tets whose smallest vertex is v form
  // group v, the groups are the graph vertices (weight: the sum of their
  // tets'), joined with the summed weights of the faces between them.  METIS
  // coarsens by contracting matched graph vertices anyway; this first step
  // has about 5.6 times fewer vertices and is built in parallel, and METIS's
  // time falls with it (flange_large, 2.0M tets: 2.4-3.1 s on the dual
  // graph, 0.3-0.6 s with the graph build on the grouped one).  A cut between
  // groups is a cut between tets, so the weights mean what they did, but the
  // cut is more ragged: on the 12,288-tet test box it left the worst alpha 7%
  // lower in half the seeds, so small graphs (cheap anyway) stay exact.
  const std::vector<uint8_t>* avoid = opt.avoid && opt.avoid->size() == static_cast<size_t>(g.nv()) ? opt.avoid : nullptr;
  const bool have_alpha = opt.alpha && opt.alpha->size() == static_cast<size_t>(ntg);
  const bool contract = nt > opt.contract_above;
  const bool balance_boundary = nt > kBalanceBoundaryAbove;
  if (contracted) *contracted = contract;
  // Per active tet its group key (its smallest vertex, or itself), and its
  // work weight in one byte (0: not active).
  std::vector<int32_t> key(static_cast<size_t>(ntg), -1);
  std::vector<uint8_t> wt(static_cast<size_t>(ntg), 0);
  tetopt::detail::parallel_for_each(nt, opt.threads, [&](int64_t j) {
    const int32_t t = tet_of[static_cast<size_t>(j)];
    const int32_t* tv = g.tet(t);
    key[t] = contract ? std::min(std::min(tv[0], tv[1]), std::min(tv[2], tv[3])) : t;
    // Work weight: 1, plus 3 below the threshold, plus 1 with a constrained
    // vertex.  Without the last term, METIS's halves of flange_large (2.0M
    // tets, 2 ranks) held 188k and 239k tets with a constrained vertex, and
    // their round-1 improve took 4.2-5.0 s against 6.1-6.7 s (3 runs); with
    // it, 4.3-4.6 s against 4.3-4.7 s (3 runs), the same total work.  (A
    // per-tet cost fitted to those counts explains only part of the gap:
    // the poor tets near the boundary are the ones improve() retries.)
    // Only rounds with more than kBalanceBoundaryAbove active tets use the
    // term, where a part costs seconds: on small meshes it saves
    // milliseconds, and any change of the cut moves the worst alpha between
    // the plateaus the optimiser ends on (the 12,288-tet test box at 4
    // ranks: 0.4886 without the term, 0.4275 with it, 0.5087 with a term of
    // 2; `tetopt improve` run again on the 0.4275 result stays there, so it
    // is a different local optimum, not a frozen tet).
    const double a = have_alpha ? (*opt.alpha)[t] : tet_alpha(g, t);
    wt[t] = static_cast<uint8_t>((a < opt.threshold ? 4 : 1) + (balance_boundary && g.tet_kind[t] > 0 ? 1 : 0));
  });
  // Graph vertex of each key, keys in increasing order.
  std::vector<int32_t> gid(static_cast<size_t>(contract ? g.nv() : ntg), -1), group_key;
  for (int32_t t : tet_of) gid[key[t]] = 0;
  for (size_t k = 0; k < gid.size(); ++k)
    if (gid[k] == 0) { gid[k] = static_cast<int32_t>(group_key.size()); group_key.push_back(static_cast<int32_t>(k)); }
  const auto ng = static_cast<int32_t>(group_key.size());
  if (ng < opt.parts) {  // as above
    for (int32_t t : tet_of) part[t] = 0;
    return part;
  }
  // The tets of group i: those of vertex v's star whose key is v, or the tet.
  auto for_members = [&](int32_t i, const auto& fn) {
    const int32_t k = group_key[static_cast<size_t>(i)];
    if (!contract) { fn(k); return; }
    for (const int32_t* it = g.star_begin(k); it != g.star_end(k); ++it)
      if (key[*it] == k) fn(*it);
  };
  // Every face costs the same to cut: a cut that follows a region interface
  // (whose faces are frozen anyway) looks free but wanders one layer off it
  // and freezes the tets next to the interface, which then stay poor (tried:
  // worst alpha 8-14% lower on generated two-region boxes).  Cutting near the
  // previous interface would freeze the same tets again, and cutting next to
  // the worst tets would freeze them.
  auto face_weight = [&](const int32_t* tv, int f) -> idx_t {
    uint8_t level = 0;
    if (avoid)
      for (int k = 0; k < 3; ++k) level = std::max(level, (*avoid)[tv[kFaceVertex[f][k]]]);
    return level >= 2 ? 400 : level == 1 ? 100 : 4;  // around the worst tets / the previous interface
  };
  struct Block {
    std::vector<idx_t> deg, adj, wgt, vw;
  };
  // Groups in parallel blocks, joined in block order: the same graph for
  // every thread count.  A group's neighbours are listed in the order they
  // are met (star order, then face order).
  const auto blocks = tetopt::detail::parallel_map_blocks(ng, opt.threads, [&](int64_t b, int64_t e) {
    Block out;
    thread_local std::vector<int32_t> slot;  // per group: its index in this group's list, or -1
    if (slot.size() < static_cast<size_t>(ng)) slot.assign(static_cast<size_t>(ng), -1);
    for (int64_t i = b; i < e; ++i) {
      const int32_t k = group_key[static_cast<size_t>(i)];
      const size_t begin = out.adj.size();
      idx_t w = 0;
      for_members(static_cast<int32_t>(i), [&](int32_t t) {
        w += wt[t];
        const int32_t* tv = g.tet(t);
        for (int f = 0; f < 4; ++f) {
          const int32_t a = g.adj[4 * static_cast<size_t>(t) + f];
          if (a < 0 || !wt[a >> 2]) continue;
          if (key[a >> 2] == k) continue;  // inside the group
          const int32_t h = gid[key[a >> 2]];
          if (slot[h] < 0) {
            slot[h] = static_cast<int32_t>(out.adj.size() - begin);
            out.adj.push_back(h);
            out.wgt.push_back(0);
          }
          out.wgt[begin + static_cast<size_t>(slot[h])] += face_weight(tv, f);
        }
      });
      for (size_t j = begin; j < out.adj.size(); ++j) slot[static_cast<size_t>(out.adj[j])] = -1;
      out.deg.push_back(static_cast<idx_t>(out.adj.size() - begin));
      out.vw.push_back(w);
    }
    return out;
  });
  std::vector<idx_t> xadj(static_cast<size_t>(ng) + 1, 0), adjncy, adjwgt, vwgt;
  vwgt.reserve(static_cast<size_t>(ng));
  size_t gi = 0;
  for (const Block& bl : blocks) {
    for (idx_t d : bl.deg) { xadj[gi + 1] = xadj[gi] + d; ++gi; }
    adjncy.insert(adjncy.end(), bl.adj.begin(), bl.adj.end());
    adjwgt.insert(adjwgt.end(), bl.wgt.begin(), bl.wgt.end());
    vwgt.insert(vwgt.end(), bl.vw.begin(), bl.vw.end());
  }
  idx_t nvtxs = ng, ncon = 1, nparts = opt.parts, objval = 0;
  idx_t options[METIS_NOPTIONS];
  METIS_SetDefaultOptions(options);
  options[METIS_OPTION_SEED] = opt.seed;
  options[METIS_OPTION_NUMBERING] = 0;
  std::vector<idx_t> out(static_cast<size_t>(ng));
  const int rc = METIS_PartGraphKway(&nvtxs, &ncon, xadj.data(), adjncy.data(), vwgt.data(), nullptr, adjwgt.data(),
                                     &nparts, nullptr, nullptr, options, &objval, out.data());
  if (rc != METIS_OK) {
    err = "METIS_PartGraphKway failed (code " + std::to_string(rc) + ")";
    return {};
  }
  tetopt::detail::parallel_for_each(nt, opt.threads, [&](int64_t j) {
    const int32_t t = tet_of[static_cast<size_t>(j)];
    part[t] = static_cast<int32_t>(out[static_cast<size_t>(gid[key[t]])]);
  });
  return part;
}

int64_t pull_in(const TetMesh& g, std::vector<int32_t>& part, int32_t kept_id, const std::vector<int32_t>& seeds) {
  std::vector<uint8_t> locked(static_cast<size_t>(g.nt()), 0);
  std::vector<int32_t> ring, ring2;
  int64_t moved = 0;
  for (int32_t s : seeds) {
    const int32_t p = part[s];
    if (p == kept_id || locked[s]) continue;
    ring.clear();
    ring2.clear();
    for (int k = 0; k < 4; ++k)
      for (const int32_t* it = g.star_begin(g.tet(s)[k]); it != g.star_end(g.tet(s)[k]); ++it) ring.push_back(*it);
    std::sort(ring.begin(), ring.end());
    ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
    for (int32_t t : ring)
      for (int k = 0; k < 4; ++k)
        for (const int32_t* it = g.star_begin(g.tet(t)[k]); it != g.star_end(g.tet(t)[k]); ++it) ring2.push_back(*it);
    std::sort(ring2.begin(), ring2.end());
    ring2.erase(std::unique(ring2.begin(), ring2.end()), ring2.end());
    for (int32_t t : ring2) {  // ring2 contains ring
      if (locked[t] || part[t] == kept_id) continue;
      if (part[t] != p) { part[t] = p; ++moved; }
      locked[t] = 1;
    }
  }
  return moved;
}

void build_parts(const TetMesh& g, const std::vector<int32_t>& part, int parts, std::vector<PartPlan>& plans,
                 std::vector<std::string>& messages, std::vector<uint8_t>& shared_out) {
  const int32_t nv = g.nv(), nt = g.nt();
  // first: the first group a vertex was seen in (any group); first_active:
  // the same over the groups below `parts` only.
  std::vector<int32_t> first(static_cast<size_t>(nv), -1), first_active(static_cast<size_t>(nv), -1);
  std::vector<uint8_t> frozen(static_cast<size_t>(nv), 0);
  shared_out.assign(static_cast<size_t>(nv), 0);
  std::vector<std::vector<int32_t>> tets_of(static_cast<size_t>(parts) + 1);
  for (int32_t t = 0; t < nt; ++t) {
    const int32_t p = part[t];
    tets_of[p].push_back(t);
    for (int k = 0; k < 4; ++k) {
      const int32_t v = g.tet(t)[k];
      if (first[v] < 0) first[v] = p;
      else if (first[v] != p) frozen[v] = 1;
      if (p < parts) {
        if (first_active[v] < 0) first_active[v] = p;
        else if (first_active[v] != p) shared_out[v] = 1;
      }
    }
  }
  const bool has_entity = !g.tet_entity.empty();
  plans.assign(static_cast<size_t>(parts), PartPlan{});
  messages.assign(static_cast<size_t>(parts), std::string{});
  std::vector<int32_t> loc(static_cast<size_t>(nv), -1);
  for (int p = 0; p < parts; ++p) {
    PartPlan& plan = plans[p];
    const std::vector<int32_t>& ts = tets_of[p];
    plan.tets = static_cast<int64_t>(ts.size());
    std::vector<int32_t> tl;
    tl.reserve(4 * ts.size());
    std::vector<int32_t> ref, ent;
    ref.reserve(ts.size());
    for (int32_t t : ts) {
      for (int k = 0; k < 4; ++k) {
        const int32_t v = g.tet(t)[k];
        if (loc[v] < 0) {
          loc[v] = static_cast<int32_t>(plan.gids.size());
          plan.gids.push_back(v);
        }
        tl.push_back(loc[v]);
      }
      ref.push_back(g.tet_ref[t]);
      if (has_entity) ent.push_back(g.tet_entity[t]);
    }
    const size_t n = plan.gids.size();
    std::vector<double> xyz(3 * n);
    std::vector<int32_t> required;
    plan.fixed.assign(n, 0);
    for (size_t i = 0; i < n; ++i) {
      const int32_t v = plan.gids[i];
      std::copy(g.point(v), g.point(v) + 3, &xyz[3 * i]);
      if (g.vert_constrained[v] || frozen[v]) {
        plan.fixed[i] = 1;
        required.push_back(static_cast<int32_t>(i));
      }
      if (shared_out[v]) ++plan.interface_vertices;
    }
    // Every face constrained in the global mesh, once per part.
    std::vector<int32_t> tris;
    for (int32_t t : ts) {
      for (int f = 0; f < 4; ++f) {
        if (!((g.face_mask[t] >> f) & 1)) continue;
        const int32_t a = g.adj[4 * static_cast<size_t>(t) + f];
        if (a >= 0 && part[a >> 2] == p && (a >> 2) < t) continue;
        for (int k = 0; k < 3; ++k) tris.push_back(loc[g.tet(t)[kFaceVertex[f][k]]]);
      }
    }
    std::vector<int32_t> edges;
    for (size_t i = 0; i + 1 < g.edges.size(); i += 2) {
      const int32_t a = loc[g.edges[i]], b = loc[g.edges[i + 1]];
      if (a >= 0 && b >= 0) { edges.push_back(a); edges.push_back(b); }
    }
    Writer w;
    w.put_vec(xyz);
    w.put_vec(tl);
    w.put_vec(ref);
    w.put_vec(ent);
    w.put_vec(required);
    w.put_vec(tris);
    w.put_vec(edges);
    messages[p] = std::move(w.buf);
    for (int32_t v : plan.gids) loc[v] = -1;
  }
}

Status decode_part(const std::string& msg, TetMesh& m) {
  Reader r(msg);
  m = TetMesh{};
  m.xyz = r.get_vec<double>();
  m.tets = r.get_vec<int32_t>();
  m.tet_ref = r.get_vec<int32_t>();
  m.tet_entity = r.get_vec<int32_t>();
  m.required_vertices = r.get_vec<int32_t>();
  m.tris = r.get_vec<int32_t>();
  m.edges = r.get_vec<int32_t>();
  if (!r.ok) return Status::error(ErrorCode::InvalidMesh, "truncated part message");
  m.vert_ref.assign(static_cast<size_t>(m.nv()), 0);
  m.tri_ref.assign(m.tris.size() / 3, 0);
  m.edge_ref.assign(m.edges.size() / 2, 0);
  // An empty part (METIS may leave one empty on a small mesh, and a mesh with
  // fewer tets than ranks has some): nothing to improve.
  if (m.tets.empty() && m.xyz.empty()) return Status::success();
  if (Status s = check_arrays(m, "part"); !s) return s;
  // A part's tets come in the global mesh's order, which may follow no
  // spatial order at all; ordering them along a Morton curve lets improve()
  // walk stars in cache (tet ids are private to the part, vertex ids stay).
  sort_tets_spatially(m);
  return build_topology(m);
}

std::string encode_result(const Status& s, const ImproveReport& rep, double seconds, const TetMesh& m) {
  Writer w;
  w.put<int32_t>(static_cast<int32_t>(s.code));
  w.put_vec(std::vector<char>(s.message.begin(), s.message.end()));
  w.put<double>(seconds);
  const int64_t counts[] = {rep.smooth_moves, rep.smooth_tried, rep.flip23, rep.flip32, rep.edge_removals,
                            rep.multi_face_removals, rep.flip22, rep.flip44, rep.all_boundary_removed,
                            rep.insertions, rep.untangled, rep.still_inverted, rep.vertex_moves, rep.pair_flips,
                            rep.rounds};
  for (int64_t c : counts) w.put<int64_t>(c);
  const double secs[] = {rep.seconds_total, rep.seconds_smooth, rep.seconds_topo, rep.seconds_check};
  for (double x : secs) w.put<double>(x);
  if (s.ok()) {
    w.put_vec(m.xyz);
    w.put_vec(m.tets);
    w.put_vec(m.tet_ref);
    w.put_vec(m.tet_entity);
  }
  return std::move(w.buf);
}

bool decode_result(const std::string& msg, PartResult& out) {
  Reader r(msg);
  out.code = r.get<int32_t>();
  std::vector<char> text = r.get_vec<char>();
  out.message.assign(text.begin(), text.end());
  out.seconds = r.get<double>();
  int64_t* counts[] = {&out.rep.smooth_moves, &out.rep.smooth_tried, &out.rep.flip23, &out.rep.flip32,
                       &out.rep.edge_removals, &out.rep.multi_face_removals, &out.rep.flip22, &out.rep.flip44,
                       &out.rep.all_boundary_removed, &out.rep.insertions, &out.rep.untangled,
                       &out.rep.still_inverted, &out.rep.vertex_moves, &out.rep.pair_flips};
  for (int64_t* c : counts) *c = r.get<int64_t>();
  out.rep.rounds = static_cast<int>(r.get<int64_t>());
  out.rep.seconds_total = r.get<double>();
  out.rep.seconds_smooth = r.get<double>();
  out.rep.seconds_topo = r.get<double>();
  out.rep.seconds_check = r.get<double>();
  if (out.code == 0) {
    out.xyz = r.get_vec<double>();
    out.tets = r.get_vec<int32_t>();
    out.tet_ref = r.get_vec<int32_t>();
    out.tet_entity = r.get_vec<int32_t>();
  }
  return r.ok;
}

Status merge_parts(TetMesh& g, const std::vector<int32_t>& part, const std::vector<PartPlan>& plans,
                   std::vector<PartResult>& results, int threads) {
  const bool has_entity = !g.tet_entity.empty();
  const bool has_vref = g.vert_ref.size() == static_cast<size_t>(g.nv());
  const int32_t kept_id = static_cast<int32_t>(plans.size());
  std::vector<int32_t> tets, ref, ent;
  size_t total = 0;
  for (const PartResult& r : results) total += r.tets.size();
  for (int32_t p : part) total += p == kept_id ? 4 : 0;
  tets.reserve(total);
  ref.reserve(total / 4);
  if (has_entity) ent.reserve(total / 4);
  // The kept tets first, unchanged (their vertices are required in every
  // part that shares them, so they do not move), with their topology: links
  // between kept tets renumbered, -1 where an improved tet was across
  // (refresh_topology then rebuilds only around the improved tets).
  std::vector<int32_t> newid(static_cast<size_t>(g.nt()), -1);
  int32_t nkept = 0;
  for (int32_t t = 0; t < g.nt(); ++t)
    if (part[t] == kept_id) newid[t] = nkept++;
  std::vector<int32_t> kadj(4 * static_cast<size_t>(nkept));
  std::vector<uint8_t> kmask(static_cast<size_t>(nkept)), kkind(static_cast<size_t>(nkept));
  for (int32_t t = 0; t < g.nt(); ++t) {
    if (part[t] != kept_id) continue;
    const int32_t k = newid[t];
    tets.insert(tets.end(), g.tet(t), g.tet(t) + 4);
    ref.push_back(g.tet_ref[t]);
    if (has_entity) ent.push_back(g.tet_entity[t]);
    for (int f = 0; f < 4; ++f) {
      const int32_t a = g.adj[4 * static_cast<size_t>(t) + f];
      kadj[4 * static_cast<size_t>(k) + f] = a >= 0 && newid[a >> 2] >= 0 ? 4 * newid[a >> 2] + (a & 3) : -1;
    }
    kmask[k] = g.face_mask[t];
    kkind[k] = g.tet_kind[t];
  }
  std::vector<int32_t> lg;
  for (size_t p = 0; p < plans.size(); ++p) {
    const PartPlan& plan = plans[p];
    PartResult& r = results[p];
    const size_t n0 = plan.gids.size(), n = r.xyz.size() / 3;
    if (n < n0 || r.tets.size() != 4 * r.tet_ref.size() || (has_entity && r.tet_entity.size() != r.tet_ref.size()))
      return Status::error(ErrorCode::Invariant, "part " + std::to_string(p) + ": inconsistent result arrays");
    lg.resize(n);
    for (size_t i = 0; i < n0; ++i) {
      const int32_t v = plan.gids[i];
      lg[i] = v;
      if (plan.fixed[i]) {
        if (std::memcmp(g.point(v), &r.xyz[3 * i], 3 * sizeof(double)) != 0)
          return Status::error(ErrorCode::Invariant, "part " + std::to_string(p) + " moved frozen vertex " +
                                                         std::to_string(v));
      } else {
        std::copy(&r.xyz[3 * i], &r.xyz[3 * i] + 3, g.point(v));
      }
    }
    for (size_t i = n0; i < n; ++i) {  // inserted vertices: appended, in part order
      lg[i] = g.nv();
      g.xyz.insert(g.xyz.end(), &r.xyz[3 * i], &r.xyz[3 * i] + 3);
      if (has_vref) g.vert_ref.push_back(0);
      for (auto& pf : g.point_fields) pf.values.insert(pf.values.end(), pf.components, 0.0);
    }
    for (int32_t v : r.tets) {
      if (v < 0 || static_cast<size_t>(v) >= n)
        return Status::error(ErrorCode::Invariant, "part " + std::to_string(p) + ": vertex id out of range");
      tets.push_back(lg[v]);
    }
    ref.insert(ref.end(), r.tet_ref.begin(), r.tet_ref.end());
    if (has_entity) ent.insert(ent.end(), r.tet_entity.begin(), r.tet_entity.end());
    r.xyz.clear(); r.xyz.shrink_to_fit();
    r.tets.clear(); r.tets.shrink_to_fit();
  }
  g.tets = std::move(tets);
  g.tet_ref = std::move(ref);
  if (has_entity) g.tet_entity = std::move(ent);
  if (nkept == 0) return build_topology(g, threads);
  g.adj = std::move(kadj);
  g.face_mask = std::move(kmask);
  g.tet_kind = std::move(kkind);
  return refresh_topology(g, nkept, threads);
}

std::vector<uint8_t> dilate(const TetMesh& g, std::vector<uint8_t> seed, int threads) {
  seed.resize(static_cast<size_t>(g.nv()), 0);
  std::vector<uint8_t> out = seed;
  mark_tet_vertices(g, out, threads, [&](int32_t t) {
    const int32_t* v = g.tet(t);
    return seed[v[0]] || seed[v[1]] || seed[v[2]] || seed[v[3]];
  });
  return out;
}

int64_t count_touching(const TetMesh& g, std::vector<uint8_t> flags, int threads) {
  flags.resize(static_cast<size_t>(g.nv()), 0);
  return detail::parallel_count(g.nt(), threads, [&](int64_t t) {
    const int32_t* v = g.tet(static_cast<int32_t>(t));
    return flags[v[0]] || flags[v[1]] || flags[v[2]] || flags[v[3]];
  });
}

}  // namespace tetopt_mpi
