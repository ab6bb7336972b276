// Shared pieces of the tetopt command line.
#pragma once
#include <atomic>
#include <string>
#include <utility>
#include <vector>

#include "tetopt/io.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/status.hpp"

namespace tetopt_cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitUsage = 1;
inline constexpr int kExitInput = 2;
inline constexpr int kExitInvariant = 3;
inline constexpr int kExitOutput = 4;
inline constexpr int kExitInterrupted = 130;

extern std::atomic<bool> g_interrupted;
void on_sigint(int);
/// SIGBUS while an input's memory map is read (read_input): one line, exit 2.
void on_sigbus(int);
/// SIGTERM, SIGHUP, and SIGINT outside improve: removes the temporary files
/// of a write in progress, then ends as the signal would (SIGINT: exit 130).
void on_terminating_signal(int sig);
/// read_mesh with on_sigbus told which file is being read.
tetopt::Status read_input(const std::string& path, tetopt::TetMesh& m, tetopt::OrientationReport* orient, int threads);
/// The input the last read_input call read (as shown in messages), empty
/// before any: main's out-of-memory message names it.
const std::string& last_input();

int cmd_quality(const std::vector<std::string>& args);
int cmd_convert(const std::vector<std::string>& args);
int cmd_improve(const std::vector<std::string>& args);
int cmd_generate(const std::vector<std::string>& args);

/// Reads IN, normalises orientation, builds topology; prints the error (one
/// line) and returns false on failure.  Reports inverted/flat tets on stderr.
/// threads: for building the topology (same result for every count).
/// order (improve only; nullptr: keep IN's order): where worth_sorting says
/// so (with reorder_above), the tets are put in Morton order before the
/// topology is built, and order gets order[new id] = id in IN (left empty
/// otherwise).
bool load_mesh(const std::string& path, tetopt::TetMesh& m, bool quiet, int threads = 1,
               std::vector<int32_t>* order = nullptr, int64_t reorder_above = -1);

/// Checks a command's files before any work: (what, path) pairs, the first
/// one the input, the rest outputs (empty paths skipped).  Two of them
/// naming the same file (through another spelling, a hard link or a
/// symbolic link too: the same device and inode where both exist) is a
/// usage error: prints "CMD: WHAT and WHAT name the same file 'P'" (over
/// IN, with the rule: no output may replace IN) and returns kExitUsage.  An
/// output that cannot be written (no such folder, a folder or a device, a
/// symbolic link loop, a name too long): prints "CMD: P: why (for WHAT)"
/// and returns kExitOutput, so that no output is written by a run that
/// fails later on another one.  Returns kExitOk otherwise.
/// files[0] is the input mesh and, with out_is_mesh, files[1] the output
/// mesh: a TetGen name among them stands for its .node, .ele and .face.
/// out_may_be_in: files[1] may be IN (tetopt convert rewrites a file in
/// place, through a temporary; tetopt improve and tetopt-mpi refuse -o IN
/// as they refuse --report IN).
int check_paths(const char* cmd, const std::vector<std::pair<std::string, std::string>>& files, bool out_is_mesh,
                bool out_may_be_in);

/// --field writes VTK XML: false, with "CMD: --field writes VTK XML (.vtu)
/// ..." on stderr, when a non-empty name does not end in .vtu (any case).
bool field_is_vtu(const char* cmd, const std::string& field);

/// A file name, or a whole message, as a line shows it: control characters
/// escaped (\n, \x1b) and bytes that are not UTF-8 as \xNN
/// (tetopt::detail::escaped_name), so that every message stays one line and
/// prints no terminal escape.  Escaping twice changes nothing: a library
/// message whose names are escaped already passes through as it is.
std::string shown(const std::string& s);

/// True when stderr is a terminal (progress lines go there).
bool stderr_is_tty();

/// Parses a number option value; prints a usage error and returns false on failure.
bool parse_double(const std::string& opt, const std::string& v, double& out);
/// False, with a message on stderr, when option args[i] has no value after it.
bool has_value(const std::vector<std::string>& args, size_t i, const std::string& opt);
bool parse_int(const std::string& opt, const std::string& v, long long& out);

}  // namespace tetopt_cli
