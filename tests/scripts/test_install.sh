#!/usr/bin/env bash
# What `cmake --install` gives C++ and Python users (issue 29), from this
# build tree into a temporary prefix:
#  - libtetopt.so exports the public API (include/tetopt) and nothing of src/;
#  - examples/cpp builds against the installed tree with find_package(tetopt)
#    (CMAKE_PREFIX_PATH), shared and static, and with pkg-config, and runs;
#  - examples/python/improve.py runs on the installed Python package;
#  - the installed man page shows every line of `tetopt --help` and of each
#    command's --help, in order (it is generated from them).
# Skips (77) in builds without the shared library (sanitizer, fuzz).
# usage: test_install.sh TETOPT_CLI SOURCE_DIR
set -u
T=$1; SRC=$2
BUILD=$(cd "$(dirname "$T")" && pwd)
[ -f "$BUILD/libtetopt.so" ] || { echo "skip: no libtetopt.so in $BUILD (TETOPT_BUILD_SHARED=OFF)"; exit 77; }
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
P="$W/prefix"
fail=0
ok() { echo "ok   $1"; }
bad() { echo "FAIL $1"; fail=1; }

cmake --install "$BUILD" --prefix "$P" > "$W/install.log" 2>&1 || { cat "$W/install.log"; echo "FAIL cmake --install"; exit 1; }
for f in lib/libtetopt.a lib/libtetopt.so lib/cmake/tetopt/tetoptConfig.cmake lib/pkgconfig/tetopt.pc \
         include/tetopt/improve.hpp bin/tetopt share/man/man1/tetopt.1; do
  [ -e "$P/$f" ] || bad "installed: $f missing"
done

# Exported symbols: those of namespace tetopt are declared in the public
# headers; none is a src/ helper (tetopt::detail, a file's own functions).
nm -DC --defined-only "$P/lib/libtetopt.so" | awk '{ $1 = ""; $2 = ""; sub(/^ +/, ""); print }' > "$W/exported"
grep '^tetopt::' "$W/exported" | sed -E 's/\(.*//; s/^(vtable|typeinfo( name)?) for //; s/\[abi:cxx11\]//' \
  | awk -F'::' '{ print $NF }' | sed 's/^~//' | sort -u > "$W/names"
n=$(wc -l < "$W/names")
[ "$n" -ge 50 ] && ok "libtetopt.so exports $n names of namespace tetopt" || bad "only $n tetopt names exported"
missing=$(while read -r name; do grep -qw -- "$name" "$SRC"/include/tetopt/*.hpp || echo "$name"; done < "$W/names")
[ -z "$missing" ] && ok "every exported tetopt name is declared in include/tetopt" \
  || bad "exported but not in the public headers: $(echo $missing | head -c 400)"
grep -q 'tetopt::detail::' "$W/exported" && bad "tetopt::detail symbols exported" || ok "no tetopt::detail symbol exported"
# A helper of src/ that the static library has (text symbol) is hidden in the shared one.
nm -C "$BUILD/libtetopt.a" 2>/dev/null | grep -q ' T tetopt::detail::' \
  && ok "the static library keeps its internal symbols (tests link them)" || bad "no tetopt::detail text symbol in libtetopt.a"

"$T" generate "$W/box.mesh" --cells 6 6 6 --jitter 0.4 --regions 2 > /dev/null || exit 1

# find_package(tetopt): shared, then static.
for kind in shared static; do
  flag=OFF; [ $kind = static ] && flag=ON
  if cmake -S "$SRC/examples/cpp" -B "$W/ex-$kind" -DCMAKE_PREFIX_PATH="$P" -DEXAMPLE_STATIC=$flag \
       -DCMAKE_BUILD_TYPE=Release > "$W/ex-$kind.log" 2>&1 && cmake --build "$W/ex-$kind" >> "$W/ex-$kind.log" 2>&1; then
    ok "examples/cpp builds with find_package(tetopt) ($kind)"
  else
    tail -20 "$W/ex-$kind.log"; bad "examples/cpp does not build with find_package(tetopt) ($kind)"; continue
  fi
  if ldd "$W/ex-$kind/improve_example" | grep -q "$P/lib/libtetopt.so"; then linked=shared; else linked=static; fi
  [ $linked = $kind ] && ok "the $kind example links the $kind library" || bad "the $kind example links the $linked library"
  if "$W/ex-$kind/improve_example" "$W/box.mesh" "$W/out-$kind.mesh" > "$W/run-$kind.out" 2>&1 \
     && grep -q "boundary unchanged: yes" "$W/run-$kind.out" && grep -q "round 1 flips" "$W/run-$kind.out"; then
    ok "the $kind example improves a mesh, with progress lines ($(tail -n 1 "$W/run-$kind.out"))"
  else
    cat "$W/run-$kind.out"; bad "the $kind example failed"
  fi
done

# pkg-config.
if command -v pkg-config > /dev/null; then
  if c++ -O1 "$SRC/examples/cpp/improve.cpp" -o "$W/ex-pc" $(PKG_CONFIG_PATH="$P/lib/pkgconfig" pkg-config --cflags --libs tetopt) \
       > "$W/pc.log" 2>&1 && LD_LIBRARY_PATH="$P/lib" "$W/ex-pc" "$W/box.mesh" "$W/out-pc.mesh" > "$W/pc.out" 2>&1 \
       && cmp -s "$W/out-pc.mesh" "$W/out-shared.mesh"; then
    ok "pkg-config --cflags --libs tetopt builds the example; same output as the CMake build"
  else
    cat "$W/pc.log" "$W/pc.out" 2>/dev/null | tail -20; bad "pkg-config build of the example"
  fi
else
  echo "skip pkg-config is not installed (Debian: pkgconf)"
fi

# The Python package as installed, and the example script.
PYDIR=$(ls -d "$P"/lib/python3*/*-packages 2>/dev/null | head -n 1)
if [ -n "$PYDIR" ] && ls "$PYDIR"/tetopt/_tetopt*.so > /dev/null 2>&1; then
  for f in __init__.py __init__.pyi py.typed; do [ -f "$PYDIR/tetopt/$f" ] || bad "installed: tetopt/$f missing"; done
  # improve_mesh writes what `tetopt improve` writes (the same bytes); the
  # C++ example calls the library alone (no region grouping of the tets).
  "$P/bin/tetopt" improve "$W/box.mesh" -o "$W/out-cli.mesh" -q
  if PYTHONPATH="$PYDIR" /usr/bin/python3 "$SRC/examples/python/improve.py" "$W/box.mesh" "$W/out-py.mesh" > "$W/py.out" 2>&1 \
     && grep -q "boundary unchanged: yes" "$W/py.out" && cmp -s "$W/out-py.mesh" "$W/out-cli.mesh"; then
    ok "examples/python/improve.py on the installed package: the installed tetopt improve's bytes"
  else
    tail -20 "$W/py.out"; bad "examples/python/improve.py"
  fi
else
  echo "skip the Python module was not built"
fi

# man tetopt shows the help texts: every line of each, in order.
MANWIDTH=250 man -l "$P/share/man/man1/tetopt.1" 2> "$W/man.err" | col -bx > "$W/man.txt"
[ -s "$W/man.txt" ] || { cat "$W/man.err"; bad "man -l tetopt.1 rendered nothing"; }
/usr/bin/python3 - "$T" "$W/man.txt" <<'PY' || fail=1
import re, subprocess, sys
tetopt, man = sys.argv[1], open(sys.argv[2]).read().splitlines()
main = subprocess.run([tetopt, "--help"], capture_output=True, text=True, check=True).stdout
cmds = re.findall(r"^  ([a-z][a-z0-9-]*) ", main.split("\ncommands:\n", 1)[1].split("\n\n", 1)[0], re.M)
texts = [("tetopt --help", main)] + [(f"tetopt {c} --help",
         subprocess.run([tetopt, c, "--help"], capture_output=True, text=True, check=True).stdout) for c in cmds]
at, bad = 0, 0
man = [l.rstrip() for l in man]
for name, text in texts:
    for line in text.splitlines():
        if not line.strip():
            continue
        # man indents the page: the help line, whole, ends a later man line.
        k = next((i for i in range(at, len(man)) if man[i].endswith(line.rstrip()) and
                  man[i][: len(man[i]) - len(line.rstrip())].strip() == ""), None)
        if k is None:
            print(f"FAIL man tetopt lacks (in order) a line of {name}: {line!r}")
            bad += 1
            break
        at = k + 1
    else:
        print(f"ok   man tetopt shows {name} ({len(text.splitlines())} lines)")
sys.exit(1 if bad or len(cmds) < 4 else 0)
PY
exit $fail
