// tetopt-mpi: partitioning, parts, merging (see distribute.hpp).
#include "distribute.hpp"

#include <metis.h>

#include <algorithm>

#include "tetopt/conventions.hpp"
#include "tetopt/quality.hpp"

namespace tetopt_mpi {

using namespace tetopt;

std::vector<int32_t> partition_tets(const TetMesh& g, const PartitionOptions& opt, std::string& err) {
  const int32_t ntg = g.nt();
  const bool all = !opt.active || opt.active->size() != static_cast<size_t>(ntg);
  // Inactive tets go to group `parts` (kept by rank 0, not improved).
  std::vector<int32_t> part(static_cast<size_t>(ntg), opt.parts);
  std::vector<int32_t> id(static_cast<size_t>(ntg), -1), tet_of;  // compact numbering of the active tets
  for (int32_t t = 0; t < ntg; ++t)
    if (all || (*opt.active)[t]) { id[t] = static_cast<int32_t>(tet_of.size()); tet_of.push_back(t); }
  const int32_t nt = static_cast<int32_t>(tet_of.size());
  if (opt.parts <= 1) {
    for (int32_t t : tet_of) part[t] = 0;
    return part;
  }
  if (nt < opt.parts) {
    err = "fewer tets (" + std::to_string(nt) + ") than parts (" + std::to_string(opt.parts) + ")";
    return {};
  }
  // Dual graph of the active tets: one vertex per tet, one edge per interior face.
  std::vector<idx_t> xadj(static_cast<size_t>(nt) + 1, 0), adjncy, adjwgt, vwgt(static_cast<size_t>(nt));
  adjncy.reserve(4 * static_cast<size_t>(nt));
  adjwgt.reserve(4 * static_cast<size_t>(nt));
  const std::vector<uint8_t>* avoid = opt.avoid && opt.avoid->size() == static_cast<size_t>(g.nv()) ? opt.avoid : nullptr;
  const bool have_alpha = opt.alpha && opt.alpha->size() == static_cast<size_t>(ntg);
  for (int32_t i = 0; i < nt; ++i) {
    const int32_t t = tet_of[i];
    const int32_t* tv = g.tet(t);
    for (int f = 0; f < 4; ++f) {
      const int32_t a = g.adj[4 * static_cast<size_t>(t) + f];
      if (a < 0 || id[a >> 2] < 0) continue;
      // Every face costs the same to cut: a cut that follows a region
      // interface (whose faces are frozen anyway) looks free but wanders one
      // layer off it and freezes the tets next to the interface, which then
      // stay poor (tried: worst alpha 8-14% lower on generated two-region
      // boxes).  Cutting near the previous interface would freeze the same
      // tets again, and cutting next to the worst tets would freeze them.
      idx_t w = 4;
      if (avoid) {
        uint8_t level = 0;
        for (int k = 0; k < 3; ++k) level = std::max(level, (*avoid)[tv[kFaceVertex[f][k]]]);
        if (level >= 2) w = 400;       // around the worst tets
        else if (level == 1) w = 100;  // around the previous interface
      }
      adjncy.push_back(id[a >> 2]);
      adjwgt.push_back(w);
    }
    xadj[i + 1] = static_cast<idx_t>(adjncy.size());
    // Work balance: poor tets cost the optimiser more than good ones.
    vwgt[i] = (have_alpha ? (*opt.alpha)[t] : tet_alpha(g, t)) < opt.threshold ? 4 : 1;
  }
  idx_t nvtxs = nt, ncon = 1, nparts = opt.parts, objval = 0;
  idx_t options[METIS_NOPTIONS];
  METIS_SetDefaultOptions(options);
  options[METIS_OPTION_SEED] = opt.seed;
  options[METIS_OPTION_NUMBERING] = 0;
  std::vector<idx_t> out(static_cast<size_t>(nt));
  const int rc = METIS_PartGraphKway(&nvtxs, &ncon, xadj.data(), adjncy.data(), vwgt.data(), nullptr, adjwgt.data(),
                                     &nparts, nullptr, nullptr, options, &objval, out.data());
  if (rc != METIS_OK) {
    err = "METIS_PartGraphKway failed (code " + std::to_string(rc) + ")";
    return {};
  }
  for (int32_t i = 0; i < nt; ++i) part[tet_of[i]] = static_cast<int32_t>(out[i]);
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
  if (Status s = check_arrays(m, "part"); !s) return s;
  return build_topology(m);
}

std::string encode_result(const Status& s, const ImproveReport& rep, double seconds, const TetMesh& m) {
  Writer w;
  w.put<int32_t>(static_cast<int32_t>(s.code));
  w.put_vec(std::vector<char>(s.message.begin(), s.message.end()));
  w.put<double>(seconds);
  const int64_t counts[] = {rep.smooth_moves, rep.smooth_tried, rep.flip23, rep.flip32, rep.edge_removals,
                            rep.multi_face_removals, rep.flip22, rep.flip44, rep.all_boundary_removed,
                            rep.insertions, rep.untangled, rep.still_inverted, rep.vertex_moves, rep.rounds};
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
                       &out.rep.still_inverted, &out.rep.vertex_moves};
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

std::vector<uint8_t> dilate(const TetMesh& g, std::vector<uint8_t> seed) {
  seed.resize(static_cast<size_t>(g.nv()), 0);
  std::vector<uint8_t> out = seed;
  for (int32_t t = 0; t < g.nt(); ++t) {
    const int32_t* v = g.tet(t);
    if (seed[v[0]] || seed[v[1]] || seed[v[2]] || seed[v[3]])
      for (int k = 0; k < 4; ++k) out[v[k]] = 1;
  }
  return out;
}

int64_t count_touching(const TetMesh& g, std::vector<uint8_t> flags) {
  flags.resize(static_cast<size_t>(g.nv()), 0);
  int64_t n = 0;
  for (int32_t t = 0; t < g.nt(); ++t) {
    const int32_t* v = g.tet(t);
    if (flags[v[0]] || flags[v[1]] || flags[v[2]] || flags[v[3]]) ++n;
  }
  return n;
}

}  // namespace tetopt_mpi
