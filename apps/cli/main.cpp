// tetopt command line: a thin front end over the library (no algorithms here).
#include <unistd.h>

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

int main(int argc, char** argv) {
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
  std::vector<std::string> args(argv + 2, argv + argc);
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
