# One developer loop, used by CI too (.ci/run calls `make test`).
#   make example   build the CLI and render the bundled Cornell box
#   make test      build everything (Rust + Python package) and run every test
#   make lint      rustfmt, clippy -D warnings, rustdoc, ruff

VENV   := .venv
PYTHON := $(VENV)/bin/python
CARGO  ?= cargo

.PHONY: example build venv python test test-rust test-python lint bench-bvh clean

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

python: venv
	$(VENV)/bin/maturin develop --release --quiet

test-rust:
	$(CARGO) test --release --workspace --exclude wavrad-py

test-python: python
	$(PYTHON) -m pytest -q tests

test: test-rust test-python

lint: venv
	$(CARGO) fmt --all --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --workspace --no-deps --exclude wavrad-py
	$(VENV)/bin/pip install --quiet ruff && $(VENV)/bin/ruff check python tests scenes benches

bench-bvh:
	$(CARGO) run --release --manifest-path benches/bvh-choice/Cargo.toml

clean:
	rm -rf target out $(VENV)
