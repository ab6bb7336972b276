// tetopt quality / convert, and the helpers every command shares.
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <new>
#include <stdexcept>

#include <sys/stat.h>

#include "cli.hpp"
#include "hugepages.hpp"
#include "improve_args.hpp"
#include "tetopt/diagnose.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/html_report.hpp"
#include "tetopt/io.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/report.hpp"

namespace tetopt_cli {

using namespace tetopt;

std::atomic<bool> g_interrupted{false};
void on_sigint(int) { g_interrupted = true; }

namespace {
// The input being read (its memory map is live), as messages show it, for
// on_sigbus (which may not allocate).
const char* volatile g_reading = nullptr;
void put_err(const char* s) {
  size_t n = 0;
  while (s[n]) ++n;
  while (n > 0) {
    const ssize_t w = ::write(2, s, n);
    if (w <= 0) return;
    s += w;
    n -= static_cast<size_t>(w);
  }
}
}  // namespace

// The readers parse a memory map of the input; when another program shrinks
// the file meanwhile, touching a page past its new end raises SIGBUS.  Then:
// one line naming the file and exit 2 (nothing was written yet), instead of
// a core dump.  Only async-signal-safe calls.  Any other SIGBUS keeps its
// default action.
void on_sigbus(int sig) {
  const char* path = g_reading;
  if (!path) {
    std::signal(sig, SIG_DFL);
    std::raise(sig);
    return;
  }
  put_err("tetopt: ");
  put_err(path);
  put_err(": the file shrank while it was read (bus error on its memory map); nothing written\n");
  ::_exit(kExitInput);
}

// SIGTERM and SIGHUP (every command), SIGINT (the commands other than
// improve, which stops gracefully on g_interrupted instead): the temporary
// files of a write in progress are removed, then the process ends as the
// signal's default action would (SIGINT: exit 130 with one line, as the
// help says).  Before, a SIGTERM while writing left OUT.tmp-PID-N behind and
// a Ctrl-C during convert, quality or generate was ignored (exit 0).
void on_terminating_signal(int sig) {
  remove_pending_temporaries();
  if (sig == SIGINT) {
    put_err("\ntetopt: interrupted\n");
    ::_exit(kExitInterrupted);
  }
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

namespace {
std::string g_last_input;  // also what g_reading points at while reading
}
const std::string& last_input() { return g_last_input; }

Status read_input(const std::string& path, TetMesh& m, OrientationReport* orient, int threads) {
  g_last_input = shown(path);
  g_reading = g_last_input.c_str();
  Status s = read_mesh(path, m, orient, threads);
  g_reading = nullptr;
  return s;
}

bool stderr_is_tty() { return ::isatty(2) == 1; }

bool parse_double(const std::string& opt, const std::string& v, double& out) {
  char* end = nullptr;
  out = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0' || !std::isfinite(out)) {
    std::fprintf(stderr, "tetopt: %s expects a number, got '%s'\n", shown(opt).c_str(), shown(v).c_str());
    return false;
  }
  return true;
}

bool has_value(const std::vector<std::string>& args, size_t i, const std::string& opt) {
  if (i + 1 < args.size()) return true;
  std::fprintf(stderr, "tetopt: %s needs a value\n", shown(opt).c_str());
  return false;
}

bool parse_int(const std::string& opt, const std::string& v, long long& out) {
  char* end = nullptr;
  errno = 0;
  out = std::strtoll(v.c_str(), &end, 10);
  if (v.empty() || *end != '\0') {
    std::fprintf(stderr, "tetopt: %s expects an integer, got '%s'\n", shown(opt).c_str(), shown(v).c_str());
    return false;
  }
  if (errno == ERANGE) {  // strtoll saturated: 99999999999999999999 read as 2^63 - 1
    std::fprintf(stderr, "tetopt: %s: '%s' is out of range\n", shown(opt).c_str(), shown(v).c_str());
    return false;
  }
  return true;
}

namespace {
std::string id_list(const std::vector<int32_t>& ids, size_t max = 10) {
  std::string s;
  for (size_t i = 0; i < ids.size() && i < max; ++i) s += (i ? ", " : "") + std::to_string(ids[i] + 1);
  if (ids.size() > max) s += ", ... (" + std::to_string(ids.size()) + " in all)";
  return s;
}
}  // namespace

bool load_mesh(const std::string& path, TetMesh& m, bool quiet, int threads, std::vector<int32_t>* order,
               int64_t reorder_above) {
  const bool progress = !quiet && stderr_is_tty();
  if (progress) std::fprintf(stderr, "reading %s ...\r", shown(path).c_str());
  OrientationReport orient;
  // The reader's arrays take about as many bytes as the file or more
  // (demo impeller: a 19 MB Medit file, 30 MB of heap after the read); the
  // largest, the tets, less than half of them.
  struct stat st {};
  if (stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode) && heap_serves(static_cast<size_t>(st.st_size) / 2))
    prefault_heap(static_cast<size_t>(st.st_size), threads);
  const Status s = load_for_improve(path, m, orient, threads, reorder_above, order, read_input, [&] {
    if (progress) std::fprintf(stderr, "building topology of %d tets ...\033[K\r", m.nt());
  });
  if (progress) std::fputs("\033[K", stderr);
  if (!s) {
    std::fprintf(stderr, "tetopt: %s\n", shown(s.message).c_str());
    return false;
  }
  if (!quiet && orient.flipped)
    std::fprintf(stderr, "note: %s stores tets in the opposite orientation; normalised on read, "
                         "written back in its own convention\n", shown(path).c_str());
  if (!quiet && !orient.inverted.empty())
    std::fprintf(stderr, "warning: %s: %zu inverted tets (ids %s)\n", shown(path).c_str(), orient.inverted.size(),
                 id_list(orient.inverted).c_str());
  if (!quiet && !orient.flat_tets.empty())
    std::fprintf(stderr, "warning: %s: %zu flat (zero-volume) tets (ids %s)\n", shown(path).c_str(),
                 orient.flat_tets.size(), id_list(orient.flat_tets).c_str());
  return true;
}

static const char* kQualityHelp =
    "usage: tetopt quality IN [--json] [--field OUT.vtu] [--html REPORT.html] [--threshold G]\n"
    "                         [--threads K] [--no-histogram] [-q]\n"
    "\n"
    "Prints the quality of a tetrahedral mesh:\n"
    "  alpha = 6*sqrt(6)*V / (sum of face areas * longest edge)  (1 regular, 0 flat, <0 inverted)\n"
    "  worst and mean alpha overall, over boundary elements (tets with at least one\n"
    "  constrained vertex) and interior tets, the dihedral range, counts of poor tets,\n"
    "  and text histograms of alpha and of the dihedral angles.\n"
    "It also says why each tet with alpha < G is bad: locked by its boundary\n"
    "triangle (no apex over that constrained triangle reaches G, so no method that\n"
    "keeps the boundary can fix it), locked by its constrained neighbours (all four\n"
    "vertices constrained: only flips can help), or improvable; and the bound on\n"
    "worst alpha and the dihedral range that any mesh with this boundary obeys\n"
    "(a triangle at a sharp edge keeps its tet inside the wedge there), with the\n"
    "fewest tets below alpha 0.1 / 0.2 / 0.3 such a mesh can have.\n"
    "\n"
    "options:\n"
    "  --json            print the statistics as one JSON object instead (keys match\n"
    "                    ../shared/tools/meshcheck.py stats --json where they overlap,\n"
    "                    plus \"diagnosis\")\n"
    "  --field OUT.vtu   also write per-tet alpha, dihedral_min, dihedral_max, kind\n"
    "                    (number of constrained vertices, 4 = all-boundary), region,\n"
    "                    diagnosis (0 good, 1 locked by triangle, 2 locked by\n"
    "                    neighbours, 3 improvable) and alpha_bound as cell data, for ParaView\n"
    "                    (VTK XML: the name must end in .vtu)\n"
    "  --html FILE       write a self-contained HTML report (histograms, tables,\n"
    "                    diagnosis with the worst tets, a 3D view of where the\n"
    "                    tets below the threshold are: docs/report.md)\n"
    "  --threshold G     alpha below which a tet is diagnosed (default 0.3)\n"
    "  --threads K       worker threads for reading, the topology, the statistics and the\n"
    "                    diagnosis (default 0 = all cores; the same output for any K)\n"
    "  --no-histogram    omit the histograms\n"
    "  -q                no notes or progress on stderr\n"
    "\n"
    "example:  tetopt quality impeller.mesh --field impeller_quality.vtu --html impeller.html\n";

int cmd_quality(const std::vector<std::string>& args) {
  std::string in, field, html;
  bool json = false, hist = true, quiet = false;
  int threads = 0;  // all cores: the same output for any count
  DiagnoseOptions dopt;
  dopt.all_measures = true;  // the bound of every per-tet measure
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "-h" || a == "--help") { std::fputs(kQualityHelp, stdout); return kExitOk; }
    if (a == "--json") json = true;
    else if (a == "--no-histogram") hist = false;
    else if (a == "-q" || a == "--quiet") quiet = true;
    else if (a == "--field" || a == "--html") {
      if (i + 1 >= args.size()) {
        std::fprintf(stderr, "tetopt quality: %s needs a file name\n", a.c_str());
        return kExitUsage;
      }
      (a == "--field" ? field : html) = args[++i];
    } else if (a == "--threshold") {
      double d = 0;
      if (!has_value(args, i, a) || !parse_double(a, args[++i], d)) return kExitUsage;
      if (d <= 0 || d > 1) { std::fputs("tetopt quality: --threshold must be in (0, 1]\n", stderr); return kExitUsage; }
      dopt.threshold = d;
    } else if (a == "--threads") {
      long long n = 0;
      if (!has_value(args, i, a) || !parse_int(a, args[++i], n)) return kExitUsage;
      if (n < 0 || n > 1024) { std::fputs("tetopt quality: --threads must be in 0..1024\n", stderr); return kExitUsage; }
      threads = static_cast<int>(n);
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "tetopt quality: unknown option '%s' (--help lists the options)\n", shown(a).c_str());
      return kExitUsage;
    } else if (in.empty()) in = a;
    else { std::fprintf(stderr, "tetopt quality: unexpected argument '%s'\n", shown(a).c_str()); return kExitUsage; }
  }
  if (in.empty()) { std::fputs(kQualityHelp, stderr); return kExitUsage; }
  if (!field_is_vtu("tetopt quality", field)) return kExitUsage;
  if (const int rc = check_paths("tetopt quality", {{"IN", in}, {"--field", field}, {"--html", html}}, false, false);
      rc)
    return rc;
  TetMesh m;
  if (!load_mesh(in, m, quiet || json, threads)) return kExitInput;
  dopt.threads = threads;
  const QualityStats s = compute_stats(m, threads, /*measures=*/true);
  const Diagnosis diag = diagnose(m, dopt);
  if (json) {
    std::string js = stats_to_json(s);
    const size_t close = js.rfind('}');
    std::string dj = diagnosis_to_json(diag, 100, 2);
    for (size_t p = dj.find('\n'); p != std::string::npos; p = dj.find('\n', p + 3)) dj.replace(p, 1, "\n  ");
    js.insert(close, ",\n  \"diagnosis\": " + dj + "\n");
    // stats_to_json ends its last value with a newline; drop the blank line
    const size_t dup = js.find("\n,\n  \"diagnosis\"");
    if (dup != std::string::npos) js.erase(dup, 1);
    std::printf("%s\n", js.c_str());
  } else {
    std::printf("%s\n%s", shown(in).c_str(), format_stats_table(s).c_str());
    if (hist) std::printf("%s", format_histograms(s).c_str());
    std::printf("%s", format_diagnosis(diag).c_str());
  }
  if (!field.empty()) {
    std::vector<CellField> fields = quality_cell_fields(m);
    for (CellField& c : diagnosis_cell_fields(diag, m.nt())) fields.push_back(std::move(c));
    Status st = write_cell_fields_vtu(field, m, fields);
    if (!st) { std::fprintf(stderr, "tetopt: %s\n", shown(st.message).c_str()); return kExitOutput; }
    if (!quiet && !json) std::printf("wrote per-tet fields to %s\n", shown(field).c_str());
  }
  if (!html.empty()) {
    HtmlReportInput hin;
    hin.title = "tetopt quality: " + in;
    hin.input = in;
    hin.before = s;
    hin.before_hist = quality_histograms(m);
    hin.diagnosis = &diag;
    hin.mesh = &m;  // the 3D view
    Status st = write_html_report(html, hin);
    if (!st) { std::fprintf(stderr, "tetopt: %s\n", shown(st.message).c_str()); return kExitOutput; }
    if (!quiet && !json) std::printf("wrote HTML report to %s\n", shown(html).c_str());
  }
  return kExitOk;
}

static const char* kConvertHelp =
    "usage: tetopt convert IN OUT [--msh-version 22|41|fluent] [--binary] [--meshb-version 2|3|4]\n"
    "                             [--write-boundary]\n"
    "                             [--threads K]\n"
    "\n"
    "Converts a tetrahedral mesh between formats, chosen by extension:\n"
    "  .mesh .meshb  Medit (GMF)        .msh  Gmsh 2.2 / 4.1 (default 4.1)\n"
    "  .vtk .vtu     VTK legacy / XML   .node/.ele[/.face]  TetGen\n"
    "  .cgns         CGNS               .exo .e .ex2        Exodus II\n"
    "Tets, listed triangles and their refs are kept in every format, and\n"
    "coordinates round-trip bit for bit.  What OUT's format cannot hold is\n"
    "named in a warning and left out: vertex refs in .msh/.vtk/.vtu, required\n"
    "entities and ridges outside Medit, listed edges and corners in TetGen,\n"
    "physical names outside Gmsh, point data arrays outside VTK.  The output\n"
    "is written to a temporary file (TetGen: all three) and renamed, so a\n"
    "failure leaves no half file.\n"
    "\n"
    "options:\n"
    "  --write-boundary  list the boundary and interface triangles IN does not list, as\n"
    "                    groups boundary_REGION and interface_A_B with new refs\n"
    "  --msh-version V   22 or 41 for Gmsh .msh output (default 41), fluent for a Fluent\n"
    "                    mesh (the default when IN is one)\n"
    "  --binary          binary .msh / .vtk output\n"
    "  --meshb-version V GMF version of .meshb output: 2, 3 (default) or 4\n"
    "  --threads K       worker threads for reading and writing (default 0 = all\n"
    "                    cores); the output is byte-identical for every K\n"
    "\n"
    "example:  tetopt convert part.msh part.mesh\n";

int cmd_convert(const std::vector<std::string>& args) {
  std::vector<std::string> pos;
  WriteOptions wo;
  bool write_boundary = false;
  wo.threads = 0;  // all cores: the same bytes for any count
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    long long v = 0;
    if (a == "-h" || a == "--help") { std::fputs(kConvertHelp, stdout); return kExitOk; }
    if (a == "--binary") wo.binary = true;
    else if (a == "--write-boundary") write_boundary = true;
    else if (a == "--threads") {
      if (!has_value(args, i, a) || !parse_int(a, args[++i], v)) return kExitUsage;
      if (v < 0 || v > 1024) { std::fputs("tetopt convert: --threads must be in 0..1024\n", stderr); return kExitUsage; }
      wo.threads = static_cast<int>(v);
    } else if (a == "--msh-version" && i + 1 < args.size() && args[i + 1] == "fluent") {
      ++i;
      wo.msh = WriteOptions::Msh::Fluent;  // a Fluent mesh (issue 28)
    } else if (a == "--msh-version" || a == "--meshb-version") {
      if (!has_value(args, i, a) || !parse_int(a, args[i + 1], v)) return kExitUsage;
      ++i;
      if (a == "--msh-version") {
        if (v != 22 && v != 41) { std::fputs("tetopt convert: --msh-version is 22, 41 or fluent\n", stderr); return kExitUsage; }
        wo.msh_version = static_cast<int>(v);
        wo.msh = WriteOptions::Msh::Gmsh;
      } else {
        if (v < 2 || v > 4) { std::fputs("tetopt convert: --meshb-version is 2, 3 or 4\n", stderr); return kExitUsage; }
        wo.meditb_version = static_cast<int>(v);
      }
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "tetopt convert: unknown option '%s' (--help lists the options)\n", shown(a).c_str());
      return kExitUsage;
    } else pos.push_back(a);
  }
  if (pos.size() != 2) { std::fputs(kConvertHelp, stderr); return kExitUsage; }
  if (format_from_path(pos[1]) == Format::Unknown) {
    std::fprintf(stderr, "tetopt: %s: unknown output extension\n", shown(pos[1]).c_str());
    return kExitUsage;
  }
  // OUT may be IN (rewritten in place: convert changes the file, not the
  // mesh); OUT must be writable before IN is read.
  if (const int rc = check_paths("tetopt convert", {{"IN", pos[0]}, {"OUT", pos[1]}}, true, true); rc) return rc;
  TetMesh m;
  OrientationReport orient;
  Status s = read_input(pos[0], m, &orient, wo.threads);
  if (!s) { std::fprintf(stderr, "tetopt: %s\n", shown(s.message).c_str()); return kExitInput; }
  if (write_boundary) add_boundary_triangles(m);
  warn_dropped(pos[1], m, wo, false);
  s = write_mesh(pos[1], m, wo);
  if (!s) { std::fprintf(stderr, "tetopt: %s\n", shown(s.message).c_str()); return kExitOutput; }
  return kExitOk;
}

static const char* kGenerateHelp =
    "usage: tetopt generate OUT [--cells NX NY NZ] [--jitter J] [--seed S] [--regions 1|2]\n"
    "\n"
    "Writes a box mesh made here: NX x NY x NZ unit cubes, each split into six\n"
    "tets (Kuhn split), interior vertices displaced at random by up to J cells\n"
    "(moves that would invert a tet are skipped).  With --regions 2 the halves\n"
    "x < NX/2 and x >= NX/2 get refs 1 and 2 (an interface to keep).  For tests\n"
    "and benchmarks: 6*NX*NY*NZ tets.\n"
    "\n"
    "example:  tetopt generate box.mesh --cells 80 80 80 --jitter 0.35   (3.07M tets)\n";

int cmd_generate(const std::vector<std::string>& args) {
  BoxMeshOptions o;
  std::string out;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    long long v = 0;
    double d = 0;
    if (a == "-h" || a == "--help") { std::fputs(kGenerateHelp, stdout); return kExitOk; }
    if (a == "--cells") {
      if (i + 3 >= args.size()) { std::fputs("tetopt generate: --cells needs three integers\n", stderr); return kExitUsage; }
      int c[3];
      for (int k = 0; k < 3; ++k) {
        if (!parse_int(a, args[i + 1 + k], v)) return kExitUsage;
        if (v < 1 || v > 2000) { std::fputs("tetopt generate: cells per axis must be in 1..2000\n", stderr); return kExitUsage; }
        c[k] = static_cast<int>(v);
      }
      o.nx = c[0]; o.ny = c[1]; o.nz = c[2];
      i += 3;
    } else if (a == "--jitter") {
      if (!has_value(args, i, a) || !parse_double(a, args[++i], d)) return kExitUsage;
      if (d < 0 || d > 0.45) { std::fputs("tetopt generate: --jitter must be in [0, 0.45]\n", stderr); return kExitUsage; }
      o.jitter = d;
    } else if (a == "--seed") {
      if (!has_value(args, i, a) || !parse_int(a, args[++i], v)) return kExitUsage;
      if (v < 0) { std::fputs("tetopt generate: --seed must be a whole number from 0 on\n", stderr); return kExitUsage; }
      o.seed = static_cast<uint64_t>(v);
    } else if (a == "--regions") {
      if (!has_value(args, i, a) || !parse_int(a, args[++i], v)) return kExitUsage;
      if (v != 1 && v != 2) { std::fputs("tetopt generate: --regions is 1 or 2\n", stderr); return kExitUsage; }
      o.regions = static_cast<int>(v);
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "tetopt generate: unknown option '%s' (--help lists the options)\n", shown(a).c_str());
      return kExitUsage;
    } else if (out.empty()) out = a;
    else { std::fprintf(stderr, "tetopt generate: unexpected argument '%s'\n", shown(a).c_str()); return kExitUsage; }
  }
  if (out.empty()) { std::fputs(kGenerateHelp, stderr); return kExitUsage; }
  TetMesh m;
  try {
    m = make_box_mesh(o);
  } catch (const std::invalid_argument& e) {  // more tets than 32-bit ids can name
    std::fprintf(stderr, "tetopt generate: %s\n", e.what());
    return kExitUsage;
  } catch (const std::bad_alloc&) {
    const double tets = 6.0 * o.nx * o.ny * o.nz;
    std::fprintf(stderr, "tetopt generate: out of memory for %.0f tets (about %.1f GB); nothing written\n", tets,
                 tets * 60e-9);
    return kExitOutput;
  }
  Status s = write_mesh(out, m);
  if (!s) { std::fprintf(stderr, "tetopt: %s\n", shown(s.message).c_str()); return kExitOutput; }
  return kExitOk;
}

}  // namespace tetopt_cli
