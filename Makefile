# Waymark entry points. `make run` and `make test` do all setup on a fresh Debian 12 machine.
BUILD_DIR ?= build
BUILD_TYPE ?= RelWithDebInfo
JOBS ?= $(shell nproc)
LISTEN ?= 127.0.0.1:50051
DB ?= ./var/waymark.db
# make run's Prometheus endpoint: loopback, a free port (the server's log names it); METRICS= is off.
METRICS ?= 127.0.0.1:0
CTEST_ARGS ?=

.PHONY: all deps peers-deps configure build run test bench demo docker-test fuzz clean

all: build

deps:
	./scripts/install-deps.sh

# Opt-in: MRPT's icp-slam for `bench/laser/laser_benchmark.sh --peers` (not needed by run or test).
peers-deps:
	./scripts/install-deps.sh --peers

$(BUILD_DIR)/build.ninja: CMakeLists.txt | deps
	cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=$(BUILD_TYPE)

configure: deps $(BUILD_DIR)/build.ninja

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

# The server on the embedded default database; stop it with Ctrl-C.
run: build
	@mkdir -p $(dir $(DB))
	@echo "Talk to it from another terminal:"
	@echo "  $(BUILD_DIR)/bin/waymark --server $(LISTEN) db create city"
	@echo "  $(BUILD_DIR)/bin/waymark --server $(LISTEN) enroll city DIR     # DIR/<crossing>/<heading>.jpg"
	@echo "  $(BUILD_DIR)/bin/waymark --server $(LISTEN) recognize city IMAGE.jpg"
	@echo "Listening on $(LISTEN), database $(DB); change them with make run LISTEN=HOST:PORT DB=FILE"
	@echo "(or DB=postgresql://USER@HOST:PORT/DBNAME). Metrics: $(if $(METRICS),the 'metrics at http://...' log line below gives the address (METRICS=127.0.0.1:9100 for a fixed port; METRICS= turns them off),off (METRICS=127.0.0.1:9100 turns them on))."
	$(BUILD_DIR)/bin/waymark-server --listen $(LISTEN) --db $(DB) --insecure-dev $(if $(METRICS),--metrics-listen $(METRICS))

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) $(CTEST_ARGS)

# The bench programs are not in the default build (make test does not need them).
bench: build
	cmake --build $(BUILD_DIR) -j $(JOBS) --target bench_programs
	./bench/run.sh $(BUILD_DIR)

# Enroll and query views cut from real 360-degree photos (Debian's blender-data), end to end.
demo: build
	cmake --build $(BUILD_DIR) -j $(JOBS) --target waymark-demo-data
	./scripts/demo.sh $(BUILD_DIR)

# Build the Docker image and smoke-test it with its own dockerd (root, Debian 12; docker/README.md).
docker-test:
	BUILD_DIR=$(BUILD_DIR) ./scripts/docker-test.sh

# Fuzzing with the sanitizers (docs/operations.md): waymark-fuzz alone, built with clang 14,
# AddressSanitizer, UndefinedBehaviorSanitizer and libFuzzer in its own directory (FUZZ_DIR,
# default build-fuzz), then every target coverage-guided for FUZZ_SECONDS (default 30) each.
fuzz: deps
	./scripts/fuzz.sh

clean:
	rm -rf $(BUILD_DIR)
