# corde_sim: convenience targets around the plain CMake build in ./build (see README).
#   make deps    install the Debian packages (scripts/install_deps.sh; fast when nothing is missing)
#   make build   deps + configure (first time) + incremental build of `all` and `tests`
#   make run     build (without the tests), then run the main job ($(RUN_CMD))
#   make test    build, then every test through ctest (unit tests and rostests)
#   make bench   build (without the tests), then the benchmarks
#   make charts  build corde_charts, run its full sweep into docs/charts/ and draw the PNGs
#                (minutes; docs/charts.md)
#   make format  clang-format over src, include, test
#   make clean   remove the build folder
SHELL := /bin/bash
.SHELLFLAGS := -o pipefail -c

BUILD_DIR  ?= build
BUILD_TYPE ?= Release
JOBS       ?= $(shell nproc 2>/dev/null || echo 2)
PYTHON     ?= /usr/bin/python3
CMAKE_ARGS ?=
# CORDE_WERROR=ON (CI) builds with warnings as errors.
ifdef CORDE_WERROR
  CMAKE_ARGS += -DCORDE_WERROR=$(CORDE_WERROR)
endif
CTEST_ARGS ?=
# The libFuzzer targets (label fuzz) are part of the project's own build and tests; CMake's
# option CORDE_FUZZ is off by default, so that a catkin workspace's `tests` skips them.
CORDE_FUZZ ?= ON
BENCH_ARGS ?=
# The main job: the node on its default scene, with rviz when a display is there (DISPLAY set).
RUN_CMD    ?= roslaunch corde_sim corde_sim.launch headless:=$(if $(DISPLAY),false,true)

# Puts the package on ROS_PACKAGE_PATH (rostest, roslaunch) when the ROS part was built. ROS
# python nodes start with `#!/usr/bin/env python3`: put the system python3 (which has rospy)
# first on PATH, ahead of pyenv/conda/venv interpreters.
SOURCE_DEVEL = export PATH="/usr/bin:$$PATH"; \
  if [ -f $(BUILD_DIR)/devel/setup.bash ]; then source $(BUILD_DIR)/devel/setup.bash; fi

.PHONY: all deps configure build build-main run test bench charts format clean

all: build

deps:
	@bash scripts/install_deps.sh

# Configure once; afterwards `cmake --build` re-runs CMake by itself when CMakeLists.txt or a
# globbed source folder changes.
$(BUILD_DIR)/CMakeCache.txt:
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) -DPYTHON_EXECUTABLE=$(PYTHON) \
	  -DCORDE_FUZZ=$(CORDE_FUZZ) $(CMAKE_ARGS)

configure: deps
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) -DPYTHON_EXECUTABLE=$(PYTHON) \
	  -DCORDE_FUZZ=$(CORDE_FUZZ) $(CMAKE_ARGS)

# Test executables are not part of `all` (catkin's convention, so that a catkin workspace does not
# compile them unless asked): `build` builds the `tests` target as well, so that ctest finds every
# test; `build-main` (for run and bench) only `all`.
build: deps
	@$(MAKE) --no-print-directory $(BUILD_DIR)/CMakeCache.txt
	@grep -q '^CORDE_FUZZ:BOOL=$(CORDE_FUZZ)$$' $(BUILD_DIR)/CMakeCache.txt \
	  || cmake -S . -B $(BUILD_DIR) -DCORDE_FUZZ=$(CORDE_FUZZ)
	cmake --build $(BUILD_DIR) -j$(JOBS) --target all tests -- --no-print-directory

build-main: deps
	@$(MAKE) --no-print-directory $(BUILD_DIR)/CMakeCache.txt
	cmake --build $(BUILD_DIR) -j$(JOBS) -- --no-print-directory

run: build-main
	$(SOURCE_DEVEL); $(RUN_CMD)

test: build
	$(SOURCE_DEVEL); cd $(BUILD_DIR) && ctest --output-on-failure $(CTEST_ARGS)

bench: build-main
	@if [ ! -x $(BUILD_DIR)/corde_bench ]; then echo "corde_bench is not built (src/tools/corde_bench.cpp missing?)"; exit 1; fi
	./$(BUILD_DIR)/corde_bench $(BENCH_ARGS)

charts: build-main
	@if [ ! -x $(BUILD_DIR)/corde_charts ]; then echo "corde_charts is not built"; exit 1; fi
	mkdir -p docs/charts
	./$(BUILD_DIR)/corde_charts --out docs/charts
	$(PYTHON) scripts/plot_charts.py docs/charts

format:
	@command -v clang-format >/dev/null || bash scripts/install_deps.sh
	find src include test \( -name '*.cpp' -o -name '*.h' -o -name '*.hpp' \) -print0 2>/dev/null \
	  | xargs -0 -r clang-format -i

clean:
	rm -rf $(BUILD_DIR)
