# dqn_dovs — every target does its own prerequisites, so each works as the first command on a fresh machine.
SHELL := /bin/bash
# Debian's python3 and ROS tools first: another python3 on PATH breaks catkin, rostest and roslaunch.
export PATH := /usr/bin:/bin:/usr/sbin:/sbin:$(PATH)
export PYTHONNOUSERSITE := 1
JOBS ?= 2
BENCHES := sim env tracker dovs inference training e2e eval-sdovs eval-dqn
SOAK_SECONDS ?= 3600

.PHONY: all setup build test check format-check test-cpp test-python bench demo clean format help soak fuzz test-asan
all: build
.PHONY: benchmark-table performance-report select-model

help:
	@echo "make setup   install Debian ROS 1 packages and the Python venv (idempotent)"
	@echo "make build   colcon build of the dqn_dovs package (+ the Python module)"
	@echo "make test    every test: gtest, rostest, Python, fuzz regressions + 40 s per fuzz target"
	@echo "make format-check  every C++ file formatted as .clang-format says (part of make test)"
	@echo "make check   the edit loop: build, the gtests that need no ROS master and the Python tests but the training smoke run and the sweep"
	@echo "make fuzz    libFuzzer targets (fuzz/), FUZZ_SECONDS=600 each (make fuzz FUZZ_TARGETS=scenario for one)"
	@echo "make test-asan  core gtests under AddressSanitizer + UBSan in build_asan/"
	@echo "make bench   every benchmark (make bench-NAME for one: $(BENCHES)), then docs/performance.md"
	@echo "make benchmark-table  results/benchmark/, then docs/benchmark.md from it: every method on the package's room scenarios (SCENARIOS=DIR: another set, e.g. the external RUMOR set, docs/external_benchmark.md; PAPER=CSV: the paper's table beside), tracker and perfect information, with the oracle and the bound (EPISODES=100, ORACLE=0 / BOUND=0 without them)"
	@echo "make benchmark-worlds  results/benchmark_worlds/, then docs/benchmark_worlds.md from it: every planner and the oracle on every building family at 4 / 8 / 12 people, under three protocols (headline mix, oblivious stress test, all attentive) (EPISODES=30, ORACLE=0 without the oracle, PROTOCOLS='headline' for one)"
	@echo "make select-model RUN=runs/NAME  rank a training run's snapshots on held-out generated scenarios"
	@echo "make demo    the ROS pipeline in simulation on the package's demo scenarios (WORLD=clutter: a building world with people)"
	@echo "make clean-clone-demo  clone the committed HEAD into an empty temporary folder and run make demo there (the repository stands alone)"
	@echo "make soak    the full pipeline in real time over random scenarios for SOAK_SECONDS (3600) s: crashes, RSS, deadlines"

setup:
	@bash scripts/setup.sh

build: setup
	@bash scripts/build.sh

test: build
	@bash scripts/run_tests.sh

check: build
	@bash scripts/check.sh

fuzz: build
	@FUZZ_SECONDS=$${FUZZ_SECONDS:-600} bash scripts/fuzz.sh $(FUZZ_TARGETS)

test-asan: setup
	@bash scripts/test_asan.sh

bench: build
	@set -e; for b in $(BENCHES); do $(MAKE) --no-print-directory bench-run-$$b; done
	@$(MAKE) --no-print-directory performance-report

# docs/performance.md from bench/results/ (what has not run is reported as not measured).
performance-report: setup
	@PYTHONPATH=$(CURDIR)/python MPLBACKEND=Agg .venv/bin/python -m dqn_dovs_py.performance_report --benches "$(BENCHES)"

benchmark-table: build
	@SCENARIOS="$(SCENARIOS)" PAPER="$(PAPER)" bash scripts/benchmark_table.sh

.PHONY: benchmark-worlds
benchmark-worlds: build
	@bash scripts/benchmark_worlds.sh

select-model: build
	@bash scripts/select_model.sh $(RUN)

bench-%: build
	@$(MAKE) --no-print-directory bench-run-$*

bench-run-%:
	@bash scripts/bench.sh $*

demo: build
	@WORLD="$(WORLD)" bash scripts/demo.sh

.PHONY: clean-clone-demo
clean-clone-demo:
	@bash scripts/clean_clone_demo.sh

soak: build
	@SOAK_SECONDS=$(SOAK_SECONDS) bash scripts/soak.sh

format:
	@find include src test bench tools fuzz \( -name '*.cpp' -o -name '*.h' \) -type f | xargs clang-format -i

format-check: setup
	@bash scripts/format_check.sh

clean:
	rm -rf build install log
