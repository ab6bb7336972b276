// The options of `tetopt improve`, parsed once for both executables that take
// them: `tetopt improve` (apps/cli/cmd_improve.cpp) and `tetopt-mpi improve`
// (apps/mpi/main.cpp).  An option added here is accepted by both, with the same
// spelling, validation and error message.  Options that only one executable
// has (tetopt's --field and --html, tetopt-mpi's --rounds and --per-rank) are
// passed in as ExtraOption by that executable.
//
// Nothing here prints: errors come back as one line (prefix included, no
// newline), so that tetopt-mpi can print them on rank 0 only.  This file has
// no dependency on the rest of apps/cli (apps/mpi/CMakeLists.txt compiles it
// into tetopt-mpi).
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "tetopt/improve.hpp"
#include "tetopt/io.hpp"
#include "tetopt/mesh.hpp"

namespace tetopt_cli {

/// What the shared improve options set.
struct ImproveArgs {
  std::string in, out, report;  // positional input, -o, --report
  tetopt::ImproveOptions opt;
  tetopt::WriteOptions wo;
  bool quiet = false, verbose = false;
  // --reorder-above N; --keep-order wins over it (whatever the order given).
  int64_t reorder_above = 1000000;
  bool keep_order = false;
  bool write_boundary = false;  ///< --write-boundary: list the unlisted boundary and interface triangles (issue 28)
};

/// An option of one executable only.  apply gets the value ("" for a flag)
/// and returns false with err set (without prefix) when it is invalid.
struct ExtraOption {
  std::vector<std::string> names;  // e.g. {"--rounds"}
  bool takes_value = true;
  std::function<bool(const std::string& value, std::string& err)> apply;
};

/// How error lines begin: command ("tetopt improve", "tetopt-mpi") for usage
/// errors, tool ("tetopt", "tetopt-mpi") for a value that is not a number.
struct ImproveArgsNames {
  std::string command, tool;
};

enum class ImproveArgsResult {
  Ok,             // all options valid, input and output given, output extension known
  Help,           // -h or --help seen: print the help, exit 0
  Error,          // err holds one line; exit 1
  ErrorWithHelp,  // no input, no output: err, a blank line, then the help
};

/// Every argument `--name=value` as the two arguments `--name` `value`
/// (GNU style, which users type from habit: `--threads=2`); other arguments,
/// and a lone `--=x`, as they are.
std::vector<std::string> split_equals(const std::vector<std::string>& args);

/// A whole number in [lo, hi] for option `name` (the own options of a
/// program, e.g. tetopt-mpi's --rounds): false with a one-line err
/// ("NAME: not a number: 'S'" or "NAME must be a whole number in LO..HI").
bool parse_whole(const std::string& name, const std::string& s, int64_t lo, int64_t hi, int64_t& out,
                 std::string& err);

/// Whether `improve` (tetopt and tetopt-mpi) first puts the tets of m (read,
/// not yet with topology) in Morton order: reorder_above >= 0 (not
/// --keep-order), m has at least reorder_above tets, they follow no spatial
/// order (tet_order_spread above kSortSpread) and none is inverted or flat
/// (the untangling names input tets by their number in IN).  Measured on
/// this 2-core machine: flange_large (2.0M tets, spread 44) 11.3-11.9 s ->
/// 9.6-9.8 s at 2 threads, worst alpha 0.1309 -> 0.1355.  The demo impeller
/// (438k tets, spread 25): 10% faster at 1 thread but not at 2 (improve
/// call 1.252 -> 1.278 s, medians of 12; its topology passes were slower,
/// 0.81-0.91 -> 0.89-1.06 s in three runs each; not analysed further: the
/// parallel flip windows may meet more conflicts when neighbouring entries
/// of the work list are neighbours in space); meshes of 50k-170k tets: no
/// difference beyond the noise.
/// The result differs (another order of the passes), hence the default of
/// 1,000,000 tets.
inline constexpr double kSortSpread = 8.0;
bool worth_sorting(const tetopt::TetMesh& m, const tetopt::OrientationReport& orient, int64_t reorder_above,
                   int threads);

/// A mesh reader: read_mesh, or the command line tool's read_input.
using MeshReader = std::function<tetopt::Status(const std::string&, tetopt::TetMesh&, tetopt::OrientationReport*, int)>;

/// Reads IN for measuring or improving, as tetopt and tetopt-mpi do: read,
/// check_measurable, Morton order when `order` is given and worth_sorting
/// (order[id] = the tet's id in IN), build_topology, orient_consistently.
/// A topology error after the reorder is reproduced on IN's own order (IN
/// is read again), so that its message names tets by their number in IN.
/// The reader's errors come as they are (they name the file), later ones
/// with "IN: " in front.  on_read (optional) runs after the read succeeded
/// (a progress line).
tetopt::Status load_for_improve(const std::string& path, tetopt::TetMesh& m, tetopt::OrientationReport& orient,
                                int threads, int64_t reorder_above, std::vector<int32_t>* order,
                                const MeshReader& read, const std::function<void()>& on_read = {});

/// Parses args (the words after "improve").  Stops at the first error.
ImproveArgsResult parse_improve_args(const std::vector<std::string>& args, const ImproveArgsNames& names,
                                     const std::vector<ExtraOption>& extra, ImproveArgs& a, std::string& err);

/// What OUT's format cannot hold of m (tetopt::dropped_by_format), printed
/// as one warning line unless quiet; returned for the report
/// (dropped_on_write).
std::vector<std::string> warn_dropped(const std::string& out, const tetopt::TetMesh& m, const tetopt::WriteOptions& wo,
                                      bool quiet);

}  // namespace tetopt_cli
