# penumbra — see README.md. `make ci` is exactly what .ci/run does.
CARGO ?= cargo

.PHONY: build test lint fmt bench demo schemas fuzz fuzz-c ci deps-check c-examples

build:
	$(CARGO) build --release

test:
	$(CARGO) test --workspace

lint:
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings

fmt:
	$(CARGO) fmt --all

# Benchmarks (criterion); figures are recorded in docs/benchmarks.md.
bench:
	$(CARGO) bench --bench tables
	$(CARGO) bench --bench spheres
	$(CARGO) bench --bench mrt
	$(CARGO) bench --bench shadows
	$(CARGO) bench --bench fiv
	$(CARGO) bench --bench mrt_level
	$(CARGO) bench --bench drt
	$(CARGO) bench --bench capi

# The README's first command: bake the demo config.
demo:
	$(CARGO) run --release -- bake bake-configs/demo.toml

# Regenerate the committed JSON Schema (a test fails when it is stale).
schemas:
	$(CARGO) run --release -- schema > schemas/bake-config.schema.json
	$(CARGO) run --release -- schema --level > schemas/mrt-level.schema.json
	$(CARGO) run --release -- schema --clutter > schemas/clutter.schema.json

# Fuzz the asset loader (needs cargo-fuzz; installs it). FUZZ_SECONDS=60 by default.
fuzz:
	bash fuzz/run.sh $${FUZZ_SECONDS:-60}

# Fuzz the single-header C reader with libFuzzer (clang; installed from Debian's packages when
# absent). FUZZ_SECONDS=60 by default. The differential mutation loop runs in `cargo test`.
fuzz-c:
	bash fuzz/run-c.sh $${FUZZ_SECONDS:-60}

# The C/C++ examples (examples/c, examples/cpp) against the C ABI's static library, built with
# the system compiler into target/c-examples/ (include/penumbra.h, include/penumbra_asset.h).
c-examples:
	bash .ci/c-examples.sh

deps-check:
	bash .ci/check-deps.sh

ci:
	bash .ci/run
