// Shared parser of the improve options (see improve_args.hpp).
#include "improve_args.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>

#include "cli.hpp"

namespace tetopt_cli {

using namespace tetopt;

namespace {

bool to_double(const std::string& v, double& out) {
  char* end = nullptr;
  out = std::strtod(v.c_str(), &end);
  return !v.empty() && *end == '\0' && std::isfinite(out);
}

bool to_int(const std::string& v, long long& out) {
  char* end = nullptr;
  errno = 0;
  out = std::strtoll(v.c_str(), &end, 10);
  return !v.empty() && *end == '\0' && errno != ERANGE;  // 1e20 is not LLONG_MAX
}

}  // namespace

std::vector<std::string> split_equals(const std::vector<std::string>& args) {
  std::vector<std::string> out;
  out.reserve(args.size());
  for (const std::string& a : args) {
    const size_t eq = a.find('=');
    if (a.size() > 2 && a.compare(0, 2, "--") == 0 && eq != std::string::npos && eq > 2) {
      out.push_back(a.substr(0, eq));
      out.push_back(a.substr(eq + 1));
    } else {
      out.push_back(a);
    }
  }
  return out;
}

bool parse_whole(const std::string& name, const std::string& s, int64_t lo, int64_t hi, int64_t& out,
                 std::string& err) {
  double d = 0;
  if (!to_double(s, d)) {
    err = name + ": not a number: '" + s + "'";
    return false;
  }
  if (d != std::floor(d) || d < static_cast<double>(lo) || d > static_cast<double>(hi)) {
    err = name + " must be a whole number in " + std::to_string(lo) + ".." + std::to_string(hi);
    return false;
  }
  out = static_cast<int64_t>(d);
  return true;
}

bool worth_sorting(const tetopt::TetMesh& m, const tetopt::OrientationReport& orient, int64_t reorder_above,
                   int threads) {
  return reorder_above >= 0 && m.nt() >= reorder_above && orient.inverted.empty() && orient.flat_tets.empty() &&
         tetopt::tet_order_spread(m, threads) > kSortSpread;
}

tetopt::Status load_for_improve(const std::string& path, tetopt::TetMesh& m, tetopt::OrientationReport& orient,
                                int threads, int64_t reorder_above, std::vector<int32_t>* order,
                                const MeshReader& read, const std::function<void()>& on_read) {
  using tetopt::Status;
  if (order) order->clear();
  orient = tetopt::OrientationReport{};
  Status s = read(path, m, &orient, threads);
  if (!s) return s;  // the reader's messages name the file already
  if (on_read) on_read();
  s = tetopt::check_measurable(m, "", threads);
  const bool sort = s && order && worth_sorting(m, orient, reorder_above, threads);
  if (sort) tetopt::sort_tets_spatially(m, threads, order);
  if (s) s = tetopt::build_topology(m, threads);
  if (s) s = tetopt::orient_consistently(m, false, &orient, threads);
  if (!s && sort) {
    // Only on this error path: IN again, in its own order.
    order->clear();
    m = tetopt::TetMesh{};
    orient = tetopt::OrientationReport{};
    s = read(path, m, &orient, threads);
    if (!s) return s;
    s = tetopt::build_topology(m, threads);
    if (s) s = tetopt::orient_consistently(m, false, &orient, threads);
  }
  if (!s) s.message = shown(path) + ": " + s.message;
  return s;
}

ImproveArgsResult parse_improve_args(const std::vector<std::string>& args, const ImproveArgsNames& names,
                                     const std::vector<ExtraOption>& extra, ImproveArgs& a, std::string& err) {
  using R = ImproveArgsResult;
  const std::string cmd = names.command + ": ";
  bool options_end = false;  // after "--": file names only (one may start with '-')
  // The value each option took: one given twice with two values is an error
  // (the last one silently won: "-o a.mesh -o b.vtu" wrote only b.vtu).
  std::map<std::string, std::string> given;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& o = args[i];
    if (!options_end && o == "--") {
      options_end = true;
      continue;
    }
    if (options_end) {
      if (a.in.empty()) a.in = o;
      else {
        err = cmd + "unexpected argument '" + o + "' (after --, only IN; give -o before --)";
        return R::Error;
      }
      continue;
    }
    std::string v;
    auto value = [&] {
      if (i + 1 >= args.size()) {
        err = cmd + o + " needs a value";
        return false;
      }
      v = args[++i];
      const std::string key = o == "-o" ? "--output" : o;
      if (const auto it = given.find(key); it != given.end() && it->second != v) {
        err = cmd + o + " given twice ('" + it->second + "', then '" + v + "')";
        return false;
      }
      given[key] = v;
      return true;
    };
    auto number = [&](double& d) {
      if (!value()) return false;
      if (to_double(v, d)) return true;
      err = names.tool + ": " + o + " expects a number, got '" + v + "'";
      return false;
    };
    auto integer = [&](long long& n) {
      if (!value()) return false;
      if (to_int(v, n)) return true;
      err = names.tool + ": " + o + " expects an integer, got '" + v + "'";
      return false;
    };
    auto bad = [&](const std::string& msg) {
      err = cmd + msg;
      return R::Error;
    };
    double d = 0;
    long long n = 0;
    if (o == "-h" || o == "--help") return R::Help;
    else if (o == "-o" || o == "--output") { if (!value()) return R::Error; a.out = v; }
    else if (o == "--report") { if (!value()) return R::Error; a.report = v; }
    else if (o == "-q" || o == "--quiet") a.quiet = true;
    else if (o == "-v" || o == "--verbose") a.verbose = true;
    else if (o == "--binary") a.wo.binary = true;
    else if (o == "--no-check") a.opt.check_invariants = false;
    else if (o == "--keep-order") a.keep_order = true;
    else if (o == "--write-boundary") a.write_boundary = true;
    else if (o == "--allow-insert") a.opt.allow_insert = true;
    else if (o == "--allow-remove") a.opt.allow_remove = true;
    else if (o == "--no-guard") a.opt.guard = false;
    else if (o == "--polish") a.opt.polish = true;
    else if (o == "--objective") {
      if (!value()) return R::Error;
      if (!parse_objective(v.c_str(), a.opt.objective))
        return bad("--objective is alpha, sine, jacobian, skewness or openfoam, not '" + v + "'");
    }
    else if (o == "--mode") {
      if (!value()) return R::Error;
      if (v == "smooth") a.opt.mode = ImproveMode::Smooth;
      else if (v == "topo") a.opt.mode = ImproveMode::Topo;
      else if (v == "combined") a.opt.mode = ImproveMode::Combined;
      else if (v == "best") a.opt.mode = ImproveMode::Best;
      else return bad("--mode is smooth, topo, combined or best, not '" + v + "'");
    } else if (o == "--optimizer") {
      if (!value()) return R::Error;
      if (v == "paper") a.opt.maxmin_optimizer = false;
      else if (v == "maxmin") a.opt.maxmin_optimizer = true;
      else return bad("--optimizer is paper or maxmin, not '" + v + "'");
    } else if (o == "--weight") {
      if (!number(d)) return R::Error;
      if (d < 0.5 || d >= 1) return bad("--weight must satisfy 0.5 <= C < 1");
      a.opt.weight = d;
    } else if (o == "--size") {
      if (!number(d)) return R::Error;
      if (!(d > 0) || !std::isfinite(d)) return bad("--size must be a positive length");
      a.opt.size = d;
    } else if (o == "--gradation") {
      if (!number(d)) return R::Error;
      if (!(d > 1) || !std::isfinite(d)) return bad("--gradation must be a ratio above 1 (MMG's -hgrad; default 1.16)");
      a.opt.gradation = d;
    } else if (o == "--no-remesh") {
      a.opt.remesh = false;
    } else if (o == "--threshold") {
      if (!number(d)) return R::Error;
      if (d <= 0 || d > 1) return bad("--threshold must be in (0, 1]");
      a.opt.threshold = d;
    } else if (o == "--reorder-above") {
      if (!integer(n)) return R::Error;
      if (n < 0) return bad("--reorder-above must be a whole number from 0 on");
      a.reorder_above = n;
    } else if (o == "--iterations") {
      if (!integer(n)) return R::Error;
      // At least one round: 0 ran one anyway (the report said rounds 1).
      if (n < 1 || n > 1000000) return bad("--iterations must be in 1..1000000");
      a.opt.iterations = static_cast<int>(n);
    } else if (o == "--seed") {
      if (!integer(n)) return R::Error;
      if (n < 0) return bad("--seed must be a whole number from 0 on");
      a.opt.seed = static_cast<uint64_t>(n);
    } else if (o == "--threads") {
      if (!integer(n)) return R::Error;
      if (n < 0 || n > 1024) return bad("--threads must be in 0..1024");
      a.opt.threads = static_cast<int>(n);
    } else if (o == "--msh-version") {
      if (i + 1 < args.size() && args[i + 1] == "fluent") {  // a Fluent mesh (issue 28)
        ++i;
        a.wo.msh = tetopt::WriteOptions::Msh::Fluent;
      } else {
        if (!integer(n)) return R::Error;
        if (n != 22 && n != 41) return bad("--msh-version is 22, 41 or fluent");
        a.wo.msh_version = static_cast<int>(n);
        a.wo.msh = tetopt::WriteOptions::Msh::Gmsh;
      }
    } else if (o == "--meshb-version") {
      if (!integer(n)) return R::Error;
      if (n < 2 || n > 4) return bad("--meshb-version is 2, 3 or 4");
      a.wo.meditb_version = static_cast<int>(n);
    } else if (!o.empty() && o[0] == '-') {
      const ExtraOption* x = nullptr;
      for (const ExtraOption& e : extra)
        for (const std::string& name : e.names)
          if (name == o) x = &e;
      if (!x) {
        // One line, not the whole help under it, where the mistake would
        // scroll away.
        err = cmd + "unknown option '" + o + "' (--help lists the options)";
        return R::Error;
      }
      if (x->takes_value && !value()) return R::Error;
      std::string msg;
      if (!x->apply(v, msg)) return bad(msg);
    } else if (a.in.empty()) a.in = o;
    else return bad("unexpected argument '" + o + "'");
  }
  if (a.in.empty() || a.out.empty()) {
    err = cmd + (a.in.empty() ? "no input mesh" : "no output (-o OUT)");
    return R::ErrorWithHelp;
  }
  if ((a.opt.allow_insert || a.opt.allow_remove) && a.opt.mode != ImproveMode::Best) {
    err = cmd;
    err += a.opt.allow_insert ? "--allow-insert" : "--allow-remove";
    err += " works in --mode best only (the default), not in --mode ";
    err += mode_name(a.opt.mode);
    return R::Error;
  }
  // The remesher's options do nothing without it: said, not ignored.
  if ((a.opt.size > 0 || a.opt.gradation > 0) && !(a.opt.allow_insert && a.opt.remesh)) {
    err = cmd + (a.opt.size > 0 ? "--size" : "--gradation");
    err += a.opt.allow_insert ? " sets the interior remesher, which --no-remesh turns off"
                              : " sets the interior remesher: add --allow-insert (and --allow-remove)";
    return R::Error;
  }
  if (format_from_path(a.out) == Format::Unknown) {
    err = cmd + a.out + ": unknown output extension";
    return R::Error;
  }
  return R::Ok;
}

std::vector<std::string> warn_dropped(const std::string& out, const tetopt::TetMesh& m, const tetopt::WriteOptions& wo,
                                      bool quiet) {
  std::vector<std::string> lost = tetopt::dropped_by_format(m, tetopt::format_from_path(out), wo);
  if (!lost.empty() && !quiet) {
    std::string list;
    for (size_t i = 0; i < lost.size(); ++i) list += (i ? (i + 1 == lost.size() ? " and " : ", ") : "") + lost[i];
    std::fprintf(stderr,
                 "warning: %s: this format cannot hold the input's %s: left out, or changed where said "
                 "(docs/formats.md, \"What is kept\")\n",
                 shown(out).c_str(), list.c_str());
  }
  return lost;
}

}  // namespace tetopt_cli
