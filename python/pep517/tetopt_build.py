"""tetopt's PEP 517 build backend: `pip install .` and `pip wheel .` from the
source tree, with nothing to download (Debian 12 ships no scikit-build-core).

It configures and builds this project with CMake (the Python module, the
`tetopt` program and its man page), then writes the wheel itself (PEP 427:
a zip with a .dist-info folder and a RECORD of sha256 hashes):

    tetopt/__init__.py, __init__.pyi, py.typed, _cli.py    (python/tetopt)
    tetopt/_tetopt.<ext suffix>                             (the pybind11 module)
    tetopt/_bin/tetopt                                      (the program)
    tetopt-<v>.data/data/share/man/man1/tetopt.1            (man tetopt)
    console script `tetopt` -> tetopt._cli:main             (runs _bin/tetopt)

Build folder: a fresh temporary one, removed afterwards; or, to reuse a
configured build (make test does), the folder named by the environment
variable TETOPT_BUILD_DIR or `--config-settings build-dir=DIR`: configured
there when it has no CMakeCache.txt, otherwise only brought up to date.
CMAKE_BUILD_PARALLEL_LEVEL sets the jobs (default: every core).  Metadata
comes from pyproject.toml's [project] table.  No sdist and no editable
install: build from the source tree.
"""
import base64
import hashlib
import importlib.machinery
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile

try:
    import tomllib
except ImportError:  # Python < 3.11
    tomllib = None

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _project():
    path = os.path.join(ROOT, "pyproject.toml")
    if tomllib is not None:
        with open(path, "rb") as f:
            return tomllib.load(f)["project"]
    # Without tomllib: the few keys used here, from their simple one-line form.
    proj, section = {}, None
    for line in open(path, encoding="utf-8"):
        line = line.strip()
        if line.startswith("["):
            section = line.strip("[]")
            continue
        if "=" not in line or line.startswith("#"):
            continue
        k, v = (x.strip() for x in line.split("=", 1))
        v = eval(v, {"__builtins__": {}})  # noqa: S307 - string and list literals of our own file
        if section == "project":
            proj[k] = v
        elif section == "project.scripts":
            proj.setdefault("scripts", {})[k.strip('"')] = v
        elif section == "project.optional-dependencies":
            proj.setdefault("optional-dependencies", {})[k] = v
    return proj


def _tag():
    impl = {"cpython": "cp"}.get(sys.implementation.name, sys.implementation.name)
    ver = f"{sys.version_info.major}{sys.version_info.minor}"
    plat = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    return f"{impl}{ver}", f"{impl}{ver}{getattr(sys, 'abiflags', '')}", plat


def _dist_info_name(proj):
    return f"{proj['name'].replace('-', '_')}-{proj['version']}"


def _metadata(proj):
    lines = ["Metadata-Version: 2.1", f"Name: {proj['name']}", f"Version: {proj['version']}",
             f"Summary: {proj.get('description', '')}"]
    if "requires-python" in proj:
        lines.append(f"Requires-Python: {proj['requires-python']}")
    for dep in proj.get("dependencies", []):
        lines.append(f"Requires-Dist: {dep}")
    for extra, deps in proj.get("optional-dependencies", {}).items():
        lines.append(f"Provides-Extra: {extra}")
        lines += [f'Requires-Dist: {d}; extra == "{extra}"' for d in deps]
    body = ""
    readme = os.path.join(ROOT, proj.get("readme", "README.md"))
    if os.path.exists(readme):
        lines.append("Description-Content-Type: text/markdown")
        body = "\n" + open(readme, encoding="utf-8").read()
    return "\n".join(lines) + "\n" + body


def _dist_info_files(proj):
    py, abi, plat = _tag()
    wheel = ("Wheel-Version: 1.0\nGenerator: tetopt_build (python/pep517)\nRoot-Is-Purelib: false\n"
             f"Tag: {py}-{abi}-{plat}\n")
    scripts = "".join(f"{k} = {v}\n" for k, v in proj.get("scripts", {}).items())
    return {"METADATA": _metadata(proj), "WHEEL": wheel, "entry_points.txt": "[console_scripts]\n" + scripts,
            "top_level.txt": "tetopt\n"}


# ---------------------------------------------------------------- PEP 517 hooks

def get_requires_for_build_wheel(config_settings=None):
    return []


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    proj = _project()
    name = _dist_info_name(proj) + ".dist-info"
    d = os.path.join(metadata_directory, name)
    os.makedirs(d, exist_ok=True)
    for fname, text in _dist_info_files(proj).items():
        with open(os.path.join(d, fname), "w", encoding="utf-8") as f:
            f.write(text)
    return name


def _run(cmd, **kw):
    sys.stderr.write("tetopt_build: " + " ".join(cmd) + "\n")
    subprocess.run(cmd, check=True, **kw)


def _build(build_dir):
    """Configures (when new) and builds the module, the program and the man page in build_dir."""
    if not os.path.exists(os.path.join(build_dir, "CMakeCache.txt")):
        args = ["cmake", "-S", ROOT, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release", "-DTETOPT_BUILD_TESTS=OFF",
                "-DTETOPT_BUILD_BENCH=OFF", "-DTETOPT_BUILD_MPI=OFF", "-DTETOPT_BUILD_SHARED=OFF",
                "-DTETOPT_BUILD_PYTHON=ON", f"-DPython_EXECUTABLE={sys.executable}"]
        # The HTML report's 3D view inlines three.js from node_modules (make
        # deps runs npm ci); a tree without it builds reports without the view.
        if not os.path.isdir(os.path.join(ROOT, "node_modules", "three")):
            sys.stderr.write("tetopt_build: no node_modules/three (make deps): HTML reports without the 3D view\n")
            args.append("-DTETOPT_VIEW3D=OFF")
        _run(args)
    env = dict(os.environ)
    env.setdefault("CMAKE_BUILD_PARALLEL_LEVEL", str(os.cpu_count() or 1))
    _run(["cmake", "--build", build_dir, "--target", "tetopt_python", "python", "tetopt_cli", "manpage"], env=env)
    suffixes = importlib.machinery.EXTENSION_SUFFIXES
    pkg = os.path.join(build_dir, "python", "tetopt")
    mods = [f for f in os.listdir(pkg) if f.startswith("_tetopt.") and any(f.endswith(s) for s in suffixes)]
    if not mods:
        found = [f for f in os.listdir(pkg) if f.startswith("_tetopt.")] if os.path.isdir(pkg) else []
        raise RuntimeError(f"{pkg}: no _tetopt module for this Python ({sys.executable}, suffixes {suffixes}); "
                           f"found {found or 'none'}: was {build_dir} configured for another interpreter, or "
                           "without pybind11-dev / python3-dev?")
    return {"module": os.path.join(pkg, mods[0]), "cli": os.path.join(build_dir, "tetopt"),
            "man": os.path.join(build_dir, "tetopt.1")}


def _record_hash(data):
    return "sha256=" + base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    proj = _project()
    build_dir = (config_settings or {}).get("build-dir") or os.environ.get("TETOPT_BUILD_DIR")
    tmp = None
    if not build_dir:
        tmp = tempfile.mkdtemp(prefix="tetopt-wheel-")
        build_dir = os.path.join(tmp, "build")
    build_dir = os.path.abspath(build_dir)
    try:
        art = _build(build_dir)
        py, abi, plat = _tag()
        base = _dist_info_name(proj)
        wheel_name = f"{base}-{py}-{abi}-{plat}.whl"
        files = []  # (name in the wheel, bytes, executable)
        src_pkg = os.path.join(ROOT, "python", "tetopt")
        for f in sorted(os.listdir(src_pkg)):
            if f.endswith((".py", ".pyi")) or f == "py.typed":
                files.append((f"tetopt/{f}", open(os.path.join(src_pkg, f), "rb").read(), False))
        files.append((f"tetopt/{os.path.basename(art['module'])}", open(art["module"], "rb").read(), False))
        files.append(("tetopt/_bin/tetopt", open(art["cli"], "rb").read(), True))
        files.append((f"{base}.data/data/share/man/man1/tetopt.1", open(art["man"], "rb").read(), False))
        for fname, text in _dist_info_files(proj).items():
            files.append((f"{base}.dist-info/{fname}", text.encode("utf-8"), False))
        record = "".join(f"{n},{_record_hash(b)},{len(b)}\n" for n, b, _ in files) + f"{base}.dist-info/RECORD,,\n"
        files.append((f"{base}.dist-info/RECORD", record.encode("utf-8"), False))
        os.makedirs(wheel_directory, exist_ok=True)
        path = os.path.join(wheel_directory, wheel_name)
        with zipfile.ZipFile(path + ".part", "w", compression=zipfile.ZIP_DEFLATED) as z:
            for n, b, exe in files:
                info = zipfile.ZipInfo(n, date_time=(1980, 1, 1, 0, 0, 0))
                info.compress_type = zipfile.ZIP_DEFLATED
                info.external_attr = ((0o755 if exe else 0o644) | 0o100000) << 16
                z.writestr(info, b)
        os.replace(path + ".part", path)
        return wheel_name
    finally:
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)
