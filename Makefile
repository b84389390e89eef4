# moa: the two commands of the README, and the steps they are made of.
#   make demo   set up, build, run the main job
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
# The core cross-compiled for a Cortex-M4F (embedded/): GCC, newlib, libstdc++.
DEBIAN_PACKAGES += gcc-arm-none-eabi libnewlib-arm-none-eabi libstdc++-arm-none-eabi-newlib

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
	else \
	  echo "moa: Debian packages present"; \
	fi

$(BUILD_DIR)/CMakeCache.txt:
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) $(CMAKE_FLAGS)

configure: deps $(BUILD_DIR)/CMakeCache.txt

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

DEMO_OUT ?= $(BUILD_DIR)/demo
demo: build
	@mkdir -p $(DEMO_OUT)
	$(MOA) odometry --config examples/logs/mixed-motion/robot.yaml \
	  --log examples/logs/mixed-motion --estimator ls --out $(DEMO_OUT)/odometry.csv
	$(MOA) evaluate --truth examples/logs/mixed-motion/truth.csv --odometry $(DEMO_OUT)/odometry.csv
	@echo "moa demo: odometry written to $(DEMO_OUT)/odometry.csv"
	@rm -rf $(DEMO_OUT)/sekimori-b  # simulate refuses a directory holding other files (a report)
	$(MOA) simulate --scenario sekimori-b --seed 1 --out $(DEMO_OUT)/sekimori-b
	$(MOA) odometry --config $(DEMO_OUT)/sekimori-b/robot.yaml --log $(DEMO_OUT)/sekimori-b \
	  --estimator consensus --out $(DEMO_OUT)/sekimori-b/odometry.csv
	$(MOA) evaluate --truth $(DEMO_OUT)/sekimori-b/truth.csv \
	  --odometry $(DEMO_OUT)/sekimori-b/odometry.csv
	@echo "moa demo: simulated log, its odometry and truth in $(DEMO_OUT)/sekimori-b"
	$(MOA) report --config $(DEMO_OUT)/sekimori-b/robot.yaml --log $(DEMO_OUT)/sekimori-b \
	  --odometry $(DEMO_OUT)/sekimori-b/odometry.csv --truth $(DEMO_OUT)/sekimori-b/truth.csv \
	  --out $(DEMO_OUT)/sekimori-b/report.html

clean:
	rm -rf $(BUILD_DIR)
