# One developer loop, used by CI too (.ci/run calls `make test`).
#   make example   build the CLI and render the bundled Cornell box
#   make test      lint, then build everything (Rust + Python package) and run every test
#   make lint      rustfmt, clippy -D warnings, rustdoc, ruff
#   make bench     wavrad against Mitsuba 3 end to end -> docs/benchmarks.md
#   make fuzz      every fuzz target, a million inputs each (nightly; docs/fuzzing.md)

VENV   := .venv
PYTHON := $(VENV)/bin/python
CARGO  ?= cargo

.PHONY: example build venv python test test-rust test-python lint llvm bench bench-bvh clean bench-micro profile fuzz

example: build
	mkdir -p out
	./target/release/wavrad render scenes/cornell-box/scene.xml -o out/cornell-box.png --stats out/cornell-box.json
	./target/release/wavrad render scenes/cornell-box/scene.xml -o out/cornell-box.exr
	./target/release/wavrad compare out/cornell-box.exr scenes/cornell-box/reference.exr

build:
	$(CARGO) build --release -p wavrad-cli

$(PYTHON):
	python3 -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --upgrade pip
	$(VENV)/bin/pip install --quiet "maturin>=1.5,<2" "pytest>=7" "numpy>=1.24"

venv: $(PYTHON)

# With the `distributed` extra (Ray, ~15 s to install) for wavrad.distributed
# and tests/test_distributed.py, which skips where Ray cannot be imported.
python: venv
	$(VENV)/bin/maturin develop --release --quiet --extras distributed

test-rust:
	$(CARGO) test --release --workspace --exclude wavrad-py

test-python: python
	$(PYTHON) -m pytest -q tests

test: lint test-rust test-python

lint: venv
	$(CARGO) fmt --all --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --workspace --no-deps --exclude wavrad-py
	$(VENV)/bin/pip install --quiet "ruff>=0.6,<1" && $(VENV)/bin/ruff check python tests scenes benches

# Mitsuba's llvm_ad_rgb variant (the one a user would time) needs libLLVM >= 17;
# Debian bookworm's is libllvm19 (as root, or set APT to "sudo apt-get").
APT ?= apt-get
llvm:
	@ls /usr/lib/*/libLLVM* 2>/dev/null | grep -Eq 'libLLVM(-|\.so\.)(1[7-9]|[2-9][0-9])' \
		|| $(APT) install -y --no-install-recommends libllvm19 \
		|| ($(APT) update && $(APT) install -y --no-install-recommends libllvm19)

bench: python llvm
	$(VENV)/bin/pip install --quiet -r benches/requirements.txt
	$(PYTHON) benches/benchmarks.py

bench-bvh:
	$(CARGO) run --release --manifest-path benches/bvh-choice/Cargo.toml

clean:
	rm -rf target out $(VENV)

# Criterion microbenchmarks of wavrad-core (docs/microbenchmarks.md): kernels,
# occlusion throughput raw vs via kernels, Gauss–Seidel sweep. A few minutes.
bench-micro:
	$(CARGO) bench -p wavrad-core --benches

# Sampled CPU profiles (docs/profile.md): the Cornell box render and the
# glossy Cornell box solve (kernels), with perf; reports go to out/.
PERF        ?= perf
PROFILE_BIN := $(or $(CARGO_TARGET_DIR),target)/profiling/wavrad
PERF_REPORT  = $(PERF) report --no-children --sort symbol --stdio -g none

profile:
	$(CARGO) build --profile profiling -p wavrad-cli
	mkdir -p out
	$(PERF) record -g -o out/perf-cornell-box.data $(PROFILE_BIN) render scenes/cornell-box/scene.xml -o out/profile-cornell-box.exr
	$(PERF_REPORT) -i out/perf-cornell-box.data > out/profile-cornell-box.txt
	$(PERF) record -F 999 -g -o out/perf-glossy-cornell-box.data $(PROFILE_BIN) solve scenes/glossy-cornell-box/scene.xml
	$(PERF_REPORT) -i out/perf-glossy-cornell-box.data > out/profile-glossy-cornell-box.txt
	grep -m 15 '%' out/profile-cornell-box.txt
	grep -m 15 '%' out/profile-glossy-cornell-box.txt

# Fuzzing (docs/fuzzing.md): each target of fuzz/ in turn, FUZZ_RUNS inputs
# each, one process at a time; what a run adds to the seed corpus goes to
# fuzz/corpus-run/, crashes to fuzz/artifacts/. Needs a nightly toolchain
# and `cargo install cargo-fuzz`; not part of `make test` (CI has stable
# only, and runs the committed corpora: crates/wavrad-io/tests/fuzz_corpus.rs).
# Inputs are written to files, in memory where /dev/shm is.
FUZZ_TARGETS ?= scene_xml obj ply serialized solution checkpoint
FUZZ_RUNS    ?= 1000000
# More libFuzzer options, e.g. -max_total_time=600.
FUZZ_OPTIONS ?=
FUZZ_TMPDIR  := $(if $(wildcard /dev/shm),/dev/shm,$(or $(TMPDIR),/tmp))

fuzz:
	cd fuzz && for t in $(FUZZ_TARGETS); do \
		mkdir -p corpus-run/$$t && \
		TMPDIR=$(FUZZ_TMPDIR) $(CARGO) +nightly fuzz run --sanitizer none --debug-assertions $$t \
			corpus-run/$$t corpus/$$t -- -runs=$(FUZZ_RUNS) -rss_limit_mb=2048 -timeout=10 \
			-print_final_stats=1 $$(test -f dict/$$t.dict && echo -dict=dict/$$t.dict) $(FUZZ_OPTIONS) || exit 1; \
	done
