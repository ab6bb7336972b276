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
/// naming the same file (the input included; a side output over the input or
/// the main output would silently replace it) is a usage error: prints
/// "CMD: WHAT and WHAT name the same file 'P'" and returns kExitUsage.  An
/// output whose folder does not exist: prints "CMD: P: no such folder (for
/// WHAT)" and returns kExitOutput, so that no output is written by a run
/// that fails later on another one.  Returns kExitOk otherwise.  The main
/// output may be the input (improve in place: written through a temporary).
/// files[0] is the input mesh and, with out_may_be_in, files[1] the output
/// mesh: a TetGen name among them stands for its .node, .ele and .face.
int check_paths(const char* cmd, const std::vector<std::pair<std::string, std::string>>& files,
                bool out_may_be_in);

/// True when stderr is a terminal (progress lines go there).
bool stderr_is_tty();

/// Parses a number option value; prints a usage error and returns false on failure.
bool parse_double(const std::string& opt, const std::string& v, double& out);
/// False, with a message on stderr, when option args[i] has no value after it.
bool has_value(const std::vector<std::string>& args, size_t i, const std::string& opt);
bool parse_int(const std::string& opt, const std::string& v, long long& out);

}  // namespace tetopt_cli
