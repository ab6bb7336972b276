# tetopt — two commands on a fresh Debian 12 machine: `make demo`, `make test`.
# Everything else (deps, configure, build) happens on the way.

BUILD    ?= build
JOBS     ?= $(shell nproc 2>/dev/null || echo 2)
DEMO_SIZE ?= 1.0
PY       := /usr/bin/python3
TETOPT   := $(BUILD)/tetopt

# Debian 12 packages tetopt needs to build, test, demo and benchmark.
DEB_PKGS := build-essential cmake libcgal-dev libgmp-dev libmpfr-dev libboost-dev \
            libgtest-dev libbenchmark-dev zlib1g-dev gmsh tetgen openfoam calculix-ccx \
            python3 python3-numpy python3-scipy python3-meshio python3-pytest python3-gmsh \
            python3-dev pybind11-dev libtbb-dev clang libclang-rt-14-dev chromium libopenmpi-dev openmpi-bin libmetis-dev \
            nodejs python3-pip python3-venv pkgconf man-db libcgns-dev cgns-convert libexodusii-dev

.PHONY: all deps build demo test bench clean python fuzz test-sanitize

all: build

deps:
	@missing=""; for p in $(DEB_PKGS); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=""; elif command -v sudo >/dev/null; then SUDO=sudo; \
	  else echo "need root or sudo to install:$$missing" >&2; exit 1; fi; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq --no-install-recommends $$missing; \
	fi
	@# The HTML report's 3D view inlines three.js, and test_view3d.sh drives
	@# chromium with playwright-core: both pinned in package-lock.json.  npm ci
	@# runs only when node_modules is missing or older than the lockfile, so
	@# later builds work offline.  (npm: its own Debian package when node is
	@# Debian's; NodeSource's nodejs carries it.)
	@if [ ! -f node_modules/.package-lock.json ] || [ package-lock.json -nt node_modules/.package-lock.json ]; then \
	  command -v npm >/dev/null || { echo "make deps: npm not found (Debian: apt-get install npm)" >&2; exit 1; }; \
	  echo "npm ci (three.js, playwright-core; package-lock.json)"; npm ci --no-audit --no-fund; \
	fi

$(BUILD)/CMakeCache.txt: | deps
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release

build: deps $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS)

demo: build
	bash demo/run_demo.sh $(TETOPT) $(DEMO_SIZE)

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

bench: build
	bash bench/run_bench.sh $(BUILD)

python: build
	@echo "python module: $(BUILD)/python (PYTHONPATH=$(BUILD)/python /usr/bin/python3 -c 'import tetopt')"
	@echo "or install it: /usr/bin/python3 -m pip install . (docs/install.md)"

# libFuzzer targets (clang), each run for FUZZ_SECONDS; corpus in fuzz/corpus/.
FUZZ_SECONDS ?= 60
fuzz: deps
	bash fuzz/run.sh $(FUZZ_SECONDS)

# The whole test suite under AddressSanitizer + UndefinedBehaviorSanitizer.
test-sanitize: deps
	cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTETOPT_SANITIZE=ON -DTETOPT_BUILD_BENCH=OFF -DTETOPT_BUILD_PYTHON=OFF
	cmake --build build-asan -j $(JOBS)
	cd build-asan && ctest --output-on-failure -j $(JOBS) -E "script\\.test_(shared_meshes|python)"

clean:
	rm -rf $(BUILD)
