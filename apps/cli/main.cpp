// tetopt command line: a thin front end over the library (no algorithms here).
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <new>
#include <string>
#include <vector>

#include "cli.hpp"
#include "hugepages.hpp"
#include "improve_args.hpp"

namespace {

const char* kMainHelp =
    "tetopt — improve tetrahedral meshes without touching their boundary\n"
    "\n"
    "usage: tetopt <command> [options]\n"
    "\n"
    "commands:\n"
    "  quality IN [--json] [--field OUT.vtu] [--no-histogram]\n"
    "                 quality statistics (paper's Table 1/3 columns) and histograms\n"
    "  improve IN -o OUT [options]\n"
    "                 improve the mesh; boundary, interfaces and refs stay bit-identical\n"
    "  convert IN OUT [--msh-version 22|41] [--binary]\n"
    "                 convert between formats (by extension)\n"
    "  generate OUT [--cells NX NY NZ] [--jitter J] [--regions 2]\n"
    "                 write a box test mesh made here (Kuhn-split cubes)\n"
    "\n"
    "formats (by extension): .mesh .meshb (Medit), .msh (Gmsh 2.2/4.1), .vtk .vtu (VTK),\n"
    "                        .node/.ele[/.face] (TetGen), .cgns (CGNS), .exo .e .ex2 (Exodus II)\n"
    "\n"
    "Run 'tetopt <command> --help' for the options of a command.\n"
    "\n"
    "exit codes:\n"
    "  0  success\n"
    "  1  usage error (unknown option, missing argument)\n"
    "  2  input error (unreadable, malformed or invalid mesh file); nothing written\n"
    "  3  invariant failure: a bug broke a promise (boundary, orientation, volume);\n"
    "     nothing written, the message names the broken invariant\n"
    "  4  output error (cannot write the output file)\n"
    "  130 interrupted (Ctrl-C); nothing written\n";

}  // namespace

// Out of memory must stay a message (exit 2 / 4), never an abort.  With
// almost no address space left (ulimit -v just above what the shared
// libraries map), the C++ runtime may have no emergency pool for
// exceptions, and a failed allocation then aborts ("terminate called
// without an active exception", tests/scripts/test_oom.sh at 10000 KiB)
// because the bad_alloc itself cannot be allocated (and, after the
// re-execution with glibc.malloc.hugetlb=1, the heap grows only by 2 MiB
// steps, so a small request fails once those are out of reach).  So main
// holds a reserve on the heap (below malloc's mmap threshold, so that
// freeing it leaves it in malloc's free lists rather than returning it to
// the system): the first failed operator new releases it and retries (a
// small request then succeeds), a later one throws as usual, with the
// reserve's room left for the exception.  Without the reserve at start:
// one line and exit 2.
namespace {
constexpr size_t kStartupReserve = size_t{1} << 16;
std::atomic<void*> g_reserve{nullptr};
void release_reserve() {
  if (void* r = g_reserve.exchange(nullptr)) {
    std::free(r);
    return;
  }
  std::set_new_handler(nullptr);
  throw std::bad_alloc();
}
}  // namespace

int main(int argc, char** argv) {
  g_reserve = std::malloc(kStartupReserve);
  if (!g_reserve) {
    // The command and its input named as the other out-of-memory messages
    // name them, control characters escaped, without allocating.
    std::fputs("tetopt", stderr);
    for (int i = 1; i < argc && i < 3; ++i) {
      std::fputc(' ', stderr);
      for (const char* c = argv[i]; *c; ++c) {
        const auto u = static_cast<unsigned char>(*c);
        if (u < 0x20 || u == 0x7f) std::fprintf(stderr, "\\x%02x", u);
        else std::fputc(*c, stderr);
      }
    }
    std::fputs(": out of memory at start-up; nothing written\n", stderr);
    return tetopt_cli::kExitInput;
  }
  std::set_new_handler(release_reserve);
  tetopt_cli::reexec_with_huge_pages(argv);
  tetopt_cli::keep_freed_memory();
  std::signal(SIGINT, argc >= 2 && std::string(argv[1]) == "improve" ? tetopt_cli::on_sigint
                                                                      : tetopt_cli::on_terminating_signal);
  std::signal(SIGTERM, tetopt_cli::on_terminating_signal);
  std::signal(SIGHUP, tetopt_cli::on_terminating_signal);
  std::signal(SIGBUS, tetopt_cli::on_sigbus);
  // Past a file size limit (ulimit -f) a write fails with EFBIG, an output
  // error (exit 4) whose temporary file is removed, instead of SIGXFSZ
  // killing the process and leaving it behind.
  std::signal(SIGXFSZ, SIG_IGN);
  if (argc < 2) {
    std::fputs(kMainHelp, stderr);
    return tetopt_cli::kExitUsage;
  }
  const std::string cmd = argv[1];
  const std::vector<std::string> args = tetopt_cli::split_equals(std::vector<std::string>(argv + 2, argv + argc));
  if (cmd == "-h" || cmd == "--help" || cmd == "help") {
    std::fputs(kMainHelp, stdout);
    return 0;
  }
  if (cmd == "--version" || cmd == "version") {
    std::puts("tetopt 0.1.0");
    return 0;
  }
  // Out of memory is a message, never an abort (issue 25): reading and
  // writing turn it into a Status themselves (exit 2 / 4); what is left is
  // improving or measuring a mesh that needs more memory than there is,
  // which is the input's size: exit 2.  Outputs are only ever renamed into
  // place complete, so nothing is written.
  try {
    if (cmd == "quality") return tetopt_cli::cmd_quality(args);
    if (cmd == "convert") return tetopt_cli::cmd_convert(args);
    if (cmd == "improve") return tetopt_cli::cmd_improve(args);
    if (cmd == "generate") return tetopt_cli::cmd_generate(args);
  } catch (const std::bad_alloc&) {
    // Name the mesh when one was read (a script running many sees which).
    const std::string& in = tetopt_cli::last_input();
    std::fprintf(stderr, "tetopt %s: %s%sout of memory (the mesh needs more memory than there is); nothing written\n",
                 cmd.c_str(), in.c_str(), in.empty() ? "" : ": ");
    return tetopt_cli::kExitInput;
  }
  std::fprintf(stderr, "tetopt: unknown command '%s'\n\n%s", tetopt_cli::shown(cmd).c_str(), kMainHelp);
  return tetopt_cli::kExitUsage;
}
