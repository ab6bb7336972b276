"""The `tetopt` command installed by pip: runs the tetopt program the wheel
carries (tetopt/_bin/tetopt, the same binary as the CMake build's), with
the same arguments, exit codes and signals (it replaces this process)."""
import os
import sys


def main() -> None:
    exe = os.path.join(os.path.dirname(os.path.abspath(__file__)), "_bin", "tetopt")
    if not os.access(exe, os.X_OK):
        sys.stderr.write(f"tetopt: the program is missing from this installation ({exe}); "
                         "reinstall with `pip install .` from the source tree\n")
        sys.exit(2)
    os.execv(exe, [exe] + sys.argv[1:])


if __name__ == "__main__":
    main()
