# moa: the two commands of the README, and the steps they are made of.
#   make demo   set up, build only the moa program (quietly, log in build/demo-build.log), run the demo
#   make test   set up, build, run every test
# Set-up installs the Debian packages the build needs, only when missing.

BUILD_DIR ?= build
BUILD_TYPE ?= Release
CMAKE_FLAGS ?=
JOBS ?= $(shell nproc)
MOA := $(BUILD_DIR)/bin/moa

DEBIAN_PACKAGES := g++ make cmake libeigen3-dev libyaml-cpp-dev libcli11-dev libfmt-dev \
                   libgtest-dev libgmock-dev libbenchmark-dev \
                   gcc-avr avr-libc binutils-avr simavr libsimavr-dev
# moa report: Chart.js, inlined into the page at build time; Chromium for its browser test.
DEBIAN_PACKAGES += libjs-chart.js chromium
# The Python module (pybind11, numpy), its tests (pytest) and example (matplotlib).
DEBIAN_PACKAGES += python3-dev pybind11-dev python3-numpy python3-pytest python3-matplotlib
# moa live --serve: the dashboard's HTTP server (a shared library; its flags come from pkg-config).
DEBIAN_PACKAGES += libcpp-httplib-dev pkgconf
# The core cross-compiled for a Cortex-M4F (embedded/): GCC, newlib, libstdc++.
DEBIAN_PACKAGES += gcc-arm-none-eabi libnewlib-arm-none-eabi libstdc++-arm-none-eabi-newlib
# ... and run on an emulated Cortex-M4F (mps2-an386) by the test embedded_qemu_odometry.
DEBIAN_PACKAGES += qemu-system-arm

# The libFuzzer targets of every reader (tests/fuzz/run.sh, a step of .ci/run): clang and its runtime.
DEBIAN_PACKAGES += clang libclang-rt-14-dev

# Under CI (CI=true) warnings are errors.
ifeq ($(CI),true)
CMAKE_FLAGS += -DMOA_WARNINGS_AS_ERRORS=ON
endif

SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: all deps configure build test demo clean

all: build

deps:
	@missing=""; \
	for p in $(DEBIAN_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "moa: installing Debian packages:$$missing"; \
	  $(SUDO) apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; \
	fi

$(BUILD_DIR)/CMakeCache.txt:
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) $(CMAKE_FLAGS)

configure: deps $(BUILD_DIR)/CMakeCache.txt

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

# The demo builds the moa program and the libraries it links, nothing else
# (no tests, benchmarks or firmware), and keeps the build's output in a file.
DEMO_OUT ?= $(BUILD_DIR)/demo
DEMO_LOG := $(BUILD_DIR)/demo-build.log
demo: deps
	@mkdir -p $(BUILD_DIR)
	@echo "moa demo: building the moa program (full log: $(DEMO_LOG))"
	@start=$$(date +%s); \
	{ $(MAKE) --no-print-directory $(BUILD_DIR)/CMakeCache.txt && \
	  cmake --build $(BUILD_DIR) -j $(JOBS) --target moa_cli; } > $(DEMO_LOG) 2>&1 || \
	{ tail -n 40 $(DEMO_LOG); echo "moa demo: the build failed; full log: $(DEMO_LOG)"; exit 1; }; \
	echo "moa demo: built in $$(( $$(date +%s) - start )) s"
	@sh examples/demo.sh $(MOA) $(DEMO_OUT)

clean:
	rm -rf $(BUILD_DIR)
